"""``motocell bench``: the benchmark suite (``bench/run.py``), from a source checkout.

The ``bench`` package lives at the repository root and is not installed with motocell, so this
command finds it next to this file's checkout (an editable install) or in the current
directory, and says so clearly when it is not there.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path
from typing import Any

HINT = (
    "motocell bench: the benchmark suite (bench/) is not importable. It ships only with the "
    "source tree: run it from the repository root (e.g. `cd motocell && .venv/bin/motocell "
    "bench`) with motocell installed editable (`pip install -e .`)."
)


def add_parser(commands: Any) -> None:
    bench = commands.add_parser(
        "bench",
        help="run the benchmark suite: print a table, write JSON to bench/results/",
        description="Run the benchmark suite (figures 1-9): median and [min-max] of at least "
        "3 runs each, printed as a table and written to bench/results/<timestamp>.json and "
        "latest.json. The full suite takes about 11 minutes, --quick about one.",
    )
    bench.add_argument("--quick", action="store_true", help="every benchmark briefly (~1 min)")
    bench.add_argument("--only", metavar="N,N", help="only these figures, e.g. 3,6")
    bench.set_defaults(run=run)


def _import_suite() -> Any:
    candidates = [Path(__file__).resolve().parents[2], Path.cwd()]
    for root in [None, *candidates]:
        if root is not None:
            if not (root / "bench" / "run.py").is_file():
                continue
            if str(root) not in sys.path:
                sys.path.insert(0, str(root))
        try:
            return importlib.import_module("bench.run")
        except ModuleNotFoundError as exc:
            if exc.name not in ("bench", "bench.run"):
                raise
    return None


def run(args: argparse.Namespace) -> int:
    suite = _import_suite()
    if suite is None:
        print(HINT, file=sys.stderr)
        return 2
    figures: list[int] = suite.parse_only(args.only)
    status: int = suite.run_suite(args.quick, figures)
    return status
