"""The metrics' rolling window: its percentiles are numpy's, without numpy's masked arrays."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from motocell.shared.metrics import Window, percentile


@pytest.mark.parametrize("count", [1, 2, 3, 10, 99, 100, 101, 1000])
def test_the_percentiles_are_numpys_linear_ones(count: int) -> None:
    values = np.random.default_rng(count).exponential(100.0, count)
    ordered = np.sort(values)
    for q in (0, 1, 50, 99, 99.9, 100):
        assert percentile(ordered, q) == pytest.approx(float(np.percentile(values, q)), rel=1e-12)


def test_a_window_keeps_the_last_values_and_summarises_them() -> None:
    window = Window(4)
    assert window.summary().count == 0
    for value in (100.0, 1.0, 2.0, 3.0, 4.0):
        window.add(value)
    summary = window.summary()
    assert (summary.count, summary.max_us) == (4, 4.0)
    assert summary.p50_us == pytest.approx(2.5)
    window.clear()
    assert window.summary().count == 0


@pytest.mark.cell  # a fresh interpreter: this one may have imported numpy.ma for another test
def test_a_summary_imports_no_masked_arrays() -> None:
    """numpy.percentile's first call imports numpy.ma: pages of their own in every fork."""
    code = (
        "import sys\n"
        "from motocell.shared.metrics import Window\n"
        "w = Window(8)\n"
        "w.add(1.0)\n"
        "w.summary()\n"
        "print('numpy.ma' in sys.modules)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True
    )
    assert done.stdout.strip() == "False"
