"""``motocell credentials``: a cell's passwords (and TLS material) in a private directory, which
a router and the cell's parties then use as they are."""

from __future__ import annotations

import stat
from pathlib import Path

import pytest
import zenoh
from cryptography import x509
from cryptography.exceptions import InvalidSignature

from motocell.shared.bus.access import Identity, cell_identities
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.certificates import issue_client_certificate
from motocell.shared.bus.credentials import load
from motocell.shared.bus.router import router_settings, zenoh_config
from motocell.shared.bus.session import open_session
from motocell.shared.ports import free_port
from motocell.tools.cli import build_parser

DUAL_ARM = Path(__file__).resolve().parents[2] / "shared" / "cells" / "dual-arm-positioner.toml"


def motocell(*argv: str) -> int:
    args = build_parser().parse_args(argv)
    status: int = args.run(args)
    return status


def mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


def test_a_password_per_identity_of_the_cell_in_a_private_directory(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    directory = tmp_path / "new" / "credentials"
    assert motocell("credentials", str(directory), "--config", str(DUAL_ARM)) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"wrote the credentials of cell dual into {directory}")
    assert f"--cell dual --credentials {directory}" in out
    assert mode(directory) == 0o700
    assert all(mode(path) == 0o600 for path in directory.iterdir())
    identities = cell_identities(3)
    assert {path.name for path in directory.iterdir()} == {
        "users",
        *(f"{identity.username('dual')}.password" for identity in identities),
    }
    users = (directory / "users").read_text().splitlines()
    assert [line.split(":")[0] for line in users] == [i.username("dual") for i in identities]


def test_the_router_made_from_the_directory_lets_its_observer_in(tmp_path: Path) -> None:
    assert motocell("credentials", str(tmp_path / "c"), "--cell", "lab") == 0
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    settings = router_settings(
        [endpoint], cell="lab", identities=cell_identities(1), credentials=tmp_path / "c"
    )
    router = zenoh.open(zenoh_config(settings))
    try:
        observer = load(tmp_path / "c", "lab", Identity(Role.OBSERVER))
        assert observer.user == "lab.observer"
        open_session("client", [endpoint], wait=False, credentials=observer).close()
    finally:
        router.close()


def test_with_tls_a_ca_a_router_certificate_for_the_hosts_and_one_per_identity(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    directory = tmp_path / "c"
    argv = ["credentials", str(directory), "--cell", "lab", "--tls", "--host", "127.0.0.1"]
    assert motocell(*argv, "--host", "robot-pc") == 0
    router = x509.load_pem_x509_certificate((directory / "router.pem").read_bytes())
    names = router.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert names.get_values_for_type(x509.DNSName) == ["robot-pc"]
    assert [str(a) for a in names.get_values_for_type(x509.IPAddress)] == ["127.0.0.1"]
    for identity in cell_identities(1):
        assert (directory / f"{identity.username('lab')}.pem").is_file()
        assert mode(directory / f"{identity.username('lab')}.key") == 0o600
    assert mode(directory / "ca.key") == 0o600

    endpoint = f"tls/127.0.0.1:{free_port()}"
    settings = router_settings(
        [endpoint],
        cell="lab",
        identities=cell_identities(1),
        credentials=directory,
        mutual_tls=True,
    )
    operator = load(directory, "lab", Identity(Role.OPERATOR))
    assert operator.certificate is not None and operator.ca is not None
    router_session = zenoh.open(zenoh_config(settings))
    try:
        capsys.readouterr()
        # As the command's own usage line says, on this test's port.
        assert (
            motocell(
                "ps", "--zenoh-connect", endpoint, "--cell", "lab", "--credentials", str(directory)
            )
            == 0
        )
        assert capsys.readouterr().out.startswith("no motocell service is live on cell lab")
    finally:
        router_session.close()


@pytest.mark.parametrize(
    ("extra", "problem"),
    [
        (["--host", "robot-pc"], "--host names the router in its TLS certificate: add --tls"),
        (["--cell", "a/b"], "name: 'a/b' must be letters, digits, - or _"),
        (["--config", "/nonexistent.toml"], "/nonexistent.toml"),
    ],
)
def test_arguments_that_cannot_work_write_nothing(
    extra: list[str], problem: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert motocell("credentials", str(tmp_path / "c"), *extra) == 2
    assert problem in capsys.readouterr().err
    assert not (tmp_path / "c").exists()


def test_a_directory_with_files_in_it_is_left_alone(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "notes.txt").write_text("mine")
    assert motocell("credentials", str(tmp_path)) == 2
    assert "exists and holds no credentials" in capsys.readouterr().err
    assert [path.name for path in tmp_path.iterdir()] == ["notes.txt"]


def contents(directory: Path) -> dict[str, bytes]:
    return {path.name: path.read_bytes() for path in directory.iterdir() if path.is_file()}


def verifies(certificate_file: Path, ca_file: Path) -> bool:
    """Whether the CA in ``ca_file`` signed the certificate in ``certificate_file``."""
    certificate = x509.load_pem_x509_certificate(certificate_file.read_bytes())
    ca = x509.load_pem_x509_certificate(ca_file.read_bytes())
    try:
        certificate.verify_directly_issued_by(ca)
    except (ValueError, TypeError, InvalidSignature):
        return False
    return True


def test_a_second_cell_joins_the_directory_signed_by_the_same_ca_touching_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    directory = tmp_path / "site"
    assert motocell("credentials", str(directory), "--cell", "one", "--tls") == 0
    before = contents(directory)
    capsys.readouterr()
    assert motocell("credentials", str(directory), "--config", str(DUAL_ARM)) == 0
    assert capsys.readouterr().out.startswith(f"added to {directory}, signed by its CA")
    after = contents(directory)
    assert {name: after[name] for name in before if name != "users"} == {
        name: content for name, content in before.items() if name != "users"
    }
    assert after["users"].startswith(before["users"])
    for identity in cell_identities(3):
        user = identity.username("dual")
        assert verifies(directory / f"{user}.pem", directory / "ca.pem")
        assert mode(directory / f"{user}.key") == 0o600
        assert load(directory, "dual", identity).certificate == directory / f"{user}.pem"

    # Again: nothing to add, nothing written.
    assert motocell("credentials", str(directory), "--config", str(DUAL_ARM)) == 0
    assert "nothing added" in capsys.readouterr().out
    assert contents(directory) == after


def test_an_identity_added_later_joins_a_router_of_the_first_files(tmp_path: Path) -> None:
    """The router's certificate and dictionary from the first run, an observer certificate
    issued afterwards by the kept CA: mutual TLS accepts it."""
    directory = tmp_path / "c"
    assert motocell("credentials", str(directory), "--cell", "lab", "--tls") == 0
    (directory / "lab.observer.pem").unlink()
    issue_client_certificate(directory, "lab.observer")
    endpoint = f"tls/127.0.0.1:{free_port()}"
    settings = router_settings(
        [endpoint],
        cell="lab",
        identities=cell_identities(1),
        credentials=directory,
        mutual_tls=True,
    )
    router = zenoh.open(zenoh_config(settings))
    try:
        observer = load(directory, "lab", Identity(Role.OBSERVER))
        open_session("client", [endpoint], wait=False, credentials=observer).close()
    finally:
        router.close()


def test_certificates_are_not_added_without_the_ca_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    directory = tmp_path / "c"
    assert motocell("credentials", str(directory), "--cell", "lab", "--tls") == 0
    (directory / "ca.key").unlink()
    before = contents(directory)
    assert motocell("credentials", str(directory), "--cell", "other") == 2
    assert "has no CA to sign with (ca.key missing)" in capsys.readouterr().err
    assert contents(directory) == before


def test_tls_is_not_added_to_a_directory_of_passwords(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert motocell("credentials", str(tmp_path / "c"), "--cell", "lab") == 0
    before = contents(tmp_path / "c")
    assert motocell("credentials", str(tmp_path / "c"), "--cell", "lab", "--tls") == 2
    assert "holds passwords only" in capsys.readouterr().err
    assert contents(tmp_path / "c") == before
