"""``motocell credentials``: a cell's passwords (and TLS material) in a private directory, which
a router and the cell's parties then use as they are."""

from __future__ import annotations

import datetime
import stat
from pathlib import Path

import pytest
import zenoh
from cryptography import x509

from motocell.shared.bus.access import Identity, cell_identities
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.certificates import issue_client_certificate
from motocell.shared.bus.credentials import load
from motocell.shared.bus.router import router_settings, zenoh_config
from motocell.shared.bus.session import open_session
from motocell.testing.ports import listening
from motocell.tools.cli import build_parser
from tests.certificates import expire_in, verifies
from tests.routers import mutual_tls_router

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
    assert f"--cell dual --credentials {directory}/bundles/dual.observer" in out
    assert mode(directory) == 0o700
    assert all(mode(path) == 0o600 for path in directory.iterdir() if path.is_file())
    identities = cell_identities(3)
    assert {path.name for path in directory.iterdir()} == {
        "users",
        "bundles",
        *(f"{identity.username('dual')}.password" for identity in identities),
    }
    users = (directory / "users").read_text().splitlines()
    assert [line.split(":")[0] for line in users] == [i.username("dual") for i in identities]


def test_the_router_made_from_the_directory_lets_its_observer_in(tmp_path: Path) -> None:
    assert motocell("credentials", str(tmp_path / "c"), "--cell", "lab") == 0

    def open_router(endpoint: str) -> zenoh.Session:
        settings = router_settings(
            [endpoint], cell="lab", identities=cell_identities(1), credentials=tmp_path / "c"
        )
        return zenoh.open(zenoh_config(settings))

    endpoint, router = listening(open_router)
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

    operator = load(directory, "lab", Identity(Role.OPERATOR))
    assert operator.certificate is not None and operator.ca is not None

    endpoint, router_session = mutual_tls_router(directory, "lab")
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
        (["--renew"], "holds no credentials to renew"),
        (["--cell", "site"], "a cell named site gets no credentials"),
        (["--config", "/dev/zero"], "/dev/zero is not a regular file (a device)"),
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
    """Every file under ``directory``, by its path there."""
    return {
        str(path.relative_to(directory)): path.read_bytes()
        for path in directory.rglob("*")
        if path.is_file()
    }


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
    dictionaries = ("users", "bundles/router/users")
    assert {name: after[name] for name in before if name not in dictionaries} == {
        name: content for name, content in before.items() if name not in dictionaries
    }
    for name in dictionaries:
        assert after[name].startswith(before[name]) and after[name] != before[name]
    for identity in cell_identities(3):
        user = identity.username("dual")
        assert verifies(directory / f"{user}.pem", directory / "ca.pem")
        assert mode(directory / f"{user}.key") == 0o600
        assert load(directory, "dual", identity).certificate == directory / f"{user}.pem"

    # Again: nothing to add, nothing written.
    assert motocell("credentials", str(directory), "--config", str(DUAL_ARM)) == 0
    assert "nothing added" in capsys.readouterr().out
    assert contents(directory) == after


def test_a_second_cell_s_identities_join_a_router_of_the_shared_directory(
    tmp_path: Path,
) -> None:
    """The second cell's router from the same files (its bundle, restarted after the
    addition): its observer's certificate, from the first cell's CA, is accepted."""
    directory = tmp_path / "site"
    assert motocell("credentials", str(directory), "--cell", "one", "--tls") == 0
    assert motocell("credentials", str(directory), "--cell", "two") == 0

    def open_router(endpoint: str) -> zenoh.Session:
        settings = router_settings(
            [endpoint],
            cell="two",
            identities=cell_identities(1),
            credentials=directory / "bundles" / "router",
            mutual_tls=True,
        )
        return zenoh.open(zenoh_config(settings))

    endpoint, router = listening(open_router, "tls")
    try:
        bundle = directory / "bundles" / "two.observer"
        observer = load(bundle, "two", Identity(Role.OBSERVER))
        open_session("client", [endpoint], wait=False, credentials=observer).close()
    finally:
        router.close()


def test_an_identity_added_later_joins_a_router_of_the_first_files(tmp_path: Path) -> None:
    """The router's certificate and dictionary from the first run, an observer certificate
    issued afterwards by the kept CA: mutual TLS accepts it."""
    directory = tmp_path / "c"
    assert motocell("credentials", str(directory), "--cell", "lab", "--tls") == 0
    (directory / "lab.observer.pem").unlink()
    issue_client_certificate(directory, "lab.observer")

    endpoint, router = mutual_tls_router(directory, "lab")
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


def test_each_bundle_holds_its_party_s_files_and_never_the_ca_key(tmp_path: Path) -> None:
    directory = tmp_path / "c"
    assert motocell("credentials", str(directory), "--cell", "lab", "--tls") == 0
    bundles = directory / "bundles"
    users = [identity.username("lab") for identity in cell_identities(1)]
    assert {path.name for path in bundles.iterdir()} == {"router", *users}
    for user in users:
        files = {path.name for path in (bundles / user).iterdir()}
        assert files == {f"{user}.password", f"{user}.pem", f"{user}.key", "ca.pem"}
    assert {path.name for path in (bundles / "router").iterdir()} == {
        "users",
        "ca.pem",
        "router.pem",
        "router.key",
    }
    for path in bundles.rglob("*"):
        assert mode(path) == (0o700 if path.is_dir() else 0o600), path
        assert path.name != "ca.key"
        if path.is_file():
            assert path.read_bytes() == (directory / path.name).read_bytes()
    assert mode(directory / "ca.key") == 0o600


def test_a_router_and_an_observer_with_only_their_bundles_meet(tmp_path: Path) -> None:
    directory = tmp_path / "c"
    assert motocell("credentials", str(directory), "--cell", "lab", "--tls") == 0

    def open_router(endpoint: str) -> zenoh.Session:
        settings = router_settings(
            [endpoint],
            cell="lab",
            identities=cell_identities(1),
            credentials=directory / "bundles" / "router",
            mutual_tls=True,
        )
        return zenoh.open(zenoh_config(settings))

    endpoint, router = listening(open_router, "tls")
    try:
        bundle = directory / "bundles" / "lab.observer"
        observer = load(bundle, "lab", Identity(Role.OBSERVER))
        assert observer.certificate is not None and observer.ca == bundle / "ca.pem"
        open_session("client", [endpoint], wait=False, credentials=observer).close()
    finally:
        router.close()


def test_an_identity_of_no_cell_gets_a_password_and_a_certificate_of_the_ca(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    directory = tmp_path / "site"
    assert motocell("credentials", str(directory), "--cell", "one", "--tls") == 0
    capsys.readouterr()
    assert motocell("credentials", str(directory), "--identity", "site.observer") == 0
    assert "site.observer" in capsys.readouterr().out
    assert "site.observer:" in (directory / "users").read_text()
    assert verifies(directory / "site.observer.pem", directory / "ca.pem")
    assert {path.name for path in (directory / "bundles" / "site.observer").iterdir()} == {
        "site.observer.password",
        "site.observer.pem",
        "site.observer.key",
        "ca.pem",
    }
    assert not (directory / "cell1.observer.password").exists()  # no cell named: none added


@pytest.mark.cell  # a refused TLS session waits: tests/lanes.py
def test_a_host_added_makes_the_router_reachable_by_that_name(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    directory = tmp_path / "c"
    argv = ["credentials", str(directory), "--cell", "lab"]
    assert motocell(*argv, "--tls", "--host", "127.0.0.1") == 0
    before = contents(directory)

    def open_router(endpoint: str) -> zenoh.Session:
        settings = router_settings(
            [endpoint],
            cell="lab",
            identities=cell_identities(1),
            credentials=directory,
            mutual_tls=True,
        )
        return zenoh.open(zenoh_config(settings))

    def observer_joins_by_name() -> bool:
        endpoint, router = listening(open_router, "tls")
        port = endpoint.rsplit(":", 1)[1]
        try:
            observer = load(directory, "lab", Identity(Role.OBSERVER))
            open_session("client", [f"tls/localhost:{port}"], wait=False, credentials=observer)
        except ConnectionError:
            return False
        else:
            return True
        finally:
            router.close()

    assert not observer_joins_by_name()
    capsys.readouterr()
    assert motocell(*argv, "--host", "localhost", "--host", "127.0.0.1") == 0
    assert "now also valid for localhost" in capsys.readouterr().out
    router = x509.load_pem_x509_certificate((directory / "router.pem").read_bytes())
    names = router.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert names.get_values_for_type(x509.DNSName) == ["localhost"]
    assert verifies(directory / "router.pem", directory / "ca.pem")
    after = contents(directory)
    changed = {name for name in after if after[name] != before.get(name)}
    assert changed == {
        "router.pem",
        "router.key",
        "bundles/router/router.pem",
        "bundles/router/router.key",
    }
    assert observer_joins_by_name()


def test_renewal_reissues_only_what_expires_within_the_window(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    directory = tmp_path / "c"
    assert motocell("credentials", str(directory), "--cell", "lab", "--tls") == 0
    expire_in(directory, "lab.gateway.pem", 20)
    expire_in(directory, "router.pem", 40)
    motocell("credentials", str(directory))  # the bundles, as they would be
    before = contents(directory)
    capsys.readouterr()

    assert motocell("credentials", str(directory), "--renew") == 0
    assert "renewed for a year (expiring within 30 days): lab.gateway" in capsys.readouterr().out
    after = contents(directory)
    changed = {name for name in after if after[name] != before[name]}
    gateway = {"lab.gateway.pem", "lab.gateway.key"}
    assert changed == gateway | {f"bundles/lab.gateway/{name}" for name in gateway}
    certificate = x509.load_pem_x509_certificate(after["lab.gateway.pem"])
    remaining = certificate.not_valid_after_utc - datetime.datetime.now(datetime.UTC)
    assert remaining > datetime.timedelta(days=364)
    assert certificate.subject == x509.load_pem_x509_certificate(before["lab.gateway.pem"]).subject
    assert verifies(directory / "lab.gateway.pem", directory / "ca.pem")

    assert motocell("credentials", str(directory), "--renew", "--within", "45") == 0
    assert "renewed for a year (expiring within 45 days): router" in capsys.readouterr().out
    router = x509.load_pem_x509_certificate((directory / "router.pem").read_bytes())
    names = router.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert names.get_values_for_type(x509.DNSName) == ["localhost"]

    renewed = contents(directory)
    assert motocell("credentials", str(directory), "--renew") == 0
    assert "nothing renewed" in capsys.readouterr().out
    assert contents(directory) == renewed


def test_renewal_stops_at_a_ca_that_expires_within_the_window(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    directory = tmp_path / "c"
    assert motocell("credentials", str(directory), "--cell", "lab", "--tls") == 0
    before = contents(directory)
    assert motocell("credentials", str(directory), "--renew", "--within", "4000") == 2
    assert "the CA of" in capsys.readouterr().err
    assert contents(directory) == before


@pytest.mark.parametrize(
    ("argv", "problem"),
    [
        (["--within", "3"], "--within says what --renew renews: add --renew"),
        (["--renew", "--cell", "x"], "--renew goes alone"),
        (["--identity", "a b"], "--identity 'a b': a Zenoh username"),
        (["--identity", "router"], "not 'router'"),
        (["--identity", "lab.router"], "--identity lab.router: a name ending in .router is"),
        (["--identity", "site.router"], "a client named so would pass for a router"),
        (["--host", "robot-pc"], "holds passwords only, so --host cannot be added"),
        (["--renew"], "holds passwords only: they do not expire"),
        (["--cell", "site"], "its usernames (site.observer, ...) are the site's own"),
    ],
)
def test_what_cannot_be_done_to_a_directory_leaves_it_alone(
    argv: list[str], problem: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert motocell("credentials", str(tmp_path / "c"), "--cell", "lab") == 0
    before = contents(tmp_path / "c")
    assert motocell("credentials", str(tmp_path / "c"), *argv) == 2
    assert problem in capsys.readouterr().err
    assert contents(tmp_path / "c") == before


def test_a_new_directory_takes_identities_of_no_cell_too(tmp_path: Path) -> None:
    directory = tmp_path / "c"
    argv = ["--identity", "site.observer", "--identity", "lab.observer"]
    assert motocell("credentials", str(directory), "--cell", "lab", "--tls", *argv) == 0
    users = [line.split(":")[0] for line in (directory / "users").read_text().splitlines()]
    assert users.count("lab.observer") == 1 and users[-1] == "site.observer"
    assert verifies(directory / "site.observer.pem", directory / "ca.pem")
    assert (directory / "bundles" / "site.observer" / "site.observer.key").is_file()
