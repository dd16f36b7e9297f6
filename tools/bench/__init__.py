"""``motocell bench``: the benchmark suite (``tools.bench.run``), installed with motocell."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``motocell bench`` (``tools.cli`` names the command)."""
    # The suite imports numpy and every benchmark: only for `motocell bench` (tools.cli fills
    # a command's parser only when that command runs).
    from motocell.tools.bench import run as suite  # noqa: PLC0415

    parser.description = (
        f"Run the benchmark suite (figures 1-{len(suite.FIGURES)}): median and [min-max] of at "
        "least 3 runs each, printed as a table and written to <timestamp>.json and latest.json "
        "in --out. The full suite takes a quarter of an hour or more, --quick a few minutes."
    )

    suite.add_arguments(parser)
    parser.set_defaults(run=suite.run)
