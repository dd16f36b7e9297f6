"""motocell: run and watch simulated Yaskawa Motoman cells that ROS-Industrial's
motoman_driver drives as it would a controller running MotoROS."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable, Sequence
from typing import Any, cast

from motocell.services.launcher import cli as launcher_cli
from motocell.services.launcher import up as launcher
from motocell.shared.service import version
from motocell.tools import (
    bench,
    credentials,
    echo,
    fault,
    hz,
    observe,
    plot,
    record,
    service,
    view,
)


class CommandParser(argparse.ArgumentParser):
    """A subcommand's parser whose options a ``fill`` function may add only when that command
    runs, so that a command whose module is slow to import (the benchmark suite imports numpy)
    costs nothing to the others: every command builds the whole parser, and `motocell up`
    does so before it starts a single service."""

    def __init__(
        self,
        *args: Any,
        fill: Callable[[argparse.ArgumentParser], None] | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(*args, **kwargs)
        self._fill = fill

    def parse_known_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        # argparse hands a chosen subcommand its arguments through this method.
        if self._fill is not None:
            fill, self._fill = self._fill, None
            fill(self)
        return super().parse_known_args(args, namespace)


class ShowVersion(argparse.Action):
    """``--version``, looked up only when asked (importlib.metadata takes 10-20 ms to import)."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS) -> None:
        super().__init__(option_strings, dest, nargs=0, help="show the version and exit")

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: object,
        option_string: str | None = None,
    ) -> None:
        print(f"motocell {version()}")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="motocell", description=__doc__, allow_abbrev=False)
    parser.add_argument("--version", action=ShowVersion)
    # Every command module takes the usual subparsers; they may pass ``fill`` through.
    commands = cast(
        "argparse._SubParsersAction[argparse.ArgumentParser]",
        parser.add_subparsers(dest="command", required=True, parser_class=CommandParser),
    )

    up = commands.add_parser("up", help="run a whole cell in the foreground")
    launcher_cli.add_arguments(up)
    up.set_defaults(run=launcher.run)

    fault.add_parser(commands)
    observe.add_parsers(commands)
    echo.add_parser(commands)
    hz.add_parser(commands)
    record.add_parser(commands)
    view.add_parser(commands)
    plot.add_parser(commands)
    bench.add_parser(commands)
    credentials.add_parser(commands)

    service.add_parser(commands)

    router = commands.add_parser(
        "router", help="a Zenoh router (a stand-in for zenohd where its image is not available)"
    )
    launcher_cli.add_router_arguments(router)
    router.set_defaults(run=launcher.router)

    commands.add_parser(
        "demo",
        help="start a cell and drive it like motoman_driver does, then stop it",
        fill=_demo_arguments,
    )
    for subcommand in commands.choices.values():
        # No abbreviated options anywhere: `--port-bas` must not silently mean `--port-base`.
        subcommand.allow_abbrev = False
        subcommand.add_argument("--version", action=ShowVersion)
    return parser


def _demo_arguments(parser: argparse.ArgumentParser) -> None:
    # numpy and the test kit: only for `motocell demo`.
    from motocell.tools import demo  # noqa: PLC0415

    demo.add_arguments(parser)


def main(argv: Sequence[str] | None = None) -> None:
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s motocell %(levelname)s %(message)s")
    sys.exit(args.run(args))


if __name__ == "__main__":
    main()
