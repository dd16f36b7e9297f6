"""TLS material for a cell's bus: a CA of its own, the router's certificate, and one client
certificate per identity (common name = its Zenoh username, which the access control can
match for mutual TLS). Everything is written next to the passwords, private to the user.

EC P-256 keys: small, fast handshakes. Certificates last a year and are renewed with the kept
CA (``motocell credentials DIR --renew``); the CA lasts ten, so that renewing a certificate
never means handing every host a new CA.
"""

from __future__ import annotations

import datetime
import ipaddress
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from motocell.shared.bus.access import Identity
from motocell.shared.bus.credentials import (
    CA_FILE,
    CA_KEY_FILE,
    CredentialsError,
    certificate_paths,
    check_private,
    read_credential,
    write_private,
)
from motocell.shared.bus.router import ROUTER_CERTIFICATE, ROUTER_KEY

LIFETIME = datetime.timedelta(days=365)
CA_LIFETIME = datetime.timedelta(days=3650)


@dataclass(frozen=True)
class Authority:
    """The CA that signs every certificate of a credentials directory."""

    certificate: x509.Certificate
    key: ec.EllipticCurvePrivateKey


def write_certificates(
    directory: Path, cell: str, identities: Sequence[Identity], hosts: Sequence[str]
) -> Authority:
    """A CA (its key kept), a router certificate valid for ``hosts`` (names or addresses the
    services dial), and a client certificate per identity, into ``directory``. Returns the
    CA."""
    authority = create_authority(directory, f"motocell {cell} CA")
    issue_router_certificate(directory, f"{cell}.router", hosts, authority)
    for identity in identities:
        issue_client_certificate(directory, identity.username(cell), authority)
    return authority


def create_authority(directory: Path, name: str) -> Authority:
    """A new CA called ``name``: its certificate ``ca.pem`` and its private key ``ca.key``."""
    key = ec.generate_private_key(ec.SECP256R1())
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)])
    certificate = (
        _builder(subject, subject, key.public_key(), CA_LIFETIME)
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .sign(key, hashes.SHA256())
    )
    write_private(directory / CA_FILE, certificate.public_bytes(serialization.Encoding.PEM))
    write_private(directory / CA_KEY_FILE, _private_bytes(key))
    return Authority(certificate, key)


def load_authority(directory: Path) -> Authority:
    """The CA kept in ``directory``; CredentialsError if its key is not there."""
    try:
        certificate = _certificate(directory / CA_FILE)
        check_private(directory / CA_KEY_FILE)
        key = serialization.load_pem_private_key(read_credential(directory / CA_KEY_FILE), None)
    except FileNotFoundError as missing:
        raise CredentialsError(
            f"{directory} has no CA to sign with ({Path(str(missing.filename)).name} missing): "
            "certificates are added in the directory `motocell credentials --tls` made, which "
            "keeps the CA's key; a directory without it needs new credentials for every party"
        ) from None
    if not isinstance(key, ec.EllipticCurvePrivateKey):
        raise CredentialsError(f"{directory / CA_KEY_FILE} is not an EC private key")
    return Authority(certificate, key)


def issue_client_certificate(
    directory: Path, common_name: str, authority: Authority | None = None
) -> tuple[Path, Path]:
    """A client certificate and key for ``common_name`` (a Zenoh username), signed by
    ``authority`` or else the CA kept in ``directory``, written as ``<common_name>.pem`` and
    ``.key`` there. Returns their paths."""
    files = certificate_paths(directory, common_name)
    _issue(files, common_name, authority or load_authority(directory), [])
    return files


def issue_router_certificate(
    directory: Path, common_name: str, hosts: Sequence[str], authority: Authority
) -> None:
    """The router's certificate, valid for the names and addresses in ``hosts``."""
    names = [_subject_name(host) for host in hosts]
    _issue((directory / ROUTER_CERTIFICATE, directory / ROUTER_KEY), common_name, authority, names)


def router_hosts(directory: Path) -> list[str]:
    """The names and addresses the router's certificate in ``directory`` is valid for."""
    return _hosts(_certificate(directory / ROUTER_CERTIFICATE))


def add_router_hosts(directory: Path, hosts: Sequence[str], authority: Authority) -> list[str]:
    """A new router certificate valid for its former names and ``hosts`` (and a new key), if
    any of them is new. Returns the names added."""
    certificate = _certificate(directory / ROUTER_CERTIFICATE)
    known = _hosts(certificate)
    added = [host for host in dict.fromkeys(hosts) if host not in known]
    if added:
        issue_router_certificate(directory, _common_name(certificate), known + added, authority)
    return added


def renew_certificates(
    directory: Path, within: datetime.timedelta, authority: Authority
) -> list[str]:
    """Every certificate of ``directory`` that expires within ``within`` from now issued again
    for a year (new keys; the same names, the CA and every password kept). Returns the file
    names renewed; CredentialsError if the CA itself expires in that window."""
    deadline = datetime.datetime.now(datetime.UTC) + within
    if authority.certificate.not_valid_after_utc <= deadline:
        raise CredentialsError(
            f"the CA of {directory} expires on "
            f"{authority.certificate.not_valid_after_utc:%Y-%m-%d}: every party needs new "
            "credentials from a new directory (`motocell credentials NEWDIR --tls`)"
        )
    renewed = []
    for path in sorted(directory.glob("*.pem")):
        certificate = _certificate(path)
        if path.name == CA_FILE or certificate.not_valid_after_utc > deadline:
            continue
        if path.name == ROUTER_CERTIFICATE:
            hosts = _hosts(certificate)
            issue_router_certificate(directory, _common_name(certificate), hosts, authority)
        else:
            issue_client_certificate(directory, _common_name(certificate), authority)
        renewed.append(path.name)
    return renewed


def _certificate(path: Path) -> x509.Certificate:
    return x509.load_pem_x509_certificate(read_credential(path))


def _common_name(certificate: x509.Certificate) -> str:
    (attribute,) = certificate.subject.get_attributes_for_oid(NameOID.COMMON_NAME)
    return str(attribute.value)


def _hosts(certificate: x509.Certificate) -> list[str]:
    names = certificate.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    return [str(name.value) for name in names]


def _issue(
    files: tuple[Path, Path],
    common_name: str,
    authority: Authority,
    alternative_names: list[x509.GeneralName],
) -> None:
    """A certificate and key for ``common_name`` into ``files``, signed by ``authority``; a
    server certificate when it has ``alternative_names``, else a client one."""
    certificate_file, key_file = files
    key = ec.generate_private_key(ec.SECP256R1())
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, common_name)])
    usage = (
        ExtendedKeyUsageOID.SERVER_AUTH if alternative_names else ExtendedKeyUsageOID.CLIENT_AUTH
    )
    builder = _builder(
        subject, authority.certificate.subject, key.public_key(), LIFETIME
    ).add_extension(x509.ExtendedKeyUsage([usage]), critical=False)
    if alternative_names:
        builder = builder.add_extension(
            x509.SubjectAlternativeName(alternative_names), critical=False
        )
    certificate = builder.sign(authority.key, hashes.SHA256())
    write_private(certificate_file, certificate.public_bytes(serialization.Encoding.PEM))
    write_private(key_file, _private_bytes(key))


def _private_bytes(key: ec.EllipticCurvePrivateKey) -> bytes:
    return key.private_bytes(
        serialization.Encoding.PEM,
        serialization.PrivateFormat.PKCS8,
        serialization.NoEncryption(),
    )


def _builder(
    subject: x509.Name,
    issuer: x509.Name,
    public_key: ec.EllipticCurvePublicKey,
    lifetime: datetime.timedelta,
) -> x509.CertificateBuilder:
    now = datetime.datetime.now(datetime.UTC)
    return (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(issuer)
        .public_key(public_key)
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5))
        .not_valid_after(now + lifetime)
    )


def _subject_name(host: str) -> x509.GeneralName:
    try:
        return x509.IPAddress(ipaddress.ip_address(host))
    except ValueError:
        return x509.DNSName(host)
