"""StopFlag and stop_on_signals: a stop that signal handlers raise without taking a lock.

Signal bursts run in child processes, so the test runner's own handlers are never involved;
the children must exit cleanly within a deadline (a deadlock would hang them)."""

from __future__ import annotations

import gc
import os
import platform
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from motocell.shared.running_service import freeze_what_lives_forever
from motocell.shared.service import StartError, StopFlag, listen, stop_on_signals
from motocell.testing.processes import wait_until

REPO = Path(__file__).resolve().parents[2]
DEADLINE_S = 20.0
BURST = 200


def run_child(script: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-c", script],
        cwd=REPO,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )


def finish(child: subprocess.Popen[str]) -> str:
    try:
        out, _ = child.communicate(timeout=DEADLINE_S)
    except subprocess.TimeoutExpired:
        child.kill()
        child.communicate()
        raise AssertionError("the child hung: a signal handler deadlocked") from None
    assert child.returncode == 0, out
    return out


WAIT_THEN_HOLD = """
import sys
from motocell.shared.service import stop_on_signals

with stop_on_signals() as stop:
    print("ready", flush=True)
    stop.wait()
    print("stopping", flush=True)
    sys.stdin.readline()  # stay inside until the parent's burst is over
print("stopped", flush=True)
"""


@pytest.mark.cell
def test_a_burst_of_signals_from_outside_stops_the_process_once() -> None:
    child = run_child(WAIT_THEN_HOLD)
    assert child.stdout is not None and child.stdin is not None
    assert child.stdout.readline() == "ready\n"
    for n in range(BURST):
        child.send_signal(signal.SIGTERM if n % 2 else signal.SIGINT)
    child.stdin.write("\n")
    child.stdin.flush()
    assert finish(child) == "stopping\nstopped\n"


SELF_BURST = """
import os, signal, threading
from motocell.shared.service import stop_on_signals

def burst():
    for n in range(COUNT):
        os.kill(os.getpid(), signal.SIGTERM if n % 2 else signal.SIGINT)

with stop_on_signals() as stop:
    sender = threading.Thread(target=burst)
    sender.start()
    stop.wait()
    print("stopping", flush=True)
    sender.join()  # every signal arrives while the handlers are still ours
print("stopped", flush=True)
""".replace("COUNT", str(BURST * 10))


@pytest.mark.cell
def test_signals_arriving_while_the_handler_runs_do_not_deadlock() -> None:
    # The handler runs on the main thread; signals sent meanwhile run it again inside itself.
    # With a handler that took a lock (threading.Event.set) this could hang for good.
    assert finish(run_child(SELF_BURST)) == "stopping\nstopped\n"


SIGNAL_INSIDE_SET = """
import signal, sys
from motocell.shared.service import stop_on_signals

nested = []

def inside_set(frame, event, arg):
    # At StopFlag.set's first call into C, a second signal arrives: raise_signal runs its
    # handler at once, nested inside the first. (threading.Event.set hangs here for good.)
    if event == "c_call" and frame.f_code.co_name == "set" and not nested:
        nested.append(True)
        signal.raise_signal(signal.SIGINT)

with stop_on_signals() as stop:
    sys.setprofile(inside_set)
    signal.raise_signal(signal.SIGTERM)
    sys.setprofile(None)
    print(nested == [True] and stop.is_set(), flush=True)
"""


@pytest.mark.cell
def test_a_signal_whose_handler_runs_inside_set_does_not_deadlock() -> None:
    assert finish(run_child(SIGNAL_INSIDE_SET)) == "True\n"


def test_a_raised_signal_sets_the_flag_and_the_old_handlers_come_back() -> None:
    before = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    with stop_on_signals() as stop:
        assert not stop.is_set()
        signal.raise_signal(signal.SIGTERM)
        signal.raise_signal(signal.SIGINT)
        assert stop.wait(DEADLINE_S)
    assert {sig: signal.getsignal(sig) for sig in before} == before


POLL_SYSCALLS = {"x86_64": {"7", "271"}, "aarch64": {"73"}}.get(platform.machine(), set())
"""The numbers of poll and ppoll, as /proc/<pid>/task/<tid>/syscall gives the call a thread is
blocked in."""


def asleep_in_poll(tid: int) -> bool:
    try:
        call = Path(f"/proc/self/task/{tid}/syscall").read_text().split()[0]
    except (OSError, IndexError):
        return False
    return call in POLL_SYSCALLS


@pytest.mark.skipif(not POLL_SYSCALLS, reason="poll's syscall number unknown on this machine")
def test_a_signal_another_thread_takes_wakes_the_main_thread_waiting_on_the_flag() -> None:
    """The kernel gives a signal sent to the process to any thread that does not block it;
    the main thread asleep in ``wait`` must still wake and stop."""

    rescued: list[bool] = []

    def take_a_signal() -> None:
        wait_until(
            lambda: asleep_in_poll(threading.main_thread().native_id or 0),
            DEADLINE_S,
            "the main thread to wait on the flag",
        )
        signal.pthread_kill(threading.get_ident(), signal.SIGTERM)
        # Had it not woken, the main thread would sleep on: wake it, and say so.
        rescued.append(not stop.wait(DEADLINE_S))
        stop.set()

    with stop_on_signals() as stop:
        taker = threading.Thread(target=take_a_signal)
        taker.start()
        stop.wait()
        taker.join(DEADLINE_S)
    assert rescued == [False]


HELD_DURING_START_UP = """
import os, signal
from motocell.shared.service import stop_on_signals
signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})  # as `motocell service` starts it
os.kill(os.getpid(), signal.SIGINT)  # a Ctrl-C while it loads: held
with stop_on_signals() as stop:
    print(stop.wait(20))
"""


@pytest.mark.cell
def test_a_signal_held_during_start_up_stops_the_process_once_it_can() -> None:
    assert finish(run_child(HELD_DURING_START_UP)) == "True\n"


def test_off_the_main_thread_no_handler_is_set() -> None:
    before = signal.getsignal(signal.SIGTERM)
    seen: list[bool] = []

    def worker() -> None:
        with stop_on_signals() as stop:
            seen.append(signal.getsignal(signal.SIGTERM) is before)
            stop.set()
            seen.append(stop.wait(0))

    thread = threading.Thread(target=worker)
    thread.start()
    thread.join(DEADLINE_S)
    assert seen == [True, True]


# -- StopFlag -------------------------------------------------------------------------------


def test_a_new_flag_is_not_set_and_a_timed_wait_says_so() -> None:
    stop = StopFlag()
    assert not stop.is_set()
    assert stop.wait(0) is False
    assert stop.wait(0.01) is False


def test_a_set_flag_stays_set() -> None:
    stop = StopFlag()
    stop.set()
    stop.set()
    assert stop.is_set()
    assert stop.wait() is True
    assert stop.wait(0) is True


def test_setting_wakes_every_waiting_thread() -> None:
    stop = StopFlag()
    woken: list[bool] = []
    waiting = threading.Barrier(5)

    def waiter() -> None:
        waiting.wait()
        woken.append(stop.wait())

    threads = [threading.Thread(target=waiter) for _ in range(4)]
    for thread in threads:
        thread.start()
    waiting.wait()
    stop.set()
    for thread in threads:
        thread.join(DEADLINE_S)
    assert woken == [True] * 4


@pytest.mark.parametrize("times", [1, 100_000])
def test_setting_never_blocks_however_often(times: int) -> None:
    stop = StopFlag()
    for _ in range(times):
        stop.set()
    assert stop.wait(0)


def test_a_forgotten_flag_releases_its_descriptors() -> None:
    before = len(os.listdir("/proc/self/fd"))
    for _ in range(50):
        StopFlag().set()
    assert len(os.listdir("/proc/self/fd")) <= before + 2


def test_what_start_up_made_is_frozen_out_of_full_collections() -> None:
    before = gc.get_freeze_count()
    try:
        freeze_what_lives_forever()
        assert gc.get_freeze_count() > before
    finally:
        gc.unfreeze()


def test_a_port_that_cannot_be_served_is_a_start_error_in_one_line() -> None:
    with listen("127.0.0.1", 0) as taken:
        port = taken.getsockname()[1]
        with pytest.raises(StartError, match=rf"^cannot listen on 127.0.0.1:{port}: Address"):
            listen("127.0.0.1", port)
    with pytest.raises(
        StartError, match=r"^cannot listen on 127.0.0.1:70000: a port is 1 to 65535$"
    ):
        listen("127.0.0.1", 70000)
