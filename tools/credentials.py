"""``motocell credentials``: everything a secured cell's bus needs, in a directory only you can
read: a password per identity and the router's user dictionary; with ``--tls`` also a CA (its
private key kept, to add and renew certificates later), the router's certificate and a
certificate per identity (mutual TLS).

Given a directory it made before, it adds what is missing and touches nothing that exists:
another cell's identities (``--config second-cell.toml``: the same CA signs them, so one router
can serve both), or an identity the cell file gained (a new group's interpolator).

For cells whose router and services do not start together under ``motocell up`` (which makes
its own at every start): compose, or services spread over several hosts. Each party then gets
only its own files; keep this directory, with the CA's key, off the cell's hosts.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from motocell.shared.bus.access import Identity, cell_identities
from motocell.shared.bus.credentials import (
    CA_FILE,
    USERS_FILE,
    CredentialsError,
    add_passwords,
    write_passwords,
)
from motocell.shared.bus.router import ROUTER_CERTIFICATE, ROUTER_KEY
from motocell.shared.config import Cell, ConfigError, load_cell

DEFAULT_HOSTS = ("localhost", "127.0.0.1")
"""The names a router's certificate is valid for unless ``--host`` says otherwise."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``motocell credentials`` (``tools.cli`` names the command)."""
    parser.description = __doc__
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument(
        "directory",
        metavar="DIR",
        help="created, readable only by you; or one made before, to add the cell's identities",
    )
    parser.add_argument(
        "--config", metavar="FILE", help="the cell file: its name, and one identity per group"
    )
    parser.add_argument(
        "--cell",
        metavar="NAME",
        help="the cell's name if it runs under another than its file's (motocell up --name); "
        "its Zenoh usernames are NAME.<identity>",
    )
    parser.add_argument(
        "--tls", action="store_true", help="also a CA and certificates, for mutual TLS"
    )
    parser.add_argument(
        "--host",
        action="append",
        default=[],
        metavar="NAME",
        help="with --tls: a name or address the router is reached by (repeatable; default: "
        f"{' and '.join(DEFAULT_HOSTS)})",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    directory = Path(args.directory)
    try:
        cell = load_cell(args.config, args.cell)
        if args.host and not args.tls:
            raise ValueError("--host names the router in its TLS certificate: add --tls")
        if _is_credentials(directory):
            print(_add_cell(directory, cell, args.tls))
            return 0
        _check_new_directory(directory)
    except (ConfigError, CredentialsError, ValueError) as exc:
        print(f"motocell credentials: {exc}", file=sys.stderr)
        return 2
    identities = cell_identities(len(cell.groups))
    write_passwords(directory, cell.name, identities)
    hosts = args.host or list(DEFAULT_HOSTS)
    if args.tls:
        # cryptography only for --tls: 20-30 ms every other motocell command would pay.
        from motocell.shared.bus.certificates import write_certificates  # noqa: PLC0415

        write_certificates(directory, cell.name, identities, hosts)
    print(report(directory, cell.name, identities, hosts if args.tls else None))
    return 0


def _is_credentials(directory: Path) -> bool:
    return (directory / USERS_FILE).is_file()


def _add_cell(directory: Path, cell: Cell, tls: bool) -> str:
    """The identities of ``cell`` that ``directory`` lacks, with certificates from its CA if
    it has one; nothing that exists is touched."""
    has_ca = (directory / CA_FILE).is_file()
    if tls and not has_ca:
        raise ValueError(
            f"{directory} holds passwords only: give --tls a new directory (every party of the "
            "cell then needs the new files)"
        )
    users = [identity.username(cell.name) for identity in cell_identities(len(cell.groups))]
    if has_ca:
        from motocell.shared.bus.certificates import (  # noqa: PLC0415
            issue_client_certificate,
            load_authority,
        )

        authority = load_authority(directory)  # before anything is written: it may be missing
        added = add_passwords(directory, users)
        for user in added:
            issue_client_certificate(directory, user, authority)
    else:
        added = add_passwords(directory, users)
    if not added:
        return f"{directory} already holds every identity of cell {cell.name}: nothing added"
    signed = f", signed by its CA ({CA_FILE})" if has_ca else ""
    return f"added to {directory}{signed}: {' '.join(added)}"


def _check_new_directory(directory: Path) -> None:
    """New credentials go into a new or empty directory, or one this command made: anything
    else may be someone's files."""
    if directory.exists() and (not directory.is_dir() or any(directory.iterdir())):
        raise ValueError(
            f"{directory} exists and holds no credentials (no {USERS_FILE} file): give a new "
            "directory, or the one `motocell credentials` made"
        )


def report(directory: Path, cell: str, identities: list[Identity], hosts: list[str] | None) -> str:
    """What was written, who needs which file, and how to use them."""
    files = [
        (USERS_FILE, "the router's user dictionary (transport.auth.usrpwd.dictionary_file)"),
        ("USER.password", "one per identity: " + " ".join(i.username(cell) for i in identities)),
    ]
    router_files = USERS_FILE
    if hosts is not None:
        files += [
            (f"{CA_FILE}, ca.key", "the cell's certificate authority (keep ca.key off the hosts)"),
            (f"{ROUTER_CERTIFICATE}, {ROUTER_KEY}", f"the router's, for {', '.join(hosts)}"),
            ("USER.pem, USER.key", "one certificate per identity (mutual TLS)"),
        ]
        router_files = f"{USERS_FILE}, {CA_FILE}, router.*"
    endpoint = "tcp/ROUTER:7447" if hosts is None else f"tls/{hosts[0]}:7447"
    where = f"--zenoh-connect {endpoint} --cell {cell} --credentials {directory}"
    return "\n".join(
        [
            f"wrote the credentials of cell {cell} into {directory} (readable only by you):",
            *(f"  {name:<28}{meaning}" for name, meaning in files),
            f"Copy to each host only what runs there: the router {router_files}; a service or "
            f"tool its own USER.* files{'' if hosts is None else ' and ' + CA_FILE}.",
            f"Zenoh usernames (USER) are {cell}.IDENTITY. Services join with --credentials DIR; "
            "observe and operate the cell with:",
            f"  motocell ps {where}",
            f"  motocell fault estop on {where}",
        ]
    )
