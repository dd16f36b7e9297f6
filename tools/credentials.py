"""``motocell credentials``: everything a secured cell's bus needs, in a directory only you can
read: a password per identity and the router's user dictionary; with ``--tls`` also a CA (its
private key kept, to add and renew certificates later), the router's certificate and a
certificate per identity (mutual TLS). ``DIR/bundles`` holds what each party needs and nothing
else: copy to each host only the bundles of what runs there.

Given a directory it made before, it adds what the options name and touches nothing that
exists: another cell's identities (``--config second-cell.toml``: the same CA signs them, so
one router can serve both), an identity the cell file gained (a new group's interpolator),
an identity of no cell (``--identity site.observer``), a name the router is reached by
(``--host``). ``--renew`` issues again the certificates that expire soon.

For cells whose router and services do not start together under ``motocell up`` (which makes
its own at every start): compose, or services spread over several hosts. Keep this directory,
with the CA's key, off the cell's hosts (docs/credentials.md).
"""

from __future__ import annotations

import argparse
import datetime
import re
import sys
from pathlib import Path

from motocell.shared.bus.access import ROUTER_SUFFIX, cell_identities, is_router_name
from motocell.shared.bus.bundles import BUNDLES, ROUTER_BUNDLE, bundle_path, write_bundles
from motocell.shared.bus.credentials import (
    CA_FILE,
    CA_KEY_FILE,
    USERS_FILE,
    CredentialsError,
    add_passwords,
    write_passwords,
)
from motocell.shared.bus.expiry import WARN_WITHIN
from motocell.shared.bus.router import ROUTER_CERTIFICATE, ROUTER_KEY
from motocell.shared.config import Cell, ConfigError, load_cell
from motocell.tools.site import RESERVED

DEFAULT_HOSTS = ("localhost", "127.0.0.1")
"""The names a router's certificate is valid for unless ``--host`` says otherwise."""
RENEW_WITHIN_DAYS = WARN_WITHIN.days
"""What ``--renew`` renews by default: what ``motocell ps`` and ``watch`` warn about."""
USERNAME = re.compile(r"[A-Za-z0-9_-]+(\.[A-Za-z0-9_-]+)*")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``motocell credentials`` (``tools.cli`` names the command)."""
    parser.description = __doc__
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument(
        "directory", metavar="DIR", help="created, readable only by you; or one made before"
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
        help="a name or address the router is reached by, in its TLS certificate (repeatable; "
        f"a new directory's default: {' and '.join(DEFAULT_HOSTS)})",
    )
    parser.add_argument(
        "--identity",
        action="append",
        default=[],
        metavar="USER",
        help="also an identity of no cell file, by its Zenoh username (repeatable): a "
        "password, and a certificate with TLS; the router's access rules say what it may do",
    )
    parser.add_argument(
        "--renew",
        action="store_true",
        help="issue again every certificate that expires within --within days (new keys; the "
        "CA and every password kept)",
    )
    parser.add_argument(
        "--within",
        type=int,
        metavar="DAYS",
        help=f"with --renew (default {RENEW_WITHIN_DAYS})",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    directory = Path(args.directory)
    try:
        _check_arguments(args)
        if (directory / USERS_FILE).is_file():
            lines = _renew(directory, args) if args.renew else _add(directory, args)
        else:
            _check_new_directory(directory, args)
            lines = _create(directory, args)
    except (ConfigError, CredentialsError, ValueError) as exc:
        print(f"motocell credentials: {exc}", file=sys.stderr)
        return 2
    write_bundles(directory)
    print("\n".join(lines))
    return 0


def _check_arguments(args: argparse.Namespace) -> None:
    if args.within is not None and not args.renew:
        raise ValueError("--within says what --renew renews: add --renew")
    if args.within is not None and args.within < 0:
        raise ValueError("--within: a number of days, 0 or more")
    if args.renew and (args.config or args.cell or args.tls or args.host or args.identity):
        raise ValueError("--renew goes alone (with --within): renew, then add")
    for user in args.identity:
        if not USERNAME.fullmatch(user) or user == ROUTER_BUNDLE:
            raise ValueError(
                f"--identity {user!r}: a Zenoh username is words of letters, digits, - or _ "
                "joined by dots (site.observer), not 'router'"
            )
        if is_router_name(user):
            raise ValueError(
                f"--identity {user}: a name ending in {ROUTER_SUFFIX} is a router's (its "
                "certificate's, or site.router, which `motocell site` makes for a mesh): a "
                "client named so would pass for a router; choose another name"
            )


def _check_new_directory(directory: Path, args: argparse.Namespace) -> None:
    """New credentials go into a new or empty directory: anything else may be someone's
    files."""
    if directory.exists() and (not directory.is_dir() or any(directory.iterdir())):
        raise ValueError(
            f"{directory} exists and holds no credentials (no {USERS_FILE} file): give a new "
            "directory, or the one `motocell credentials` made"
        )
    if args.renew:
        raise ValueError(f"{directory} holds no credentials to renew")
    if args.host and not args.tls:
        raise ValueError("--host names the router in its TLS certificate: add --tls")


def _cell(args: argparse.Namespace) -> Cell:
    """The cell whose identities the options name; ValueError for one no site could serve."""
    cell = load_cell(args.config, args.cell)
    if cell.name == RESERVED:
        raise ValueError(
            f"a cell named {RESERVED} gets no credentials: its usernames ({RESERVED}.observer, "
            "...) are the site's own, which watch every cell of a site; give it another name "
            f"here with --cell NAME, and run it with `motocell up --name NAME`"
        )
    return cell


def _create(directory: Path, args: argparse.Namespace) -> list[str]:
    cell = _cell(args)
    identities = cell_identities(len(cell.groups), face=cell.ros2 is not None)
    write_passwords(directory, cell.name, identities)
    extra = add_passwords(directory, args.identity)  # an --identity of the cell's is no extra
    hosts = args.host or list(DEFAULT_HOSTS)
    if args.tls:
        # cryptography only for --tls: 20-30 ms every other motocell command would pay.
        from motocell.shared.bus.certificates import (  # noqa: PLC0415
            issue_client_certificate,
            write_certificates,
        )

        authority = write_certificates(directory, cell.name, identities, hosts)
        for user in extra:
            issue_client_certificate(directory, user, authority)
    users = [identity.username(cell.name) for identity in identities] + extra
    return report(directory, cell.name, users, hosts if args.tls else None)


def _add(directory: Path, args: argparse.Namespace) -> list[str]:
    """What the options name that ``directory`` lacks: the identities of the cell (if one is
    named), of ``--identity``, the router's ``--host`` names; certificates from its CA."""
    has_ca = (directory / CA_FILE).is_file()
    if (args.tls or args.host) and not has_ca:
        option = "--tls" if args.tls else "--host"
        raise ValueError(
            f"{directory} holds passwords only, so {option} cannot be added: give --tls a new "
            "directory (every party of the cell then needs the new files)"
        )
    users = list(args.identity)
    if args.config or args.cell:
        cell = _cell(args)
        users = [
            i.username(cell.name)
            for i in cell_identities(len(cell.groups), face=cell.ros2 is not None)
        ] + users
    if not has_ca:
        return _added(directory, add_passwords(directory, users), [], signed=False)
    from motocell.shared.bus.certificates import (  # noqa: PLC0415
        add_router_hosts,
        issue_client_certificate,
        load_authority,
    )

    authority = load_authority(directory)  # before anything is written: it may be missing
    added = add_passwords(directory, users)
    for user in added:
        issue_client_certificate(directory, user, authority)
    hosts = add_router_hosts(directory, args.host, authority) if args.host else []
    return _added(directory, added, hosts, signed=True)


def _added(directory: Path, users: list[str], hosts: list[str], *, signed: bool) -> list[str]:
    if not users and not hosts:
        return [f"{directory} already holds all that: nothing added (bundles written again)"]
    lines = []
    if users:
        by = f", signed by its CA ({CA_FILE})" if signed else ""
        lines.append(f"added to {directory}{by}: {' '.join(users)}")
    if hosts:
        lines.append(f"the router's certificate is now also valid for {', '.join(hosts)}")
    router = bundle_path(directory, ROUTER_BUNDLE)
    lines.append(
        f"Restart the router with the new {router} (it reads its users and certificate at "
        "start); give each new identity its bundle."
    )
    return lines


def _renew(directory: Path, args: argparse.Namespace) -> list[str]:
    if not (directory / CA_FILE).is_file():
        raise ValueError(f"{directory} holds passwords only: they do not expire")
    from motocell.shared.bus.certificates import load_authority, renew_certificates  # noqa: PLC0415

    days = RENEW_WITHIN_DAYS if args.within is None else args.within
    within = datetime.timedelta(days=days)
    renewed = renew_certificates(directory, within, load_authority(directory))
    if not renewed:
        return [f"no certificate of {directory} expires within {days} days: nothing renewed"]
    parties = [ROUTER_BUNDLE if name == ROUTER_CERTIFICATE else name[:-4] for name in renewed]
    return [
        f"renewed for a year (expiring within {days} days): {' '.join(parties)}",
        f"Copy each one's bundle ({directory / BUNDLES}/PARTY) to where it runs and restart "
        "it; passwords and the CA are unchanged.",
    ]


def report(directory: Path, cell: str, users: list[str], hosts: list[str] | None) -> list[str]:
    """What was written, who needs which file, and how to use them."""
    files = [
        (USERS_FILE, "the router's user dictionary (transport.auth.usrpwd.dictionary_file)"),
        ("USER.password", "one per identity: " + " ".join(users)),
    ]
    if hosts is not None:
        files += [
            (f"{CA_FILE}, {CA_KEY_FILE}", "the CA; its key signs new certificates"),
            (f"{ROUTER_CERTIFICATE}, {ROUTER_KEY}", f"the router's, for {', '.join(hosts)}"),
            ("USER.pem, USER.key", "one certificate per identity (mutual TLS)"),
        ]
    files.append((f"{BUNDLES}/PARTY/", f"what each party needs: {ROUTER_BUNDLE}, or a USER"))
    endpoint = "tcp/ROUTER:7447" if hosts is None else f"tls/{hosts[0]}:7447"
    observer = bundle_path(directory, f"{cell}.observer")
    operator = bundle_path(directory, f"{cell}.operator")
    return [
        f"wrote the credentials of cell {cell} into {directory} (readable only by you):",
        *(f"  {name:<28}{meaning}" for name, meaning in files),
        f"Copy to each host only the bundles of what runs there (never {CA_KEY_FILE}: keep "
        "this directory off the cell's hosts); a host with several merges their files.",
        f"Zenoh usernames (USER) are {cell}.IDENTITY. A party joins with --credentials "
        "BUNDLE; observe and operate the cell with:",
        f"  motocell ps --zenoh-connect {endpoint} --cell {cell} --credentials {observer}",
        f"  motocell fault estop on --zenoh-connect {endpoint} --cell {cell} "
        f"--credentials {operator}",
    ]
