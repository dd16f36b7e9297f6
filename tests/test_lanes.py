"""The lanes (``tests/lanes.py``): a test outside the ``cell`` lane that starts a process
fails, naming it, a ``cell`` test may; ``-m "not cell"`` is the fast lane, which fuzzes with the
light Hypothesis profile, any other run with the deep one."""

from __future__ import annotations

import textwrap

import pytest
from hypothesis import settings

from tests.lanes import (
    DEEP_FUZZING,
    FAST_FUZZING,
    SpawnGuard,
    SpawnLog,
    describe,
    hypothesis_profile,
    is_fast_lane,
)

pytest_plugins = ["pytester"]


def test_the_log_keeps_what_starts_a_process_and_forgets_it_once_taken() -> None:
    log = SpawnLog()
    log.audit("open", ("/etc/hosts", "r", 0))
    log.audit("subprocess.Popen", ("/bin/true", ["/bin/true", "-x"], None, None))
    log.audit("os.system", (b"ls",))
    assert log.take() == ["subprocess.Popen: /bin/true -x", "os.system: b'ls'"]
    assert log.take() == []


def test_an_event_without_a_command_is_named_alone() -> None:
    assert describe("os.fork", ()) == "os.fork"
    assert describe("os.spawn", (0, "/bin/sh", ("sh", "-c", "true"), {})) == (
        "os.spawn: sh -c true"
    )


@pytest.mark.parametrize("markexpr", ["not cell", " not  cell "])
def test_not_cell_however_spaced_is_the_fast_lane(markexpr: str) -> None:
    assert is_fast_lane(markexpr)


@pytest.mark.parametrize("markexpr", ["", "cell", "not cell and cell", "not cells"])
def test_any_other_selection_is_not(markexpr: str) -> None:
    assert not is_fast_lane(markexpr)


def test_the_fast_lane_fuzzes_lightly_any_other_run_deeply_unless_told() -> None:
    assert hypothesis_profile("not cell", None) == FAST_FUZZING
    assert hypothesis_profile("", None) == DEEP_FUZZING
    assert hypothesis_profile("cell", None) == DEEP_FUZZING
    assert hypothesis_profile("not cell", DEEP_FUZZING) == DEEP_FUZZING
    assert hypothesis_profile("", FAST_FUZZING) == FAST_FUZZING


def test_this_run_fuzzes_with_the_profile_of_its_lane(request: pytest.FixtureRequest) -> None:
    """tests/conftest.py loads it, as it registers both."""
    config = request.config
    chosen = hypothesis_profile(config.option.markexpr, config.getoption("hypothesis_profile"))
    assert settings.default == settings.get_profile(chosen)


INNER = """
import subprocess
import sys

import pytest


def start_one():
    subprocess.run([sys.executable, "-c", "pass"], check=True)


@pytest.fixture(scope="module")
def started_by_a_fixture():
    start_one()


def test_unmarked():
    start_one()


@pytest.mark.cell
def test_marked():
    start_one()


def test_unmarked_with_a_module_fixture(started_by_a_fixture):
    pass


def test_starting_nothing():
    pass
"""


@pytest.mark.cell
def test_only_cell_tests_may_start_a_process(pytester: pytest.Pytester) -> None:
    pytester.makeini("[pytest]\nmarkers =\n    cell: starts processes\n")
    pytester.makepyfile(test_inner=textwrap.dedent(INNER))
    result = pytester.inline_run("-p", "no:cacheprovider", plugins=[SpawnGuard()])
    outcomes = {
        report.nodeid.split("::")[-1]: (report.when, report.outcome)
        for report in result.getreports("pytest_runtest_logreport")
        if report.outcome == "failed" or report.when == "call"
    }
    assert outcomes == {
        "test_unmarked": ("call", "failed"),
        "test_marked": ("call", "passed"),
        "test_unmarked_with_a_module_fixture": ("setup", "failed"),
        "test_starting_nothing": ("call", "passed"),
    }
    (failure,) = [r for r in result.getfailures() if r.when == "call"]
    assert "the test started 1 process(es) outside the cell lane" in failure.longreprtext
    assert "-c pass" in failure.longreprtext
