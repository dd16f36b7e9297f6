"""Started motocell cells for users' own tests: ``cell()`` and ``cells()`` (context managers,
for any test runner) and the pytest plugin's fixtures (``motocell.testing.plugin``);
docs/testing-with-motocell.md.

pytest imports the plugin, and so this package, in every run of every project where motocell
is installed: the names below load their modules (Zenoh, numpy, the harness) on first use.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from motocell.testing.under_test import CellUnderTest, FaultError, StartCell, cell, cells

__all__ = ["CellUnderTest", "FaultError", "StartCell", "cell", "cells"]


def __getattr__(name: str) -> object:
    if name not in __all__:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module("motocell.testing.under_test"), name)
