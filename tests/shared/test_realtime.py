"""The executor clock's real-time settings: where it may run, the timer slack, and the one
command that lets it run SCHED_FIFO."""

from __future__ import annotations

import ctypes
import os
import sys
import threading

import pytest

from motocell.shared.realtime import (
    CAP_SYS_NICE,
    ELSEWHERE,
    clock_cpus,
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
