"""A certificate's end read without a TLS library, and the warning a credentials directory
gets when one ends within 30 days."""

from __future__ import annotations

import contextlib
import datetime
import io
from pathlib import Path

import pytest
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID

from motocell.shared.bus.expiry import expiring, not_after, warnings
from motocell.tools.cli import build_parser
from tests.certificates import expire_in

NOW = datetime.datetime.now(datetime.UTC)


def tls_directory(directory: Path) -> Path:
    args = build_parser().parse_args(["credentials", str(directory), "--cell", "lab", "--tls"])
    with contextlib.redirect_stdout(io.StringIO()):
        assert args.run(args) == 0
    return directory


def self_signed(end: datetime.datetime) -> bytes:
    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "an issuer")])
    certificate = (
        x509.CertificateBuilder()
        .subject_name(name)
        .issuer_name(name)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(datetime.datetime(2020, 1, 1, tzinfo=datetime.UTC))
        .not_valid_after(end)
        .sign(key, hashes.SHA256())
    )
    return certificate.public_bytes(serialization.Encoding.PEM)


def test_every_certificate_motocell_writes_reads_as_cryptography_reads_it(tmp_path: Path) -> None:
    directory = tls_directory(tmp_path / "c")
    pems = sorted(directory.glob("*.pem"))
    assert len(pems) > 5
    for path in pems:
        expected = x509.load_pem_x509_certificate(path.read_bytes()).not_valid_after_utc
        assert not_after(path.read_bytes()) == expected, path.name


@pytest.mark.parametrize(
    "end",
    [
        datetime.datetime(2031, 7, 4, 12, 30, 5, tzinfo=datetime.UTC),  # a UTCTime
        datetime.datetime(2051, 1, 2, 3, 4, 5, tzinfo=datetime.UTC),  # a GeneralizedTime
    ],
)
def test_both_encodings_of_a_time(end: datetime.datetime) -> None:
    assert not_after(self_signed(end)) == end


@pytest.mark.parametrize(
    "text",
    [b"", b"hello", b"-----BEGIN CERTIFICATE-----\nAAAA\n-----END CERTIFICATE-----\n"],
)
def test_what_is_no_certificate_is_a_value_error(text: bytes) -> None:
    with pytest.raises(ValueError, match="not a PEM certificate"):
        not_after(text)


def test_only_what_ends_within_30_days_soonest_first(tmp_path: Path) -> None:
    directory = tls_directory(tmp_path / "c")
    gateway = expire_in(directory, "lab.gateway.pem", 20)
    router = expire_in(directory, "router.pem", 3)
    expire_in(directory, "lab.observer.pem", 31)
    (directory / "notes.pem").write_text("not a certificate")
    assert expiring(directory, NOW) == [("router.pem", router), ("lab.gateway.pem", gateway)]


def test_one_line_per_directory_with_what_ends_and_how_to_renew(tmp_path: Path) -> None:
    ending = tls_directory(tmp_path / "ending")
    fine = tls_directory(tmp_path / "fine")
    end = expire_in(ending, "lab.observer.pem", -1)
    (line,) = warnings([ending, fine, ending], NOW)
    assert line.startswith(f"certificates of {ending} end within 30 days: lab.observer.pem ")
    assert f"expired {end:%Y-%m-%d %H:%M} UTC" in line
    assert "motocell credentials DIR --renew" in line
    assert warnings([fine, tmp_path / "absent"], NOW) == []
