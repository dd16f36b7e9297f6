"""The cells ``motocell view`` and ``motocell record`` observe, and the cell files they need to
draw each cell in 3D (its groups' robot models and their places in the cell).

A cell started on this machine is drawn from the file its launcher registered; a cell reached
with ``--zenoh-connect`` from the ``--config`` file that holds its name.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Iterable

import zenoh

from motocell.shared import registry
from motocell.shared.bus.access import Identity
from motocell.shared.bus.catalog import Role
from motocell.shared.config import Cell, ConfigError, load_cell
from motocell.tools import cells
from motocell.tools.cells import CellsError, Target

OBSERVER = Identity(Role.OBSERVER)
"""Who the commands join as: a secured cell's router lets it receive, never send."""

Joined = list[tuple[Target, zenoh.Session]]
Body = Callable[[Joined, dict[str, Cell]], int]
"""What a command does with the cells joined and their cell files; its exit status."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """``--config`` and ``--duration``."""
    parser.add_argument(
        "--config",
        action="append",
        default=[],
        metavar="FILE",
        help="the cell file of a cell not started here, for its 3D scene (repeatable); a cell "
        "started here is drawn from the file it runs",
    )
    parser.add_argument(
        "--duration", type=float, metavar="S", help="stop after S seconds (default: at Ctrl-C)"
    )


def observe(args: argparse.Namespace, command: str, body: Body) -> int:
    """``body`` on the cells ``args`` names, each joined as its observer, with their cell files;
    the sessions closed after. A ``--duration`` that is not positive, a cell that cannot be
    joined or a bad ``--config`` file costs one line on stderr and the command's exit status."""
    if args.duration is not None and not args.duration > 0:
        print(f"motocell {command}: --duration must be positive", file=sys.stderr)
        return 2
    try:
        joined = cells.join_all(cells.some_targets(args), OBSERVER)
    except CellsError as exc:
        return cells.failed(command, exc)
    try:
        files = known((target for target, _ in joined), args.config, command)
    except ConfigError as exc:
        cells.close_all(joined)
        print(f"motocell {command}: {exc}", file=sys.stderr)
        return 2
    try:
        return body(joined, files)
    finally:
        cells.close_all(joined)


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
