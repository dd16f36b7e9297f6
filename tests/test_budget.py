"""The fast lane's CPU budget (``tests/budget.py``): a run of the whole lane with a test or
the lane over budget fails, in one line naming them; a narrower run is not held to it."""

from __future__ import annotations

import re
import textwrap

import pytest

from tests import budget
from tests.budget import Budget, CpuBudget, failure, overruns, spent

pytest_plugins = ["pytester"]

TIGHT = Budget(test_s=0.05, lane_s=1000.0)


def test_within_budget_nothing_is_over_and_the_cost_is_said() -> None:
    plan = Budget(test_s=2.0, lane_s=30.0)
    assert overruns(plan, {"a": 1.9, "b": 0.1}, 29.0) == []
    assert spent(plan, {"a": 1.94, "b": 0.1}, 29.04) == (
        "the fast lane's CPU time: 29.0 s (budget 30 s), its costliest test 1.9 s (budget 2 s)"
    )


def test_the_lane_then_each_test_over_budget_costliest_first() -> None:
    over = overruns(Budget(test_s=2.0, lane_s=30.0), {"a": 2.5, "b": 0.1, "c": 4.0}, 31.0)
    assert over == [
        "the lane 31.0 s (budget 30 s)",
        "c 4.0 s (budget 2 s)",
        "a 2.5 s (budget 2 s)",
    ]
    assert failure(over) == (
        "the fast lane went over its CPU budget (tests/budget.py): "
        "the lane 31.0 s (budget 30 s); c 4.0 s (budget 2 s); a 2.5 s (budget 2 s)"
    )


INNER = """
import time

import pytest


def test_burns():
    end = time.process_time() + 0.1
    while time.process_time() < end:
        pass


def test_idles():
    pass


@pytest.mark.cell
def test_of_the_cell_lane():
    pass
"""


@pytest.fixture
def inner(pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch) -> pytest.Pytester:
    """A suite of its own, run in this process: untraced as far as the budget knows, so the
    check runs under coverage or a debugger too."""
    monkeypatch.setattr(budget, "traced", lambda config: False)
    pytester.makeini("[pytest]\nmarkers =\n    cell: the slow lane\n")
    pytester.makepyfile(test_inner=textwrap.dedent(INNER))
    return pytester


def run(inner: pytest.Pytester, plan: Budget, *args: str) -> pytest.RunResult:
    return inner.runpytest_inprocess("-p", "no:cacheprovider", *args, plugins=[CpuBudget(plan)])


def test_a_test_over_budget_fails_the_whole_lane_naming_it(inner: pytest.Pytester) -> None:
    result = run(inner, TIGHT, "-m", "not cell")
    result.assert_outcomes(passed=2, deselected=1)
    assert result.ret == pytest.ExitCode.TESTS_FAILED
    (line,) = [line for line in result.outlines if "CPU budget" in line]
    assert line.startswith("the fast lane went over its CPU budget (tests/budget.py): ")
    assert re.search(r"test_inner.py::test_burns \d+\.\d s \(budget 0.05 s\)", line), line
    assert "test_idles" not in line


def test_the_lane_over_budget_fails_it(inner: pytest.Pytester) -> None:
    result = run(inner, Budget(test_s=1000.0, lane_s=0.1), "-m", "not cell")
    assert result.ret == pytest.ExitCode.TESTS_FAILED
    result.stdout.fnmatch_lines(["*CPU budget (tests/budget.py): the lane 0.* s (budget 0.1 s)"])


def test_within_budget_the_lane_passes_saying_what_it_cost(inner: pytest.Pytester) -> None:
    result = run(inner, Budget(test_s=100.0, lane_s=1000.0), "-m", "not cell")
    assert result.ret == pytest.ExitCode.OK
    result.stdout.fnmatch_lines(["the fast lane's CPU time: * s (budget 1000 s), its costliest *"])


@pytest.mark.parametrize(
    "narrowed",
    [
        ["-m", "not cell", "-k", "burns"],
        ["-m", "not cell", "test_inner.py"],
        ["-m", "not cell", "--deselect", "test_inner.py::test_idles"],
        [],
        ["-m", "cell or not cell"],
    ],
    ids=["keyword", "path", "deselect", "whole suite", "another mark expression"],
)
def test_a_run_other_than_the_whole_fast_lane_is_not_held_to_it(
    inner: pytest.Pytester, narrowed: list[str]
) -> None:
    result = run(inner, TIGHT, *narrowed)
    assert result.ret == pytest.ExitCode.OK
    assert not [line for line in result.outlines if "the fast lane" in line]


def test_a_traced_run_is_not_held_to_it(
    inner: pytest.Pytester, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(budget, "traced", lambda config: True)
    result = run(inner, TIGHT, "-m", "not cell")
    assert result.ret == pytest.ExitCode.OK
    assert not [line for line in result.outlines if "the fast lane" in line]


def test_a_failing_run_over_budget_says_so_too(inner: pytest.Pytester) -> None:
    inner.makepyfile(test_failing="def test_fails():\n    assert False\n")
    result = run(inner, TIGHT, "-m", "not cell")
    result.assert_outcomes(passed=2, failed=1, deselected=1)
    assert result.ret == pytest.ExitCode.TESTS_FAILED
    result.stdout.fnmatch_lines(["*CPU budget*test_inner.py::test_burns*"])
