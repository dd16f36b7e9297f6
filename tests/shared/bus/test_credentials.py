"""Credentials on disk: private files, one password per identity, clear errors."""

from __future__ import annotations

import stat
from pathlib import Path

import pytest

from motocell.shared.bus.access import Identity, cell_identities
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.credentials import USERS_FILE, CredentialsError, load, write_passwords


def mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


def test_every_file_is_private_and_every_identity_has_its_own_password(tmp_path: Path) -> None:
    directory = tmp_path / "creds"
    identities = cell_identities(2)
    write_passwords(directory, "c1", identities)
    assert mode(directory) == 0o700
    assert all(mode(path) == 0o600 for path in directory.iterdir())
    loaded = [load(directory, "c1", identity) for identity in identities]
    assert len({credentials.password for credentials in loaded}) == len(identities)
    users = (directory / USERS_FILE).read_text().splitlines()
    assert sorted(users) == sorted(f"{c.user}:{c.password}" for c in loaded)
    assert loaded[0].ca is None and loaded[0].certificate is None


def test_a_missing_identity_says_how_to_make_one(tmp_path: Path) -> None:
    write_passwords(tmp_path, "c1", [Identity(Role.GATEWAY)])
    with pytest.raises(CredentialsError, match="motocell credentials"):
        load(tmp_path, "c1", Identity(Role.OBSERVER))


def test_regenerating_replaces_every_password(tmp_path: Path) -> None:
    identity = Identity(Role.OBSERVER)
    write_passwords(tmp_path, "c1", [identity])
    first = load(tmp_path, "c1", identity).password
    write_passwords(tmp_path, "c1", [identity])
    assert load(tmp_path, "c1", identity).password != first
