"""Credentials on disk: private files, one password per identity, clear errors."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from motocell.shared.bus.access import Identity, cell_identities
from motocell.shared.bus.catalog import Role
from motocell.shared.bus.credentials import (
    USERS_FILE,
    CredentialsError,
    load,
    password_path,
    write_passwords,
)
from motocell.shared.files import SECRET_LIMIT


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


@pytest.mark.parametrize("opened", [0o644, 0o640, 0o604, 0o660])
def test_a_password_others_may_read_is_refused_with_the_chmod_that_fixes_it(
    tmp_path: Path, opened: int
) -> None:
    identity = Identity(Role.OBSERVER)
    write_passwords(tmp_path, "c1", [identity])
    path = password_path(tmp_path, "c1.observer")
    path.chmod(opened)
    with pytest.raises(CredentialsError) as info:
        load(tmp_path, "c1", identity)
    assert str(info.value) == (
        f"{path} is open to other users (permissions {opened:04o}) and a password or key must "
        f"be its owner's alone: chmod 600 {path}"
    )
    path.chmod(0o600)
    assert load(tmp_path, "c1", identity).user == "c1.observer"
    path.chmod(0o400)  # read-only for its owner is as private
    assert load(tmp_path, "c1", identity).user == "c1.observer"


def test_a_key_others_may_read_is_refused(tmp_path: Path) -> None:
    identity = Identity(Role.OBSERVER)
    write_passwords(tmp_path, "c1", [identity])
    (tmp_path / "c1.observer.pem").write_text("a certificate is public")
    key = tmp_path / "c1.observer.key"
    key.write_text("a key")
    key.chmod(0o644)
    with pytest.raises(CredentialsError, match=f"chmod 600 {key}"):
        load(tmp_path, "c1", identity)
    key.chmod(0o600)
    assert load(tmp_path, "c1", identity).key == key


@pytest.mark.parametrize("kind", ["fifo", "binary", "huge"])
def test_a_password_that_is_no_small_text_file_is_one_line(tmp_path: Path, kind: str) -> None:
    identity = Identity(Role.OBSERVER)
    write_passwords(tmp_path, "c1", [identity])
    path = password_path(tmp_path, "c1.observer")
    path.unlink()
    if kind == "fifo":
        os.mkfifo(path, 0o600)
    else:
        path.write_bytes(b"\xff\xfe" if kind == "binary" else b"x" * (SECRET_LIMIT + 1))
        path.chmod(0o600)
    problem = {"fifo": "not a regular file", "binary": "not a text file", "huge": "larger than"}
    with pytest.raises(CredentialsError, match=problem[kind]):
        load(tmp_path, "c1", identity)
