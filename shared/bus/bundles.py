"""What each party of a secured bus gets of a credentials directory: one folder per party
under ``<directory>/bundles``, holding only that party's files, so that copying "only what
runs there" to a host is one command.

- ``bundles/<user>/``: the identity's ``<user>.password``, and with TLS its ``<user>.pem`` and
  ``<user>.key`` and the CA's certificate ``ca.pem``;
- ``bundles/router/``: the router's user dictionary ``users``, and with TLS ``ca.pem``,
  ``router.pem`` and ``router.key``.

Never the CA's private key. Each bundle is itself a credentials directory (``--credentials
BUNDLE``), and bundles merge: a host that runs several parties takes the files of all their
bundles into one folder. The files at the top of the directory are the originals; the bundles
are copies, written again by every ``motocell credentials`` that changes anything, in place
(a container's mount of a bundle sees the new files).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from motocell.shared.bus.credentials import (
    CA_FILE,
    PASSWORD_SUFFIX,
    USERS_FILE,
    certificate_paths,
    make_private_directory,
    password_path,
    read_credential,
    write_private,
)
from motocell.shared.bus.router import ROUTER_CERTIFICATE, ROUTER_KEY

BUNDLES = "bundles"
ROUTER_BUNDLE = "router"


def write_bundles(directory: Path) -> list[Path]:
    """A bundle for the router and for every identity with a password in ``directory``."""
    router = [directory / name for name in (USERS_FILE, CA_FILE, ROUTER_CERTIFICATE, ROUTER_KEY)]
    bundles = [_bundle(directory, ROUTER_BUNDLE, router)]
    for user in users(directory):
        files = [password_path(directory, user), *certificate_paths(directory, user)]
        bundles.append(_bundle(directory, user, [*files, directory / CA_FILE]))
    return bundles


def users(directory: Path) -> list[str]:
    """The Zenoh usernames with a password in ``directory``."""
    return sorted(
        path.name.removesuffix(PASSWORD_SUFFIX) for path in directory.glob(f"*{PASSWORD_SUFFIX}")
    )


def bundle_path(directory: Path, party: str) -> Path:
    """The bundle of ``party`` (a Zenoh username, or ``router``)."""
    return directory / BUNDLES / party


def _bundle(directory: Path, party: str, files: Sequence[Path]) -> Path:
    bundle = bundle_path(directory, party)
    make_private_directory(bundle.parent)
    make_private_directory(bundle)
    for path in files:
        if path.is_file():
            write_private(bundle / path.name, read_credential(path))
    return bundle
