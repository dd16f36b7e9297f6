"""``motocell site``: one Zenoh router's configuration for every secured cell of a site (or one
per host of a meshed site), from the site's credentials directory, in which ``motocell
credentials DIR --config CELL`` put every cell's identities under one CA (docs/site.md).

Each cell's identities may do exactly what they may on a router of the cell's own, on their own
cell's keys only; the site observer (``site.observer``) watches every cell and acts on none;
on a TLS site, the routers of a mesh reach each other as ``site.router``. Both are added to
the directory when missing (a password, and a certificate from its CA); nothing else there is
touched.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from motocell.shared.bus.access import (
    SITE_OBSERVER,
    SITE_ROUTER,
    Party,
    cell_identities,
    cell_parties,
    router_links,
    site_observer,
)
from motocell.shared.bus.bundles import write_bundles
from motocell.shared.bus.credentials import (
    CA_FILE,
    Credentials,
    CredentialsError,
    add_passwords,
    certificate_paths,
    load_user,
    password_path,
    read_credential,
    write_private,
)
from motocell.shared.bus.router import ROUTER_CERTIFICATE, secured_settings
from motocell.shared.config import Cell, ConfigError, load_cell

RESERVED = SITE_OBSERVER.split(".")[0]
"""No cell may have this name: its identities' usernames would be the site's own."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``motocell site`` (``tools.cli`` names the command)."""
    parser.description = __doc__
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument("credentials", metavar="DIR", help="the site's credentials directory")
    parser.add_argument(
        "--config",
        action="append",
        default=[],
        required=True,
        metavar="[NAME=]FILE",
        help="a cell the router serves: its cell file or sample name, with NAME= when it runs "
        "under another name (motocell up --name) (repeatable)",
    )
    parser.add_argument(
        "--listen",
        action="append",
        default=[],
        required=True,
        metavar="ENDPOINT",
        help="where this router listens, e.g. tls/0.0.0.0:7447 (repeatable)",
    )
    parser.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="another router of the site's mesh, e.g. tls/host-b:7447 (repeatable; name each "
        "pair of routers once, on one of the two)",
    )
    parser.add_argument(
        "--out", required=True, type=Path, metavar="FILE", help="the router configuration"
    )
    parser.add_argument(
        "--files-at",
        type=Path,
        metavar="PATH",
        help="where the router finds its files, if not in DIR: its bundle (DIR/bundles/router), "
        f"merged with DIR/bundles/{SITE_ROUTER} for a router that --connects",
    )
    parser.set_defaults(run=run)


@dataclass(frozen=True)
class SiteCell:
    name: str
    groups: int
    face: bool = False
    """The cell file has ``[ros2]``: the cell has the ROS 2 face's identity too."""


def parse_cell(text: str) -> SiteCell:
    """``NAME=FILE`` or ``FILE``; ConfigError for a file that cannot be read."""
    name, separator, config = text.rpartition("=")
    cell: Cell = load_cell(config, name if separator else None)
    return SiteCell(cell.name, len(cell.groups), face=cell.ros2 is not None)


def run(args: argparse.Namespace) -> int:
    try:
        cells = [parse_cell(text) for text in args.config]
        settings = site_router_settings(
            Path(args.credentials), cells, args.listen, args.connect, files_at=args.files_at
        )
        # Private: with a mesh it holds this router's password towards the others.
        write_private(args.out, json.dumps(settings, indent=2) + "\n")
    except (ConfigError, CredentialsError, ValueError) as exc:
        print(f"motocell site: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"motocell site: cannot write {args.out}: {exc.strerror}", file=sys.stderr)
        return 2
    print(report(args, cells))
    return 0


def site_router_settings(
    directory: Path,
    cells: Sequence[SiteCell],
    listen: Sequence[str],
    connect: Sequence[str],
    *,
    files_at: Path | None = None,
) -> dict[str, Any]:
    """The router of ``cells`` with every identity in ``directory``; on a TLS listener mutual
    TLS, each identity its password and certificate together. The configuration names the
    router's files in ``files_at`` (default ``directory``). ValueError or CredentialsError for
    what cannot be served."""
    _check_cells(directory, cells)
    tls = any(endpoint.startswith("tls/") for endpoint in [*listen, *connect])
    if tls and not (directory / CA_FILE).is_file():
        raise ValueError(
            f"{directory} has no CA for a TLS router: make it with `motocell credentials "
            f"{directory} --config CELL --tls --host ROUTERHOST`"
        )
    if connect and not tls:
        raise ValueError(
            "the routers of a mesh know each other by their certificates: give TLS endpoints "
            "(tls/HOST:PORT) and a directory with a CA"
        )
    _add_site_identities(directory, [SITE_OBSERVER, *([SITE_ROUTER] if tls else [])], tls)
    parties: list[Party] = [site_observer(SITE_OBSERVER)]
    for cell in cells:
        parties += cell_parties(cell.name, cell_identities(cell.groups, face=cell.face))
    if tls:
        # Any TLS router of the site may be one a mesh's other routers connect to; only one
        # that dials others knows a router by its certificate alone.
        router_name = _router_common_name(directory)
        _check_no_client_named(directory, router_name)
        parties += router_links(SITE_ROUTER, router_name if connect else None)
    files = files_at or directory
    link = None
    if connect:
        own = load_user(directory, SITE_ROUTER)
        certificate, key = certificate_paths(files, SITE_ROUTER)
        link = Credentials(own.user, own.password, certificate=certificate, key=key)
    return secured_settings(listen, connect, parties, files, mutual_tls=tls, link=link)


def _router_common_name(directory: Path) -> str:
    """The common name of the site's router certificate: what a router of the mesh shows the
    routers that connect to it."""
    from cryptography import x509  # noqa: PLC0415 (only a TLS site loads it)
    from cryptography.x509.oid import NameOID  # noqa: PLC0415

    certificate = x509.load_pem_x509_certificate(read_credential(directory / ROUTER_CERTIFICATE))
    (attribute,) = certificate.subject.get_attributes_for_oid(NameOID.COMMON_NAME)
    return str(attribute.value)


def _check_no_client_named(directory: Path, router_name: str) -> None:
    """No client identity in ``directory`` has the router's name: with its certificate, any
    password of the site would pass for a router the others dial."""
    found = [
        path.name
        for path in (
            password_path(directory, router_name),
            *certificate_paths(directory, router_name),
        )
        if path.exists()
    ]
    if found:
        raise ValueError(
            f"{directory} holds a client identity named like its router ({router_name}: "
            f"{', '.join(found)}), which would pass for a router of the site: remove those "
            "files, and any copy of them"
        )


def _check_cells(directory: Path, cells: Sequence[SiteCell]) -> None:
    names = [cell.name for cell in cells]
    for name in names:
        if names.count(name) > 1:
            raise ValueError(f"cell {name} is given twice: one --config per cell")
        if name == RESERVED:
            raise ValueError(
                f"a cell named {RESERVED} cannot join a site: its usernames would be the "
                f"site's own; run it under another name (--config OTHER=FILE, motocell up --name)"
            )
    for cell in cells:
        for identity in cell_identities(cell.groups, face=cell.face):
            user = identity.username(cell.name)
            if not password_path(directory, user).is_file():
                raise ValueError(
                    f"{directory} lacks {user}: add cell {cell.name}'s identities with "
                    f"`motocell credentials {directory} --config CELLFILE`"
                )


def _add_site_identities(directory: Path, users: Sequence[str], tls: bool) -> None:
    """A password for each of ``users`` that has none, and a certificate from the directory's
    CA on a TLS site; what exists is left as it is."""
    if tls:
        # cryptography only for a TLS site (as motocell credentials does).
        from motocell.shared.bus.certificates import (  # noqa: PLC0415
            issue_client_certificate,
            load_authority,
        )

        authority = load_authority(directory)
        added = add_passwords(directory, users)
        for user in added:
            issue_client_certificate(directory, user, authority)
    else:
        added = add_passwords(directory, users)
    if added:
        write_bundles(directory)  # the new identities', and the router's with their passwords


def report(args: argparse.Namespace, cells: Sequence[SiteCell]) -> str:
    listen = args.listen[0].replace("0.0.0.0", "ROUTERHOST")
    directory = args.credentials
    return "\n".join(
        [
            f"wrote {args.out}: a router for cells {', '.join(c.name for c in cells)} on "
            f"{', '.join(args.listen)}"
            + (f", meshed with {', '.join(args.connect)}" if args.connect else ""),
            f"  run it:          motocell router --config {args.out}   (or zenohd -c)",
            f"  a cell joins:    motocell up --config CELL --zenoh-connect {listen} "
            f"--credentials {directory}",
            f"  watch the site:  motocell ps --zenoh-connect {listen} --credentials {directory}",
        ]
    )
