"""``motocell site``: one router's configuration for several cells, from the site's credentials
directory; what it refuses, in one line each."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from motocell.shared.bus.access import SITE_OBSERVER, SITE_ROUTER, cell_identities
from motocell.shared.bus.bundles import ROUTER_BUNDLE, bundle_path
from motocell.shared.bus.certificates import issue_client_certificate, write_certificates
from motocell.shared.bus.credentials import add_passwords, password_path, write_passwords
from motocell.shared.bus.router import zenoh_config
from motocell.tools.cli import main
from motocell.tools.site import SiteCell, site_router_settings

CELLS = [SiteCell("arm", 1), SiteCell("pair", 2)]


def credentials(directory: Path, tls: bool) -> Path:
    """Both cells' identities in one directory (under one CA with ``tls``)."""
    identities = {cell.name: cell_identities(cell.groups) for cell in CELLS}
    write_passwords(directory, "arm", identities["arm"])
    if tls:
        write_certificates(directory, "arm", identities["arm"], ["127.0.0.1"])
    added = add_passwords(directory, [i.username("pair") for i in identities["pair"]])
    if tls:
        for user in added:
            issue_client_certificate(directory, user)
    return directory


def test_a_site_router_serves_every_cell_the_site_observer_and_the_mesh(tmp_path: Path) -> None:
    directory = credentials(tmp_path, tls=True)
    settings = site_router_settings(directory, CELLS, ["tls/127.0.0.1:0"], ["tls/127.0.0.1:1"])
    subjects = {subject["id"]: subject for subject in settings["access_control"]["subjects"]}
    assert SITE_OBSERVER in subjects and SITE_ROUTER in subjects
    assert {"arm.gateway", "pair.interpolator-1", "pair.observer"} <= set(subjects)
    by_name = [s for s in subjects.values() if "usernames" in s]
    assert all(s["cert_common_names"] == s["usernames"] for s in by_name)
    # The one subject known by certificate alone: a router this one connects to.
    assert [s["id"] for s in subjects.values() if "usernames" not in s] == ["arm.router"]
    for user in (SITE_OBSERVER, SITE_ROUTER):
        assert password_path(directory, user).is_file()
        assert (directory / f"{user}.pem").is_file()
    tls = settings["transport"]["link"]["tls"]
    assert tls["enable_mtls"] and tls["connect_certificate"].endswith(f"{SITE_ROUTER}.pem")
    assert settings["transport"]["auth"]["usrpwd"]["user"] == SITE_ROUTER
    zenoh_config(settings)  # Zenoh takes every field


def test_a_router_that_dials_no_other_knows_no_party_by_its_certificate_alone(
    tmp_path: Path,
) -> None:
    directory = credentials(tmp_path, tls=True)
    settings = site_router_settings(directory, CELLS, ["tls/127.0.0.1:0"], [])
    subjects = settings["access_control"]["subjects"]
    assert SITE_ROUTER in {subject["id"] for subject in subjects}
    for subject in subjects:
        assert subject["usernames"] == subject["cert_common_names"] == [subject["id"]], subject


@pytest.mark.parametrize("connect", [[], ["tls/127.0.0.1:1"]])
@pytest.mark.parametrize("kind", ["certificate", "password"])
def test_a_directory_with_a_client_named_like_its_router_is_refused(
    tmp_path: Path, connect: list[str], kind: str
) -> None:
    directory = credentials(tmp_path, tls=True)
    if kind == "certificate":
        issue_client_certificate(directory, "arm.router")
    else:
        add_passwords(directory, ["arm.router"])
    with pytest.raises(ValueError, match=r"a client identity named like its router \(arm.router"):
        site_router_settings(directory, CELLS, ["tls/127.0.0.1:0"], connect)


def test_a_password_only_site_names_users_alone_and_links_no_router(tmp_path: Path) -> None:
    """A mesh needs TLS (test_what_cannot_be_served_is_refused)."""
    settings = site_router_settings(
        credentials(tmp_path, tls=False), CELLS, ["tcp/127.0.0.1:0"], []
    )
    subjects = settings["access_control"]["subjects"]
    assert not any("cert_common_names" in subject for subject in subjects)
    assert SITE_ROUTER not in {subject["id"] for subject in subjects}
    assert "tls" not in settings["transport"]["link"]


@pytest.mark.parametrize(
    ("cells", "listen", "says"),
    [
        ([SiteCell("arm", 1), SiteCell("other", 1)], "tcp/127.0.0.1:0", "lacks other.controller"),
        ([SiteCell("arm", 1), SiteCell("arm", 1)], "tcp/127.0.0.1:0", "given twice"),
        ([SiteCell("site", 1)], "tcp/127.0.0.1:0", "cannot join a site"),
        (CELLS, "tls/127.0.0.1:0", "has no CA"),
    ],
)
def test_what_cannot_be_served_is_refused(
    tmp_path: Path, cells: list[SiteCell], listen: str, says: str
) -> None:
    with pytest.raises(ValueError, match=says):
        site_router_settings(credentials(tmp_path, tls=False), cells, [listen], [])


def test_the_command_writes_a_private_config_or_says_what_is_wrong(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    directory = credentials(tmp_path / "c", tls=False)
    out = tmp_path / "router.json5"
    command = ["site", str(directory), "--config", "arm=single-arm", "--listen", "tcp/0.0.0.0:1"]
    with pytest.raises(SystemExit) as refused:
        main([*command, "--config", "missing=single-arm", "--out", str(out)])
    assert refused.value.code == 2
    assert "lacks missing.controller" in capsys.readouterr().err
    with pytest.raises(SystemExit) as unwritable:
        main([*command, "--out", str(tmp_path / "missing" / "router.json5")])
    assert unwritable.value.code == 2
    assert "cannot write" in capsys.readouterr().err
    with pytest.raises(SystemExit) as done:
        main([*command, "--out", str(out)])
    assert done.value.code == 0
    assert out.stat().st_mode & 0o077 == 0
    assert json.loads(out.read_text())["mode"] == "router"


def test_a_mesh_without_tls_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="know each other by their certificates"):
        site_router_settings(
            credentials(tmp_path, tls=False), CELLS, ["tcp/127.0.0.1:0"], ["tcp/127.0.0.1:1"]
        )


def test_the_router_may_find_its_files_elsewhere_and_new_identities_get_bundles(
    tmp_path: Path,
) -> None:
    """A router host has only its bundles (merged), at a path of its own."""
    directory = credentials(tmp_path / "c", tls=True)
    there = Path("/etc/motocell/credentials")
    settings = site_router_settings(
        directory, CELLS, ["tls/0.0.0.0:7447"], ["tls/b:7447"], files_at=there
    )
    assert settings["transport"]["auth"]["usrpwd"]["dictionary_file"] == str(there / "users")
    tls = settings["transport"]["link"]["tls"]
    assert tls["listen_certificate"] == str(there / "router.pem")
    assert tls["connect_certificate"] == str(there / f"{SITE_ROUTER}.pem")
    for user in (SITE_OBSERVER, SITE_ROUTER):
        assert (bundle_path(directory, user) / f"{user}.pem").is_file()
    router_users = (bundle_path(directory, ROUTER_BUNDLE) / "users").read_text()
    assert f"{SITE_OBSERVER}:" in router_users and f"{SITE_ROUTER}:" in router_users
