"""The lane guard (``tests/lanes.py``): a test outside the ``cell`` lane that starts a process
fails, naming it; a ``cell`` test may."""

from __future__ import annotations

import textwrap

import pytest

from tests.lanes import SpawnGuard, SpawnLog, describe

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
