"""Started motocell cells for users' own tests: ``cell()`` and ``cells()`` (context managers,
for any test runner), ``cell_fixture`` (a pytest fixture of a configured cell at any scope) and
the pytest plugin's fixtures (``motocell.testing.plugin``); docs/testing-with-motocell.md.

pytest imports the plugin, and so this package, in every run of every project where motocell
is installed: the names below load their modules (Zenoh, numpy, the harness) on first use.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from motocell.shared.bus.schemas import Alarm, MotionHolder
    from motocell.shared.config import ConfigError
    from motocell.testing.cell_status import CellStatus
    from motocell.testing.fixtures import cell_fixture
    from motocell.testing.under_test import CellUnderTest, FaultError, StartCell, cell, cells

HOMES: dict[str, str] = {
    "Alarm": "motocell.shared.bus.schemas",
    "CellStatus": "motocell.testing.cell_status",
    "CellUnderTest": "motocell.testing.under_test",
    "ConfigError": "motocell.shared.config",
    "FaultError": "motocell.testing.under_test",
    "MotionHolder": "motocell.shared.bus.schemas",
    "StartCell": "motocell.testing.under_test",
    "cell": "motocell.testing.under_test",
    "cell_fixture": "motocell.testing.fixtures",
    "cells": "motocell.testing.under_test",
}
"""Each name's module. ``Alarm`` and ``MotionHolder``: what ``CellStatus`` holds, for a test
to compare with. ``ConfigError`` (``motocell.shared.config``'s): a cell asked for with a
field it cannot take (``cell(byte_order="middle")``), raised before anything starts, naming
the field and what it takes."""
__all__ = [
    "Alarm",
    "CellStatus",
    "CellUnderTest",
    "ConfigError",
    "FaultError",
    "MotionHolder",
    "StartCell",
    "cell",
    "cell_fixture",
    "cells",
]


def __getattr__(name: str) -> object:
    if name not in HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(HOMES[name]), name)
