"""``motocell up``'s one line about priorities: what the cell could not get (the executor's clock,
the services, or both) and the one command that allows it, said once."""

from __future__ import annotations

import logging

import pytest

from motocell.services.launcher.realtime_line import RealtimeNotice, refused_line
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import ExecutorMetrics, Percentiles
from motocell.shared.realtime import ELSEWHERE, RT_PRIORITY, SERVICE_PRIORITY, fix_command
from tests.services.launcher.fake_session import Session

COMMAND = "sudo setcap cap_sys_nice+ep /usr/bin/python3.11"


def test_nothing_is_said_when_everything_was_granted() -> None:
    assert refused_line(clock=False, services=False, command=COMMAND) is None


def test_a_clock_without_sched_fifo_is_said_with_what_it_risks() -> None:
    line = refused_line(clock=True, services=False, command=COMMAND)
    assert line == (
        f"the executor runs WITHOUT real-time priority (SCHED_FIFO {RT_PRIORITY} refused) and "
        f"will miss periods under load; to allow it: {COMMAND}; then start the cell again"
    )


def test_services_without_sched_rr_are_said_with_what_that_risks() -> None:
    line = refused_line(clock=False, services=True, command=COMMAND)
    assert line is not None
    assert line.startswith(
        f"the cell's services run WITHOUT real-time priority (SCHED_RR {SERVICE_PRIORITY} "
        "refused): ordinary load can starve them into stopping motion;"
    )
    assert line.endswith(f"to allow it: {COMMAND}; then start the cell again")


def test_both_refused_are_one_line_with_one_command() -> None:
    line = refused_line(clock=True, services=True, command=COMMAND)
    assert line is not None
    assert line.startswith("the executor runs WITHOUT real-time priority")
    assert f"SCHED_FIFO {RT_PRIORITY} refused" in line
    assert f"SCHED_RR {SERVICE_PRIORITY} refused" in line
    assert line.count("to allow it:") == 1
    assert "\n" not in line


# -- the notice over a scripted bus ----------------------------------------------------------


def report(session: Session, *, realtime: bool) -> None:
    window = Percentiles(count=0, p50_us=0.0, p99_us=0.0, max_us=0.0)
    metrics = ExecutorMetrics(
        tick=1, lateness=window, missed_total=0, queue_depths=[], realtime=realtime
    )
    session.put(metrics)


def notice(
    session: Session, *, services_realtime: bool, executor_pid: int | None
) -> RealtimeNotice:
    return RealtimeNotice(
        session.zenoh(),
        CellKeys("cell1"),
        lambda: executor_pid,
        services_realtime=services_realtime,
        executor_here=executor_pid is not None,
    )


def warnings(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.message for r in caplog.records if r.levelno == logging.WARNING]


def test_both_refused_wait_for_the_executor_and_are_said_once(
    caplog: pytest.LogCaptureFixture,
) -> None:
    session = Session()
    watching = notice(session, services_realtime=False, executor_pid=2**22 + 1)
    assert not watching.check()
    assert warnings(caplog) == []
    report(session, realtime=False)
    assert watching.check()
    report(session, realtime=False)
    assert watching.check()
    # A pid this process cannot look at: the general advice.
    assert warnings(caplog) == [refused_line(clock=True, services=True, command=ELSEWHERE)]
    assert session.subscriber is not None
    assert session.subscriber.undeclared == 1


def test_services_refused_with_the_clock_granted_are_said_once_the_executor_reports(
    caplog: pytest.LogCaptureFixture,
) -> None:
    session = Session()
    watching = notice(session, services_realtime=False, executor_pid=2**22 + 1)
    report(session, realtime=True)
    assert watching.check()
    expected = refused_line(clock=False, services=True, command=fix_command())
    assert warnings(caplog) == [expected]


def test_without_an_executor_here_a_refusal_is_said_at_once(
    caplog: pytest.LogCaptureFixture,
) -> None:
    session = Session()
    watching = notice(session, services_realtime=False, executor_pid=None)
    expected = refused_line(clock=False, services=True, command=fix_command())
    assert warnings(caplog) == [expected]
    report(session, realtime=False)  # the executor elsewhere, refused too: its own line
    assert watching.check()
    assert warnings(caplog) == [
        expected,
        refused_line(clock=True, services=False, command=ELSEWHERE),
    ]


def test_a_cell_that_got_everything_says_nothing(caplog: pytest.LogCaptureFixture) -> None:
    session = Session()
    watching = notice(session, services_realtime=True, executor_pid=2**22 + 1)
    report(session, realtime=True)
    assert watching.check()
    watching.close()
    assert warnings(caplog) == []
