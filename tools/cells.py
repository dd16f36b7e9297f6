"""Which cells a command acts on, and how it joins each one's bus.

A cell started on this machine (``motocell up``) is found by name in the registry of running
cells (``shared.registry``): its router's endpoint and its credentials directory, so the
commands need no flags. Each cell has a router and credentials of its own, so a command that
covers several cells opens one session per cell. A cell started elsewhere (compose, another
host) is reached with ``--zenoh-connect``, plus ``--cell`` and ``--credentials`` when its bus
is secured; on an open bus the command acts on every cell the router carries.
"""

from __future__ import annotations

import argparse
import difflib
import sys
from dataclasses import dataclass
from pathlib import Path

import zenoh

from motocell.shared import registry
from motocell.shared.bus.access import SITE_OBSERVER, Identity
from motocell.shared.bus.credentials import CredentialsError, load, load_user, password_path
from motocell.shared.bus.keys import ALIVE_ROOT
from motocell.shared.bus.session import NoRouterError as NothingListens
from motocell.shared.bus.session import open_session

ANY_CELL = "*"
"""The cell level of a key expression that matches every cell (open bus, cells not named)."""
_FORBIDDEN_IN_NAME = set("/*$#?")
"""Key-expression syntax: a name with these would select more than one cell's keys."""
WELL_KNOWN_ENDPOINT = "tcp/127.0.0.1:7447"
"""Where the first cell started here has its router, for the help: the value of
``services.launcher.core.endpoints.WELL_KNOWN_ENDPOINT`` (tests/tools/test_cli.py checks the
help names that one), not an import of it, which would load the launcher and the cell-file
reader with it, a fifth of the CPU `motocell ps` and `motocell fault` spend."""
NOTHING_RUNNING = (
    "no cell is running here (start one with `motocell up`; reach a cell started elsewhere "
    "with --zenoh-connect)"
)


class CellsError(Exception):
    """One line for the person at the terminal, and the command's exit status."""

    status = 1


class TargetError(CellsError):
    """The command cannot tell which cell it means: a name not running, or two candidates."""

    status = 2


class JoinError(CellsError):
    """A cell's bus cannot be joined: the message says why and what to do."""


class UnusableCredentialsError(JoinError):
    """The credentials given cannot be used as they are (missing, open to other users, no
    small file): the user's to fix, status 2 as for any mistake."""

    status = 2


class NoRouterError(JoinError):
    """Nothing listens at the target's endpoint (yet): a command that can wait for it may."""


@dataclass(frozen=True)
class Target:
    """One router to join, the cells to act on there, and where the credentials are."""

    endpoint: str
    cells: tuple[str, ...]
    """Empty: every cell the router carries (an open bus only: credentials are per cell)."""
    credentials: Path | None = None
    """The cell's credentials directory; None for an open bus."""
    launcher: int = 0
    """The pid of the launcher that registered the cell; 0 for a router named outright. A
    cell started again under its name is another bus (new credentials) though nothing
    else of its target differs."""

    @property
    def names(self) -> tuple[str, ...]:
        """The cell level of this target's key expressions."""
        return self.cells or (ANY_CELL,)

    def describe(self) -> str:
        return f"cell {', '.join(self.cells)}" if self.cells else self.endpoint

    def explain(self, problem: object) -> str:
        """``problem`` with the cell it concerns, when the target names one."""
        return f"cell {', '.join(self.cells)}: {problem}" if self.cells else str(problem)


def add_arguments(parser: argparse.ArgumentParser, *, several: bool) -> None:
    """``--cell`` (repeatable when ``several``), ``--zenoh-connect`` and ``--credentials``."""
    if several:
        parser.add_argument(
            "--cell",
            action="append",
            default=[],
            metavar="NAME",
            help="only this cell (repeatable; default: every cell running here)",
        )
    else:
        parser.add_argument(
            "--cell", metavar="NAME", help="the cell (default: the one cell running here)"
        )
    parser.add_argument(
        "--zenoh-connect",
        metavar="ENDPOINT",
        help="a router of a cell not started on this machine (compose, another host), e.g. "
        "tcp/robot-pc:7447; default: each cell's own router, as `motocell up` registered it "
        f"in {registry.runtime_dir()} (the first cell takes {WELL_KNOWN_ENDPOINT} when free)",
    )
    parser.add_argument(
        "--credentials",
        metavar="DIR",
        help="with --zenoh-connect and --cell: that cell's credentials directory "
        "(motocell credentials); without it the bus must be open",
    )


def cells_named(args: argparse.Namespace) -> list[str]:
    """The ``--cell`` names given, each once, in order; TargetError for a wildcard."""
    given: list[str] = [args.cell] if isinstance(args.cell, str) else list(args.cell or [])
    for name in given:
        if not name or _FORBIDDEN_IN_NAME & set(name):
            raise TargetError(f"not a cell name: {name!r}")
    return list(dict.fromkeys(given))


def targets(args: argparse.Namespace) -> list[Target]:
    """Where the cells the command names are. From the registry unless ``--zenoh-connect``
    names a router; an empty list when no cell runs here. TargetError (NoSuchCellError's
    message: the cells that do run) for a name that is not running."""
    cells = cells_named(args)
    if args.zenoh_connect is None:
        if args.credentials is not None:
            raise TargetError(
                "--credentials goes with --zenoh-connect: a cell started here is found with "
                "its own credentials"
            )
        try:
            entries = [registry.find(name) for name in cells] if cells else registry.running()
        except registry.NoSuchCellError as exc:
            raise TargetError(f"{exc}{_did_you_mean(cells)}") from None
        return [
            Target(
                entry.zenoh_endpoint,
                (entry.name,),
                Path(entry.credentials) if entry.credentials else None,
                entry.pid,
            )
            for entry in entries
        ]
    if args.credentials is None:
        return [Target(args.zenoh_connect, tuple(cells))]
    credentials = Path(args.credentials)
    if len(cells) != 1 and not password_path(credentials, SITE_OBSERVER).is_file():
        raise TargetError(
            "--credentials needs one --cell: credentials belong to one cell (a site's, with "
            f"its {SITE_OBSERVER}, watch every cell: docs/site.md)"
        )
    return [Target(args.zenoh_connect, tuple(cells), credentials)]


def _did_you_mean(names: list[str]) -> str:
    """ "; did you mean arm?" for a name that is not running but close to one that is."""
    running = [entry.name for entry in registry.running()]
    for name in names:
        close = difflib.get_close_matches(name, running, n=1)
        if name not in running and close:
            return f"; did you mean {close[0]}?"
    return ""


def some_targets(args: argparse.Namespace) -> list[Target]:
    """``targets``, or TargetError when no cell runs here."""
    found = targets(args)
    if not found:
        raise TargetError(NOTHING_RUNNING)
    return found


def failed(command: str, error: CellsError) -> int:
    """Report ``error`` as ``motocell <command>`` and give its exit status."""
    print(f"motocell {command}: {error}", file=sys.stderr)
    return error.status


def join(target: Target, identity: Identity) -> zenoh.Session:
    """A session on ``target``'s bus as ``identity``; JoinError at once if that fails (no
    router there, or the credentials refused: Zenoh answers both within milliseconds)."""
    credentials = None
    if target.credentials is not None:
        try:
            credentials = (
                load(target.credentials, target.cells[0], identity)
                if len(target.cells) == 1
                else load_user(target.credentials, SITE_OBSERVER)
            )
        except CredentialsError as exc:
            raise UnusableCredentialsError(target.explain(exc)) from None
    try:
        return open_session("client", [target.endpoint], wait=False, credentials=credentials)
    except NothingListens as exc:
        raise NoRouterError(target.explain(exc)) from None
    except ConnectionError as exc:
        raise JoinError(target.explain(exc)) from None


def join_all(found: list[Target], identity: Identity) -> list[tuple[Target, zenoh.Session]]:
    """A session on every target; JoinError (and nothing left open) if one cannot be joined."""
    joined: list[tuple[Target, zenoh.Session]] = []
    try:
        for target in found:
            joined.append((target, join(target, identity)))
    except JoinError:
        close_all(joined)
        raise
    return joined


def close_all(joined: list[tuple[Target, zenoh.Session]]) -> None:
    for _, session in joined:
        session.close()


def cells_on(session: zenoh.Session, timeout: float = 2.0) -> list[str]:
    """The cells with a live service behind ``session``'s router (an open bus shows all)."""
    replies = session.liveliness().get(f"{ALIVE_ROOT}/{ANY_CELL}/alive/*/*", timeout=timeout)
    return sorted({str(reply.ok.key_expr).split("/")[1] for reply in replies if reply.ok})
