"""``python -m motocell.services.launcher`` (``motocell up``): the options in ``cli``, the cell
in ``up``; this module wires them."""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence

from motocell.services.launcher.cli import add_arguments
from motocell.services.launcher.up import run


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m motocell.services.launcher",
        description="Run a whole cell.",
        allow_abbrev=False,
    )
    add_arguments(parser)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s motocell %(levelname)s %(message)s")
    sys.exit(run(args))


if __name__ == "__main__":
    main()
