"""Real-time settings: where the executor's clock may run, its timer slack, the priority every
other thread of a cell asks for, and the one command that allows them."""

from __future__ import annotations

import ctypes
import logging
import os
import sys
import threading

import pytest

from motocell.shared.realtime import (
    CAP_SYS_NICE,
    ELSEWHERE,
    REPLY_PRIORITY,
    RT_PRIORITY,
    SERVICE_PRIORITY,
    clock_cpus,
    enter_reply_priority,
    enter_service_priority,
    fix,
    fix_command,
    tighten_timer_slack,
)

PR_GET_TIMERSLACK = 30


@pytest.mark.parametrize("cpus", [{0}, {0, 1}, {0, 1, 2}])
def test_fewer_than_four_cpus_leave_the_clock_free(cpus: set[int]) -> None:
    assert clock_cpus(cpus) is None


def test_four_or_more_cpus_keep_the_clock_off_the_first() -> None:
    assert clock_cpus({0, 1, 2, 3}) == {1, 2, 3}
    assert clock_cpus(set(range(16))) == set(range(1, 16))


def test_the_first_allowed_cpu_is_left_out_not_cpu_0() -> None:
    # A process confined to CPUs 4-7 (taskset, a cgroup's cpuset) keeps the clock off 4.
    assert clock_cpus({4, 5, 6, 7}) == {5, 6, 7}


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="prctl is Linux's")
def test_the_timer_slack_of_the_calling_thread_becomes_1_ns() -> None:
    seen: list[int] = []

    def clock() -> None:
        tighten_timer_slack()
        seen.append(ctypes.CDLL(None).prctl(PR_GET_TIMERSLACK))

    thread = threading.Thread(target=clock)
    thread.start()
    thread.join()
    assert seen == [1]


def test_without_cap_sys_nice_the_interpreter_gets_it() -> None:
    command = fix(0, "/opt/python/bin/python3.11")
    assert command.startswith("sudo setcap cap_sys_nice+ep /opt/python/bin/python3.11 ")
    assert "--ulimit rtprio=99" in command  # what a container needs instead


def test_refused_with_cap_sys_nice_is_a_missing_real_time_budget() -> None:
    assert "cpu.rt_runtime_us" in fix(1 << CAP_SYS_NICE, "/usr/bin/python3")


def test_this_process_is_looked_up_in_proc() -> None:
    if not sys.platform.startswith("linux"):
        assert fix_command() == ELSEWHERE
    else:
        # The interpreter itself, not a venv's symbolic link to it: setcap refuses links.
        interpreter = os.path.realpath(sys.executable)
        assert fix_command() in {fix(0, interpreter), fix(1 << CAP_SYS_NICE, interpreter)}


def test_a_process_that_cannot_be_seen_gets_the_general_advice() -> None:
    assert fix_command(2**22 + 1) == ELSEWHERE  # above every pid_max


# -- the other threads of a cell's processes -------------------------------------------------


def test_the_services_run_above_ordinary_threads_and_below_the_clock() -> None:
    assert 1 <= SERVICE_PRIORITY < RT_PRIORITY


class Scheduler:
    """``os.sched_setscheduler`` as the kernel would answer it, recorded."""

    def __init__(self, refuse: bool) -> None:
        self.refuse = refuse
        self.calls: list[tuple[int, int, int]] = []

    def __call__(self, pid: int, policy: int, param: os.sched_param) -> None:
        self.calls.append((pid, policy, param.sched_priority))
        if self.refuse:
            raise PermissionError(1, "Operation not permitted")


@pytest.fixture
def linux(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(sys, "platform", "linux")


def test_a_service_asks_sched_rr_for_the_calling_thread_which_its_threads_inherit(
    linux: None, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    scheduler = Scheduler(refuse=False)
    monkeypatch.setattr(os, "sched_setscheduler", scheduler, raising=False)
    caplog.set_level(logging.DEBUG)
    assert enter_service_priority(logging.getLogger("gateway"))
    # No SCHED_RESET_ON_FORK: the kernel would reset the threads Zenoh starts as well.
    assert scheduler.calls == [(0, os.SCHED_RR, SERVICE_PRIORITY)]
    assert [r.levelno for r in caplog.records] == [logging.DEBUG]


def test_a_refused_service_warns_once_with_the_command_that_allows_it(
    linux: None, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setattr(os, "sched_setscheduler", Scheduler(refuse=True), raising=False)
    assert not enter_service_priority(logging.getLogger("gateway"))
    (record,) = caplog.records
    assert record.levelno == logging.WARNING
    assert f"SCHED_RR {SERVICE_PRIORITY} refused: Operation not permitted" in record.message
    assert record.message.endswith(f"To allow it: {fix_command()}")


def test_under_a_launcher_a_refusal_is_left_to_the_launcher(
    linux: None, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setattr(os, "sched_setscheduler", Scheduler(refuse=True), raising=False)
    caplog.set_level(logging.INFO)
    assert not enter_service_priority(logging.getLogger("gateway"), quiet=True)
    assert caplog.records == []


def test_off_linux_nothing_is_asked(monkeypatch: pytest.MonkeyPatch) -> None:
    scheduler = Scheduler(refuse=False)
    monkeypatch.setattr(sys, "platform", "darwin")
    monkeypatch.setattr(os, "sched_setscheduler", scheduler, raising=False)
    assert not enter_service_priority(logging.getLogger("gateway"))
    assert scheduler.calls == []


def at_policy(monkeypatch: pytest.MonkeyPatch, policy: int, priority: int) -> None:
    """The calling thread reads as running ``policy`` at ``priority``."""
    monkeypatch.setattr(os, "sched_getscheduler", lambda pid: policy, raising=False)
    monkeypatch.setattr(os, "sched_getparam", lambda pid: os.sched_param(priority), raising=False)


def test_a_connection_thread_at_the_services_priority_answers_a_step_above_it(
    linux: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    scheduler = Scheduler(refuse=False)
    monkeypatch.setattr(os, "sched_setscheduler", scheduler, raising=False)
    at_policy(monkeypatch, os.SCHED_RR, SERVICE_PRIORITY)
    assert enter_reply_priority()
    assert scheduler.calls == [(0, os.SCHED_RR, REPLY_PRIORITY)]
    assert SERVICE_PRIORITY < REPLY_PRIORITY < RT_PRIORITY


def test_a_thread_refused_the_services_priority_is_not_raised(
    linux: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    scheduler = Scheduler(refuse=False)
    monkeypatch.setattr(os, "sched_setscheduler", scheduler, raising=False)
    at_policy(monkeypatch, os.SCHED_OTHER, 0)
    assert not enter_reply_priority()
    assert scheduler.calls == []


def test_a_refused_reply_priority_leaves_the_thread_at_the_services(
    linux: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(os, "sched_setscheduler", Scheduler(refuse=True), raising=False)
    at_policy(monkeypatch, os.SCHED_RR, SERVICE_PRIORITY)
    assert not enter_reply_priority()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="scheduling policies are Linux's")
def test_a_thread_started_after_it_runs_sched_rr_too() -> None:
    seen: list[tuple[int, int]] = []

    def service() -> None:
        if not enter_service_priority(logging.getLogger("test"), quiet=True):
            return
        child = threading.Thread(
            target=lambda: seen.append((os.sched_getscheduler(0), os.sched_getparam(0)[0]))
        )
        child.start()
        child.join()

    thread = threading.Thread(target=service)
    thread.start()
    thread.join()
    if not seen:
        pytest.skip("SCHED_RR refused here (no CAP_SYS_NICE, no rtprio limit)")
    assert seen == [(os.SCHED_RR, SERVICE_PRIORITY)]
