"""The options of ``motocell up`` (``python -m motocell.services.launcher``, which ``motocell
up`` runs: ``parser``) and ``motocell router`` (a subcommand ``tools.cli`` builds from
``add_router_arguments``)."""

from __future__ import annotations

import argparse

from motocell import __version__
from motocell.services.launcher.core.endpoints import WELL_KNOWN_ENDPOINT
from motocell.services.launcher.core.tcp_ports import PORT_BASE_AUTO
from motocell.services.launcher.lifeline import lifeline_argument
from motocell.shared.service import add_cell_arguments


def parser() -> argparse.ArgumentParser:
    """``motocell up``'s parser."""
    up = argparse.ArgumentParser(prog="motocell up", allow_abbrev=False)
    add_arguments(up)
    up.add_argument("--version", action="version", version=f"motocell {__version__}")
    return up


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``motocell up``."""
    parser.description = (
        "Run a whole cell in the foreground until Ctrl-C (or SIGTERM): its Zenoh router and "
        "every service as a process of its own. One line, `cell NAME ready: ...` with its "
        "ports and Zenoh endpoint, says when clients can connect."
    )
    add_cell_arguments(parser)
    parser.add_argument(
        "--host", help="address the TCP ports listen on (default: the cell file's, 127.0.0.1)"
    )
    parser.add_argument(
        "--port-base",
        metavar="N",
        help=f"motion port N, state N+1, I/O N+2 (default: the cell file's, 50240); "
        f"{PORT_BASE_AUTO}: three free ports, which the ready line prints",
    )
    parser.add_argument(
        "--byte-order",
        choices=("little", "big"),
        help="override the controller's (FS100 big, others little)",
    )
    parser.add_argument(
        "--skip",
        action="append",
        default=[],
        metavar="SERVICE",
        help="do not start this service here, to run it elsewhere with `motocell service "
        "SERVICE`: gateway (or gateway/0), interpolator/1, ... as logs and `motocell watch` "
        "name them (repeatable); the cell is NOT_READY until it joins",
    )
    parser.add_argument(
        "--zenoh-listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help=f"where the cell's own router listens (repeatable; default {WELL_KNOWN_ENDPOINT} "
        "when that port is free, else a free port: the ready line and `motocell ps` show it)",
    )
    parser.add_argument(
        "--zenoh-connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="join this Zenoh router, which runs already (compose, another host), instead of "
        "running the cell's own (repeatable)",
    )
    parser.add_argument(
        "--credentials",
        metavar="DIR",
        help="with --zenoh-connect to a secured router: the cell's credentials directory "
        "(`motocell credentials`); without --zenoh-connect the cell writes its own",
    )
    parser.add_argument(
        "--open-bus",
        action="store_true",
        help="no credentials and no access control: anyone who reaches the router can move "
        "the robot. Only for a trusted lab network (see docs/security.md)",
    )
    parser.add_argument(
        "--cold",
        action="store_true",
        help="start every service as a fresh interpreter instead of a fork of the warm parent "
        "that has imported them (slower; for comparison and debugging, docs/startup.md)",
    )
    # The warm parent, forked before this parser existed (``warm_parent.fork_zygote``): the
    # launcher's ``__main__`` puts it here, and ``up.run`` takes it; None runs the cell cold.
    parser.set_defaults(warm_parent=None)
    add_lifeline_argument(parser, "cell")
    parser.add_argument(
        "--lifeline-scratch",
        action="append",
        default=[],
        metavar="DIR",
        help="with --lifeline: a directory the starting program made for this cell alone (its "
        "registry, credentials, cell file), removed once the cell stopped because the lifeline "
        "ended (repeatable)",
    )


def add_lifeline_argument(parser: argparse.ArgumentParser, what: str) -> None:
    parser.add_argument(
        "--lifeline",
        type=lifeline_argument,
        metavar="FD",
        help=f"for a program that starts the {what} and must not leave it behind "
        "(motocell.testing): the read end of a pipe whose write end that program alone holds; "
        f"when the program ends, however it ends, the pipe reads end of file and the {what} "
        "stops",
    )


def add_router_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``motocell router``."""
    parser.description = "A Zenoh router in the foreground until Ctrl-C (or SIGTERM)."
    parser.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help=f"where it listens (repeatable; default {WELL_KNOWN_ENDPOINT})",
    )
    parser.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="another router to link to (repeatable; default: none)",
    )
    parser.add_argument(
        "--config",
        metavar="FILE",
        help="run from a Zenoh router config file instead, as `zenohd -c FILE` does (e.g. "
        "deploy/zenoh/router.json5); --listen/--connect are then ignored",
    )
    add_lifeline_argument(parser, "router")
