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
    from motocell.shared.config import ConfigError
    from motocell.testing.under_test import CellUnderTest, FaultError, StartCell, cell, cells

__all__ = ["CellUnderTest", "ConfigError", "FaultError", "StartCell", "cell", "cells"]
"""``ConfigError`` (``motocell.shared.config``'s): a cell asked for with a field it cannot take
(``cell(byte_order="middle")``), raised before anything starts, naming the field and what it
takes. The others are ``under_test``'s."""


def __getattr__(name: str) -> object:
    if name not in __all__:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    home = "motocell.shared.config" if name == "ConfigError" else "motocell.testing.under_test"
    return getattr(importlib.import_module(home), name)
