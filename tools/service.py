"""``motocell service NAME [OPTIONS]``: one service of a cell in the foreground, run as
``motocell up`` runs it (``python -m motocell.services.<service>`` with this interpreter), typically
on another host than the rest of the cell (``motocell up --skip NAME`` there)."""

from __future__ import annotations

import argparse
import os
import signal
import sys

from motocell.shared.config import EXIT_CONFIG
from motocell.shared.service_names import PER_GROUP, SERVICES, UnknownServiceError, service_kind

EXAMPLE = (
    "motocell service interpolator/1 --config cell.toml --zenoh-connect tls/HOST:7447 "
    "--credentials DIR"
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``motocell service`` (``tools.cli`` names the command)."""
    parser.description = (
        "Run one service of a cell in the foreground, as `motocell up` runs it "
        "(python -m motocell.services.<service> with this interpreter): typically one that "
        f"`motocell up --skip NAME` leaves to another host. For example: {EXAMPLE}"
    )
    parser.add_argument(
        "name",
        metavar="NAME",
        help=f"{', '.join(s for s in SERVICES if s != PER_GROUP)}, or {PER_GROUP}/GROUP "
        f"(as logs, `motocell watch` and `--skip` name them; gateway/0 is gateway)",
    )
    parser.add_argument(
        "options",
        nargs=argparse.REMAINDER,
        metavar="OPTIONS",
        help="the service's own (`motocell service NAME --help` lists them)",
    )
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Replace this process with the service; only returns to refuse a name."""
    try:
        command = service_command(args.name, args.options)
    except UnknownServiceError as exc:
        print(f"motocell service: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    # Held until the service's handlers are in place (shared.service.stop_on_signals): a
    # Ctrl-C while it loads then stops it cleanly, not with a traceback from its imports.
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    # No priority here: the service takes its own once its imports are done. Imports at the
    # services' priority would refuse a second service sooner beside busy loops, but starve the
    # cells already running (shared.realtime leave_service_priority), whose motion matters more
    # than a refusal's speed (measured: docs/realtime.md, The other threads).
    os.execv(command[0], command)


def service_command(name: str, options: list[str]) -> list[str]:
    """The command line that runs service ``name`` with ``options``; UnknownServiceError for
    a name that is no service."""
    service, instance = service_kind(name)
    extra = []
    if instance is not None and service == PER_GROUP:
        if any(option.split("=")[0] == "--group" for option in options):
            raise UnknownServiceError(f"{name} names its group: leave out --group")
        extra = ["--group", instance]
    return [sys.executable, "-m", f"motocell.services.{service}", *extra, *options]
