"""The fast lane's budget, in CPU seconds: no test over ``Budget.test_s``, the lane not over
``Budget.lane_s``.

A contributor runs ``pytest -m "not cell"`` on every save, so a test that makes it slow is a
defect of its own. Wall-clock time would say so only on an idle machine (the shared ones run
several suites at once), so the budget counts the CPU time of this process instead
(``time.process_time``: every thread, Zenoh's too), which the load of other processes changes
far less. A test that waits (a timeout, a sleep) costs no CPU and is not seen here: waiting on
a router is for the ``cell`` lane (``tests/lanes.py``).

Only a run of the whole fast lane is held to it (``lanes.runs_the_whole_fast_lane``), and only
untraced: coverage and debuggers multiply the cost of every line. Such a run ends with one line
saying what it cost; over budget, that line names what went over and the run fails (exit
status 1), the tests themselves keeping their outcome.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Generator, Mapping
from dataclasses import dataclass

import pytest

from tests import lanes


@dataclass(frozen=True)
class Budget:
    test_s: float
    """CPU seconds one test may take, its fixtures' set-up and tear-down included."""
    lane_s: float
    """CPU seconds the run may take from its start, collection included."""


BUDGET = Budget(test_s=4.0, lane_s=50.0)
"""What the lane costs, with headroom: docs/conventions.md, "Lanes"."""


def traced(config: pytest.Config) -> bool:
    """Whether coverage (pytest-cov's plugin) or a debugger traces this run."""
    return sys.gettrace() is not None or config.pluginmanager.hasplugin("_cov")


def overruns(budget: Budget, tests: Mapping[str, float], lane_s: float) -> list[str]:
    """What went over ``budget``: the lane, then each test over it, costliest first."""
    over = []
    if lane_s > budget.lane_s:
        over.append(f"the lane {lane_s:.1f} s (budget {budget.lane_s:g} s)")
    costly = sorted(
        ((cost, test) for test, cost in tests.items() if cost > budget.test_s), reverse=True
    )
    over += [f"{test} {cost:.1f} s (budget {budget.test_s:g} s)" for cost, test in costly]
    return over


def failure(over: list[str]) -> str:
    """The line that fails a run of the whole lane, naming what went ``over`` its budget."""
    return f"the fast lane went over its CPU budget (tests/budget.py): {'; '.join(over)}"


def spent(budget: Budget, tests: Mapping[str, float], lane_s: float) -> str:
    """The line a run of the whole lane within ``budget`` ends with."""
    costliest = max(tests.values(), default=0.0)
    return (
        f"the fast lane's CPU time: {lane_s:.1f} s (budget {budget.lane_s:g} s), its costliest "
        f"test {costliest:.1f} s (budget {budget.test_s:g} s)"
    )


class CpuBudget:
    """The plugin: measures each test's CPU time and the run's, and fails a run of the whole
    fast lane that went over ``budget``."""

    def __init__(self, budget: Budget = BUDGET) -> None:
        self.budget = budget
        self.applies = False
        self.started_s = 0.0
        self.tests: dict[str, float] = {}
        self.over: list[str] = []
        self.line = ""

    def pytest_sessionstart(self, session: pytest.Session) -> None:
        config = session.config
        self.applies = lanes.runs_the_whole_fast_lane(config) and not traced(config)
        self.started_s = time.process_time()

    @pytest.hookimpl(wrapper=True)
    def pytest_runtest_protocol(
        self, item: pytest.Item, nextitem: pytest.Item | None
    ) -> Generator[None, object, object]:
        started = time.process_time()
        try:
            return (yield)
        finally:
            self.tests[item.nodeid] = time.process_time() - started

    def pytest_sessionfinish(self, session: pytest.Session) -> None:
        if not self.applies:
            return
        lane_s = time.process_time() - self.started_s
        self.over = overruns(self.budget, self.tests, lane_s)
        if self.over:
            self.line = failure(self.over)
            if session.exitstatus == pytest.ExitCode.OK:
                session.exitstatus = pytest.ExitCode.TESTS_FAILED
        else:
            self.line = spent(self.budget, self.tests, lane_s)

    def pytest_terminal_summary(self, terminalreporter: pytest.TerminalReporter) -> None:
        if self.line:
            terminalreporter.write_line(self.line, red=bool(self.over), bold=bool(self.over))
