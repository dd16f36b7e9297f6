"""Certificates near their end, for tests of renewal and of the warnings before it: a
certificate issued again by the kept CA, same subject, key and extensions, valid only a few
more days."""

from __future__ import annotations

import datetime
from pathlib import Path

from cryptography import x509
from cryptography.exceptions import InvalidSignature
from cryptography.hazmat.primitives import hashes, serialization

from motocell.shared.bus.certificates import load_authority


def expire_in(directory: Path, name: str, days: float) -> datetime.datetime:
    """``directory/name`` valid only ``days`` more days from now (its key still fits).
    Returns its new end."""
    authority = load_authority(directory)
    old = x509.load_pem_x509_certificate((directory / name).read_bytes())
    now = datetime.datetime.now(datetime.UTC).replace(microsecond=0)
    end = now + datetime.timedelta(days=days)
    builder = (
        x509.CertificateBuilder()
        .subject_name(old.subject)
        .issuer_name(old.issuer)
        .public_key(old.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(days=1))
        .not_valid_after(end)
    )
    for extension in old.extensions:
        builder = builder.add_extension(extension.value, extension.critical)
    certificate = builder.sign(authority.key, hashes.SHA256())
    (directory / name).write_bytes(certificate.public_bytes(serialization.Encoding.PEM))
    return end


def verifies(certificate_file: Path, ca_file: Path) -> bool:
    """Whether the CA in ``ca_file`` signed the certificate in ``certificate_file``."""
    certificate = x509.load_pem_x509_certificate(certificate_file.read_bytes())
    ca = x509.load_pem_x509_certificate(ca_file.read_bytes())
    try:
        certificate.verify_directly_issued_by(ca)
    except (ValueError, TypeError, InvalidSignature):
        return False
    return True
