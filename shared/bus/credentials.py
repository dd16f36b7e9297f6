"""A cell's identities on disk: one password per identity, and the router's user dictionary.

Layout of a credentials directory (mode 0700; every file 0600, readable only by its owner).
Every identity's files are named by its Zenoh username, so the identities of several cells
can share one directory (and one CA):

- ``users``: the router's ``transport.auth.usrpwd.dictionary_file``, ``user:password`` lines;
- ``<user>.password``: that identity's password (``dual.gateway.password``,
  ``dual.interpolator-1.password``, ``site.observer.password``);
- with TLS (``motocell credentials --tls``): ``ca.pem`` and the CA's private key ``ca.key``,
  ``router.pem``/``router.key`` and ``<user>.pem``/``<user>.key`` (certificate common name =
  the Zenoh username).

Passwords are 32 random bytes: Zenoh never sends them in clear, but without TLS a captured
handshake could be attacked offline, so they must not be guessable.

A password or private key that another user may read is refused, as ssh refuses such a key:
one line naming the file and the ``chmod`` that fixes it (docs/credentials.md, Permissions).
"""

from __future__ import annotations

import base64
import os
import stat
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from motocell.shared.bus.access import Identity
from motocell.shared.files import SECRET_LIMIT, FileRefusedError, read_bounded, read_text_bounded

USERS_FILE = "users"
PASSWORD_SUFFIX = ".password"
PASSWORD_BYTES = 32
"""Of randomness in each password (the module's text says why)."""
CA_FILE = "ca.pem"
CA_KEY_FILE = "ca.key"
"""The CA's private key: only in the directory where credentials are made, never on a host of
the cell (it signs anyone into the bus)."""


class CredentialsError(Exception):
    """A credentials directory that cannot be used; the message says how to fix it."""


@dataclass(frozen=True)
class Credentials:
    """What one identity needs to join a cell's bus."""

    user: str
    password: str
    ca: Path | None = None
    """The CA that signed the router's certificate: connect over TLS when set."""
    certificate: Path | None = None
    key: Path | None = None
    """This identity's certificate and key: mutual TLS when set."""


def password_path(directory: Path, user: str) -> Path:
    return directory / f"{user}{PASSWORD_SUFFIX}"


def certificate_paths(directory: Path, user: str) -> tuple[Path, Path]:
    """Where ``user``'s certificate and private key are."""
    return directory / f"{user}.pem", directory / f"{user}.key"


def write_passwords(directory: Path, cell: str, identities: Sequence[Identity]) -> None:
    """Create (or refresh) ``directory`` with a new password for every identity."""
    make_private_directory(directory)
    users = [identity.username(cell) for identity in identities]
    write_private(directory / USERS_FILE, "".join(_new_password(directory, u) for u in users))


def add_passwords(directory: Path, users: Sequence[str]) -> list[str]:
    """A password for each of ``users`` that has none in ``directory``, added to the router's
    dictionary; every existing password and line is left as it is. Returns the users added."""
    added = [user for user in users if not password_path(directory, user).exists()]
    lines = "".join(_new_password(directory, user) for user in added)
    descriptor = os.open(directory / USERS_FILE, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o600)
    with os.fdopen(descriptor, "a") as file:
        file.write(lines)
    return added


def _new_password(directory: Path, user: str) -> str:
    """A fresh password written for ``user``; its line of the router's dictionary."""
    password = _random_text(PASSWORD_BYTES)
    write_private(password_path(directory, user), password + "\n")
    return f"{user}:{password}\n"


def _random_text(size: int) -> str:
    """``size`` bytes from the kernel's random source, as URL-safe text: what
    ``secrets.token_urlsafe`` does, without the ``hmac`` and ``hashlib`` (OpenSSL) that
    ``secrets`` imports, 4-5 ms of CPU in every process that imports this module (the launcher
    and the warm parent, at every cell's start), none of which hashes anything."""
    return base64.urlsafe_b64encode(os.urandom(size)).rstrip(b"=").decode("ascii")


def load(directory: Path, cell: str, identity: Identity) -> Credentials:
    """The credentials of ``identity`` from ``directory`` (TLS files used when present)."""
    return load_user(directory, identity.username(cell))


def load_user(directory: Path, user: str) -> Credentials:
    """The credentials of the Zenoh username ``user`` from ``directory``."""
    path = password_path(directory, user)
    try:
        password = read_secret(path).strip()
    except FileNotFoundError:
        raise CredentialsError(
            f"no password for {user} in {directory}: generate the cell's credentials "
            f"with `motocell credentials {directory}` (or start the cell with `motocell up`)"
        ) from None
    except PermissionError:
        raise CredentialsError(
            f"cannot read {path}: run as the user who started the cell"
        ) from None
    ca = directory / CA_FILE
    certificate, key = certificate_paths(directory, user)
    has_certificate = certificate.is_file() and key.is_file()
    if has_certificate:
        check_private(key)  # Zenoh reads it; its permissions are ours to check
    return Credentials(
        user,
        password,
        ca if ca.is_file() else None,
        certificate if has_certificate else None,
        key if has_certificate else None,
    )


def read_secret(path: Path) -> str:
    """A password or private key's text: CredentialsError if others may read it, or it is no
    small text file; OSError if it cannot be read."""
    check_private(path)
    try:
        return read_text_bounded(path, SECRET_LIMIT)
    except FileRefusedError as exc:
        raise CredentialsError(str(exc)) from None


def read_credential(path: Path) -> bytes:
    """A certificate's or key's bytes: CredentialsError for what is no small regular file;
    OSError if it cannot be read. A key's permissions are the caller's to check first."""
    try:
        return read_bounded(path, SECRET_LIMIT)
    except FileRefusedError as exc:
        raise CredentialsError(str(exc)) from None


def check_private(path: Path) -> None:
    """CredentialsError unless only its owner may read or change the secret at ``path``."""
    mode = stat.S_IMODE(path.stat().st_mode)
    if mode & 0o077:
        raise CredentialsError(
            f"{path} is open to other users (permissions {mode:04o}) and a password or key must "
            f"be its owner's alone: chmod 600 {path}"
        )


def make_private_directory(directory: Path) -> None:
    directory.mkdir(parents=True, exist_ok=True, mode=0o700)
    directory.chmod(0o700)


def write_private(path: Path, content: str | bytes) -> None:
    """Written so that no other user can ever read it, not even for a moment."""
    data = content.encode() if isinstance(content, str) else content
    descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(descriptor, "wb") as file:
        file.write(data)
    path.chmod(0o600)
