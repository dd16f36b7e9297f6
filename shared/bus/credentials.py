"""A cell's identities on disk: one password per identity, and the router's user dictionary.

Layout of a credentials directory (mode 0700; every file 0600, readable only by its owner):

- ``users``: the router's ``transport.auth.usrpwd.dictionary_file``, ``user:password`` lines;
- ``<identity>.password``: that identity's password (``gateway.password``,
  ``interpolator-1.password``, ``observer.password``);
- with TLS (``motocell credentials --tls``): ``ca.pem``, ``router.pem``/``router.key`` and
  ``<identity>.pem``/``<identity>.key`` (certificate common name = the Zenoh username).

Passwords are 32 random bytes: Zenoh never sends them in clear, but without TLS a captured
handshake could be attacked offline, so they must not be guessable.
"""

from __future__ import annotations

import os
import secrets
from dataclasses import dataclass
from pathlib import Path

from motocell.shared.bus.access import Identity

USERS_FILE = "users"
CA_FILE = "ca.pem"


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


def write_passwords(directory: Path, cell: str, identities: list[Identity]) -> None:
    """Create (or refresh) ``directory`` with a new password for every identity."""
    directory.mkdir(parents=True, exist_ok=True, mode=0o700)
    directory.chmod(0o700)
    lines = []
    for identity in identities:
        password = secrets.token_urlsafe(32)
        write_private(directory / f"{identity.name}.password", password + "\n")
        lines.append(f"{identity.username(cell)}:{password}\n")
    write_private(directory / USERS_FILE, "".join(lines))


def load(directory: Path, cell: str, identity: Identity) -> Credentials:
    """The credentials of ``identity`` from ``directory`` (TLS files used when present)."""
    password_file = directory / f"{identity.name}.password"
    try:
        password = password_file.read_text().strip()
    except FileNotFoundError:
        raise CredentialsError(
            f"no password for {identity.name} in {directory}: generate the cell's credentials "
            f"with `motocell credentials {directory}` (or start the cell with `motocell up`)"
        ) from None
    except PermissionError:
        raise CredentialsError(
            f"cannot read {password_file}: run as the user who started the cell"
        ) from None
    ca = directory / CA_FILE
    certificate = directory / f"{identity.name}.pem"
    key = directory / f"{identity.name}.key"
    has_certificate = certificate.is_file() and key.is_file()
    return Credentials(
        identity.username(cell),
        password,
        ca if ca.is_file() else None,
        certificate if has_certificate else None,
        key if has_certificate else None,
    )


def write_private(path: Path, content: str | bytes) -> None:
    """Written so that no other user can ever read it, not even for a moment."""
    data = content.encode() if isinstance(content, str) else content
    descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(descriptor, "wb") as file:
        file.write(data)
    path.chmod(0o600)
