"""``motocell bench``: the benchmark suite (``bench.run``), installed with motocell."""

from __future__ import annotations

import argparse

from bench import run as suite


def add_parser(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    bench = commands.add_parser(
        "bench",
        help="run the benchmark suite: print a table, write JSON results",
        description="Run the benchmark suite (figures 1-9): median and [min-max] of at least "
        "3 runs each, printed as a table and written to <timestamp>.json and latest.json in "
        "--out. The full suite takes about 11 minutes, --quick about one.",
    )
    suite.add_arguments(bench)
    bench.set_defaults(run=suite.run)
