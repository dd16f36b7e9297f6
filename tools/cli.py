"""motocell: run and watch simulated Yaskawa Motoman cells that ROS-Industrial's motoman_driver
drives as it would a controller running MotoROS."""

from __future__ import annotations

import argparse
import importlib
import logging
import sys
from collections.abc import Sequence
from typing import Any, cast

from motocell import __version__
from motocell.shared.signals import release_stop_signals

COMMANDS = (
    ("up", "run a whole cell in the foreground"),
    ("fault", "inject or clear a fault in a running cell"),
    ("ps", "list every live service of the cells running here, their ports and bus"),
    ("watch", "a live view of the cells running here"),
    ("echo", "print a key's samples as JSON lines (like rostopic echo)"),
    ("hz", "print how often a key's samples arrive (like rostopic hz)"),
    ("record", "record every sample of running cells into an MCAP file"),
    ("view", "serve the running cells live to Foxglove (3D scene, joints, status)"),
    ("plot", "plot a recording (motocell record) as a PNG"),
    ("bench", "run the benchmark suite: print a table, write JSON results"),
    ("credentials", "make, add to or renew a deployment's passwords and TLS certificates"),
    ("site", "write one Zenoh router's configuration for several secured cells (a site)"),
    (
        "service",
        "run one service of a cell in the foreground (one that `motocell up --skip` leaves out)",
    ),
    ("router", "a Zenoh router (a stand-in for zenohd where its image is not available)"),
    ("demo", "start a cell and drive it like motoman_driver does, then stop it"),
)
"""Every command and its line in ``motocell --help``: the one place that knows them all, so
that listing them imports none. Each is the module ``motocell.tools.<name>``, whose
``add_arguments(parser)`` gives the command its description, options and ``run``; ``up`` and
``router`` are the launcher's (``services.launcher``)."""


class CommandParser(argparse.ArgumentParser):
    """A command's parser, filled (its module imported, its options added) only when that
    command runs: a command costs the others nothing. The light ones (``ps``, ``watch``,
    ``fault``, ``echo``, ``hz``) are mostly imports, and `motocell up` parses its options
    before it starts a single service; filling every parser would import every command's
    module (Zenoh sessions, the launcher, the benchmark suite's numpy) into each of them."""

    def __init__(self, *args: Any, command: str, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # No abbreviated options anywhere: `--port-bas` must not silently mean `--port-base`.
        self.allow_abbrev = False
        self.command = command
        self.filled = False

    def parse_known_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        # argparse hands a chosen subcommand its arguments through this method.
        if not self.filled:
            self.filled = True
            fill(self.command, self)
            self.add_argument("--version", action=ShowVersion)
        return super().parse_known_args(args, namespace)


def fill(command: str, parser: argparse.ArgumentParser) -> None:
    """``command``'s description, options and ``run``, imported now."""
    if command == "router":
        # The launcher's router (its configuration, its process).
        from motocell.services.launcher import cli as launcher_cli  # noqa: PLC0415
        from motocell.services.launcher import up as launcher  # noqa: PLC0415

        launcher_cli.add_router_arguments(parser)
        parser.set_defaults(run=launcher.router)
        return
    # Imported here, not at the top: only the command that runs (CommandParser).
    module = importlib.import_module(f"motocell.tools.{command}")
    module.add_arguments(parser)


class ShowVersion(argparse.Action):
    """``--version``."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS) -> None:
        super().__init__(option_strings, dest, nargs=0, help="show the version and exit")

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: object,
        option_string: str | None = None,
    ) -> None:
        print(f"motocell {__version__}")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="motocell", description=__doc__, allow_abbrev=False)
    parser.add_argument("--version", action=ShowVersion)
    commands = cast(
        "argparse._SubParsersAction[argparse.ArgumentParser]",
        parser.add_subparsers(dest="command", required=True, parser_class=CommandParser),
    )
    for name, help_ in COMMANDS:
        commands.add_parser(name, help=help_, command=name)
    return parser


OWN_SIGNALS = frozenset({"up", "router", "watch", "echo", "hz", "record", "service"})
"""The commands that take SIGINT and SIGTERM themselves once their handlers are in place
(``shared.service.stop_on_signals``; ``service`` execs a service that does): until then the two
stay held (``tools.__main__``), so one that comes while they start stops them there, cleanly."""


def main(argv: Sequence[str] | None = None) -> None:
    words = list(sys.argv[1:] if argv is None else argv)
    if words[:1] == ["up"]:
        # The launcher's own ``__main__``: it forks its warm parent once its modules are in,
        # before anything of this module's parser would load (docs/startup.md).
        from motocell.services.launcher.__main__ import launch  # noqa: PLC0415

        launch(words[1:])
    args = build_parser().parse_args(words)
    if args.command not in OWN_SIGNALS:
        # Held while the command loaded (tools.__main__); it stops on them from here on.
        release_stop_signals()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s motocell %(levelname)s %(message)s")
    sys.exit(args.run(args))


if __name__ == "__main__":
    main()
