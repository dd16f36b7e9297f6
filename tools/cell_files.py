"""The cell files of the cells a command shows: what ``motocell view`` and ``motocell record``
need to draw a cell in 3D (its groups' robot models and their places in the cell).

A cell started on this machine is drawn from the file its launcher registered; a cell reached
with ``--zenoh-connect`` from the ``--config`` file that holds its name.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable

from motocell.shared import registry
from motocell.shared.config import Cell, ConfigError, load_cell
from motocell.tools.cells import Target


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--config",
        action="append",
        default=[],
        metavar="FILE",
        help="the cell file of a cell not started here, for its 3D scene (repeatable); a cell "
        "started here is drawn from the file it runs",
    )


def given(paths: list[str]) -> dict[str, Cell]:
    """The ``--config`` files by the cell name each holds; ConfigError for a bad one."""
    loaded = [load_cell(path) for path in paths]
    return {cell.name: cell for cell in loaded}


def started_here(targets: Iterable[Target], command: str) -> dict[str, Cell]:
    """The cell files of the cells started on this machine, as their launchers registered
    them. A file that cannot be read any more is said on stderr and left out: that cell gets
    no 3D scene, everything else still shows."""
    found: dict[str, Cell] = {}
    for target in targets:
        if not target.launcher:
            continue  # a router named outright: its cells' files come from --config
        for name in target.cells:
            try:
                entry = registry.find(name)
                found[name] = load_cell(entry.config or None, name)
            except (registry.NoSuchCellError, ConfigError) as exc:
                print(f"motocell {command}: cell {name}: no 3D scene: {exc}", file=sys.stderr)
    return found


def known(targets: Iterable[Target], paths: list[str], command: str) -> dict[str, Cell]:
    """Every cell file the command has: registered ones, overridden by ``--config``."""
    return {**started_here(targets, command), **given(paths)}
