"""A failed test's report, from a user's test run by pytest in this process (``pytester``):
a section on its cell with the cell's state and the end of its log; with
``--motocell-keep-failed`` the cell kept until that run ends, and the commands to look at it.
One module-scoped cell (``cell_fixture``) for both of the user's tests; nothing of it is
left once the run ends (``tests/conftest.py`` fails a test that leaves a process)."""

from __future__ import annotations

import textwrap

import pytest

pytestmark = pytest.mark.cell

pytest_plugins = ["pytester"]

USER_TESTS = """
from motocell.testing import CellUnderTest, cell_fixture

shared = cell_fixture(scope="module", pending_points=4)


def test_reset_clears_what_a_test_before_left(shared: CellUnderTest) -> None:
    shared.fault("estop")
    shared.fault("hold")
    shared.fault("alarm", 4100, 2)
    shared.reset()
    status = shared.status()
    assert (status.estop, status.hold, status.alarms, status.servo_on) == (False, False, (), False)
    assert shared.config.pending_points == 4


def test_fails_on_purpose_under_an_estop(shared: CellUnderTest) -> None:
    shared.fault("estop")
    shared.fault("alarm", 4100, 2)
    assert shared.status().motion_ready, "fails on purpose"
"""


def test_a_failed_tests_report_shows_its_kept_cell_and_the_run_stops_it(
    pytester: pytest.Pytester,
) -> None:
    pytester.makepyfile(test_user=textwrap.dedent(USER_TESTS))
    result = pytester.runpytest_inprocess("-p", "no:cacheprovider", "--motocell-keep-failed")
    result.assert_outcomes(passed=1, failed=1)
    output = result.stdout.str()
    sections = output.split("- motocell cell test-")
    assert len(sections) == 2, output
    shown = sections[1]
    for expected in [
        "servo off, PLAY, REMOTE",
        "E-stop on, HOLD off",
        "alarms (code.subcode): 4100.2",
        "motion ready: NOT_READY",
        "trajectory mode: nobody",
        "group 0 positions: 0.000000, ",
        "fault injected: alarm",
        "kept running (--motocell-keep-failed)",
        "motocell watch --zenoh-connect tcp/127.0.0.1:",
        "--credentials ",
    ]:
        assert expected in shown, output
