"""Real-time scheduling: the executor's clock (SCHED_FIFO, where it may run), every other thread
of a cell's processes (SCHED_RR below the clock, the gateway's motion connection thread a step
above the rest), and the one command that allows both. The executor applies the clock's
(``services/executor/loop.py``), every service and the launcher's router their own
(``enter_service_priority``), the motion connection thread its own (``enter_reply_priority``);
the launcher, ``motocell ps`` and ``motocell watch`` show the command when they run without
(docs/realtime.md).
"""

from __future__ import annotations

import ctypes
import logging
import os
import sys
from collections.abc import Set

RT_PRIORITY = 50
"""The clock thread's SCHED_FIFO priority: above every ordinary thread and below the kernel's own
real-time threads (interrupt threads run at 50 too, and the migration threads at 99)."""

SERVICE_PRIORITY = 10
"""The SCHED_RR priority of every thread of a cell's processes but the clock: the services, their
Zenoh threads, the launcher's router. Above every ordinary process, so that a machine busy with
other work (a build, other cells, CPU hogs) cannot starve what the stall rules wait for (the
controller's status, the interpolators' increments, the gateway's view of both, the router that
carries them) into stopping motion; below the clock, which preempts them all. Measured:
docs/realtime.md, "The other threads: SCHED_RR 10"."""

REPLY_PRIORITY = 20
"""The SCHED_RR priority of the gateway's motion connection thread, the one that answers the
motion port's client, while that client keeps it waiting (``services/gateway/reply_priority.py``):
above the rest of the cell (SERVICE_PRIORITY), so that a request preempts the
interpolating, broadcasting and routing its previous point set off instead of waiting for a CPU
behind them; below the clock. Measured: docs/reply-path.md, "The reply's priority"."""

MIN_CPUS_FOR_AFFINITY = 4
"""Below this the clock is never restricted: with two or three CPUs, the ones left to it would be
busy with everything else too, and the scheduler needs them all to place it at once."""

PR_SET_TIMERSLACK = 29
TIMER_SLACK_NS = 1

CAP_SYS_NICE = 23
ELSEWHERE = "give its process an rtprio limit of 50 or more, or CAP_SYS_NICE (docs/realtime.md)"


def clock_cpus(allowed: Set[int]) -> set[int] | None:
    """The CPUs the clock thread may run on, or None for no restriction.

    With at least MIN_CPUS_FOR_AFFINITY allowed CPUs, every one but the lowest-numbered: the
    boot CPU keeps housekeeping (legacy interrupts, the timekeeping duty of a tickless kernel,
    nohz_full's housekeeping by default). Never a single CPU: several cells' clocks pinned to one
    would queue behind each other there, while the real-time scheduler spreads unpinned
    SCHED_FIFO threads over the CPUs not running one.
    """
    if len(allowed) < MIN_CPUS_FOR_AFFINITY:
        return None
    return set(allowed) - {min(allowed)}


def tighten_timer_slack() -> None:
    """The calling thread's sleeps end at their deadline, not up to 50 µs after it (the default
    slack lets the kernel batch wake-ups). A SCHED_FIFO thread has no slack anyway; this is for
    a clock refused real-time priority (measured: docs/realtime.md, What the clock asks the
    kernel for). Needs no privilege; nothing to do off Linux."""
    if sys.platform.startswith("linux"):
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_TIMERSLACK, TIMER_SLACK_NS)


def enter_service_priority(log: logging.Logger, *, quiet: bool = False) -> bool:
    """SCHED_RR SERVICE_PRIORITY for the calling thread and every thread it starts from now on
    (they inherit it: call it before the Zenoh session opens, whose threads carry every
    message), and for processes it starts (the launcher's services). Whether it was granted.

    Refused (no CAP_SYS_NICE, an rtprio limit below SERVICE_PRIORITY) the process runs on at
    ordinary priority, and says so in one warning with the command that allows it; ``quiet``
    leaves that to whoever started it (``motocell up`` says it once for the whole cell)."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        round_robin(SERVICE_PRIORITY)
    except OSError as exc:
        log.log(
            logging.DEBUG if quiet else logging.WARNING,
            "running WITHOUT real-time priority (SCHED_RR %d refused: %s); ordinary load on "
            "this machine can starve it into stopping motion. To allow it: %s",
            SERVICE_PRIORITY,
            exc.strerror,
            fix_command(),
        )
        return False
    log.debug("every thread runs SCHED_RR priority %d", SERVICE_PRIORITY)
    return True


def enter_reply_priority() -> bool:
    """SCHED_RR REPLY_PRIORITY for the calling thread, if it runs at the services' priority
    (a thread of a process that was refused it, or of a test, stays as it is). Whether it was
    granted: an rtprio limit between the services' priority and this one keeps it at the
    services', which works as before, only slower to answer."""
    if not sys.platform.startswith("linux"):
        return False
    if (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority) != (
        os.SCHED_RR,
        SERVICE_PRIORITY,
    ):
        return False
    try:
        round_robin(REPLY_PRIORITY)
    except OSError:
        return False
    return True


def round_robin(priority: int) -> None:
    """SCHED_RR ``priority`` for the calling thread (OSError where it is refused)."""
    os.sched_setscheduler(0, os.SCHED_RR, os.sched_param(priority))


def leave_service_priority() -> None:
    """The calling thread back to ordinary scheduling; the threads it already started keep
    theirs. For the launcher's main thread once its router runs: the processes it starts then
    begin at ordinary priority, and a service takes its own only once its imports are done
    (``shared.running_service``). Imports at SCHED_RR 10, a starting cell's eight interpreters
    loading numpy and Zenoh, would hold the CPUs in 100 ms round-robin slices against the running
    cells' threads of the same priority, long enough for a moving neighbour's controller to go
    unheard and its trajectory to stop with alarm 4200 (measured: docs/realtime.md, The other
    threads)."""
    if sys.platform.startswith("linux"):
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))


def fix_command(pid: int | str = "self") -> str:
    """The one command that lets process ``pid`` of this machine (an executor, a service, the
    launcher) take the priorities above, the clock's SCHED_FIFO and the others' SCHED_RR alike;
    ELSEWHERE when this process cannot look at it (not Linux, another user's process)."""
    proc = f"/proc/{pid}"
    try:
        with open(f"{proc}/status") as status:
            capabilities = next(line for line in status if line.startswith("CapEff:"))
        interpreter = os.readlink(f"{proc}/exe")
    except (OSError, StopIteration):
        return ELSEWHERE
    return fix(int(capabilities.split()[1], 16), interpreter)


def fix(capabilities: int, interpreter: str) -> str:
    """For a process with these effective ``capabilities`` running ``interpreter``.

    Verified on Linux 6.18 with a process holding no capabilities and an rtprio limit of 0:
    ``setcap`` on the interpreter made SCHED_FIFO 50 succeed. It lets every program that
    interpreter runs raise its priority; docs/realtime.md has the narrower ways. In a container
    the rtprio limit is the way: Docker gives a non-root user no capabilities from ``cap_add``.
    """
    if capabilities >> CAP_SYS_NICE & 1:
        # Allowed but refused: no budget (cgroup v1 real-time group scheduling gives a new
        # cgroup 0 µs of real-time time per period).
        return "give its cgroup a real-time budget (cpu.rt_runtime_us, docs/realtime.md)"
    return (
        f"sudo setcap cap_sys_nice+ep {interpreter} (in a container: --ulimit rtprio=99; "
        "compose: ulimits: {rtprio: 99})"
    )
