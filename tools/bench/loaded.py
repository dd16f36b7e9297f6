"""The loaded cell of figures 3 and 6: 4 groups moving, 4 state clients at a one-tick period.

One cell (``bench_cell``, state period 4 ms), 4 ``tools.bench.state_client`` processes and one
``tools.bench.stream_client`` process (a constant-velocity 2016 trajectory, points 100 ms apart,
streamed like motoman_driver, so the gateway also answers a BUSY point every ~5 ms). Each run is
one window of the ``executor/tick`` stream; figures 3 and 6 read the same runs.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from motocell.shared.bus.schemas import State, Tick
from motocell.testing.client import ex_messages
from motocell.testing.running_cell import RunningCell
from motocell.tools.bench.clients import (
    StateClientProcess,
    StreamClientProcess,
    StreamRecord,
    measured_again,
)
from motocell.tools.bench.measuring import (
    EXECUTOR_MODES,
    LogTail,
    Observer,
    bench_cell,
    gc_paused,
    positions_of,
    ramps,
    wait_moving,
    wake_ns,
    workdir,
)

STATE_CLIENTS = 4
LOADED_SPEED = 0.02
"""rad/s (m/s) on every axis. A full run (60 s + 4 s) then moves 1.28 rad, inside every
model's range from its initial position (the tightest, arm7's second axis, ends at 1.92 rad;
0.05 rad/s ran into it after 38 s and the cell rightly stopped with its soft-limit alarm), and
the 7-axis arm's axes (65,536 pulses/rad) still move 5 pulses a tick, so the feedback pulses
of the 4 groups together identify the tick they come from."""
POINT_INTERVAL_S = 0.1
SETTLE_S = 0.5
"""After the first move, until the ring is full and state flows."""
RUN_OVERHEAD_S = 20.0
"""Per run besides its window: waiting for the robot to stop and start, settling, stopping."""


@dataclass
class LoadedRun:
    """One measurement window."""

    window_s: float
    start_ns: int
    end_ns: int
    lateness_ns: np.ndarray
    missed: int
    ticks: int
    tick_gaps: int
    wake: np.ndarray
    """Wake time (ns) of each tick of the window."""
    keys: np.ndarray
    """Feedback pulses of every group, concatenated, one row per tick of the window."""
    clients: list[dict[str, np.ndarray]]
    """Per state client: ``received_ns`` and ``pulses`` (the same layout as ``keys``)."""
    dropped: int
    """State cycles and requests past the clients' records (the whole figure)."""
    state_period_ns: int
    points: int
    busy: int
    state_age_ms: np.ndarray
    """Per ``state`` sample: when the observer got it - its ``tick_ns`` (broadcaster part)."""
    state_repeats: int
    """``state`` samples that show the same tick as the previous one."""
    state_samples: int


_loaded_cache: dict[tuple[int, float], tuple[list[LoadedRun], set[bool]]] = {}


def loaded_runs(runs: int, seconds: float) -> list[LoadedRun]:
    """Figures 3 and 6 are measured in the same runs (same conditions); the first caller
    measures, the second reuses them, and the executor modes seen then (``EXECUTOR_MODES``)."""
    key = (runs, seconds)
    if key not in _loaded_cache:
        measured = measure_loaded(runs, seconds)
        _loaded_cache[key] = (measured, set(EXECUTOR_MODES.seen))
    measured, modes = _loaded_cache[key]
    for realtime in modes:
        EXECUTOR_MODES.note(realtime)
    return measured


@dataclass
class _Window:
    first: int
    last: int
    start_ns: int
    end_ns: int
    record: StreamRecord


def measure_loaded(
    runs: int,
    seconds: float,
    before_window: Callable[[int], None] | None = None,
    extra_s: float = 0.0,
    refusals: list[tuple[int, str]] | None = None,
) -> list[LoadedRun]:
    """``runs`` windows of ``seconds`` on one loaded cell; ``before_window(run)`` is called
    before each (figure 11 starts or stops a neighbour cell there), ``extra_s`` is what it may
    take in all (the state clients' records are sized for it). A stream the cell refuses ends
    the figure, unless ``refusals`` is given: it is noted there (the run, why), the cell
    recovered (START_TRAJ_MODE) and the window measured again, at most ``clients.RETRIES`` times."""
    with contextlib.ExitStack() as stack:
        directory = stack.enter_context(workdir())
        cell = stack.enter_context(bench_cell(directory, "bench34", state_period_ms=4.0))
        observer = stack.enter_context(Observer(cell))
        observer.record_ticks()
        observer.record_states()
        recording_s = runs * (seconds + RUN_OVERHEAD_S) + RUN_OVERHEAD_S + extra_s
        clients: list[StateClientProcess] = []
        for index in range(STATE_CLIENTS):
            client = StateClientProcess(cell, directory / f"state{index}.npz", recording_s)
            stack.callback(client.kill)
            clients.append(client)
        streamer = stack.enter_context(StreamClientProcess(cell, directory))
        stack.enter_context(gc_paused())
        streamer.start_traj_mode()
        windows = []
        log = LogTail(directory / "bench34.log")
        for run in range(runs):
            if before_window is not None:
                before_window(run)
            window = functools.partial(_window, cell, observer, streamer, run, seconds)
            windows.append(measured_again(streamer, window, log, refusals, run))
        observer.wait_still()
        recorded = [client.stop() for client in clients]
        dropped = sum(int(data["dropped"]) for data in recorded)
        dropped += sum(w.record.dropped for w in windows)
        return [
            _loaded_run(
                cell=cell,
                ticks=observer.ticks_since(w.first - 1, w.last),
                states=observer.states_between(w.start_ns, w.end_ns),
                window=w,
                recorded=recorded,
                dropped=dropped,
                seconds=seconds,
            )
            for w in windows
        ]


def _window(
    cell: RunningCell, observer: Observer, streamer: StreamClientProcess, run: int, seconds: float
) -> _Window:
    still = observer.wait_still()
    direction = 1.0 if run % 2 == 0 else -1.0
    duration = seconds + RUN_OVERHEAD_S
    plans = ramps(
        positions_of(cell.cell, still), direction * LOADED_SPEED, duration, POINT_INTERVAL_S
    )
    mark = observer.mark()
    streamer.begin(ex_messages(plans), duration)
    try:
        wait_moving(observer, mark)
        time.sleep(SETTLE_S)
        first = observer.mark()
        start_ns = time.monotonic_ns()
        time.sleep(seconds)
        last = observer.mark()
        end_ns = time.monotonic_ns()
    except BaseException:
        streamer.end().check()  # a refused point says why the robot did not move
        raise
    return _Window(first, last, start_ns, end_ns, streamer.end().check())


def _loaded_run(
    *,
    cell: RunningCell,
    ticks: list[Tick],
    states: list[tuple[int, State]],
    window: _Window,
    recorded: list[dict[str, np.ndarray]],
    dropped: int,
    seconds: float,
) -> LoadedRun:
    before, inside = ticks[0], ticks[1:]
    axes = [group.axes for group in cell.cell.groups]
    keys = np.array(
        [
            [p for g, n in zip(t.groups, axes, strict=True) for p in g.feedback_pulses[:n]]
            for t in inside
        ],
        dtype=np.int64,
    )
    numbers = np.array([t.tick for t in inside])
    clients = []
    for data in recorded:
        received = data["received_ns"]
        within = (received >= window.start_ns) & (received <= window.end_ns)
        clients.append({"received_ns": received[within], "pulses": data["pulses"][within]})
    return LoadedRun(
        window_s=seconds,
        start_ns=window.start_ns,
        end_ns=window.end_ns,
        lateness_ns=np.array([t.lateness_ns for t in inside], dtype=np.int64),
        missed=inside[-1].missed - before.missed,
        ticks=len(inside),
        tick_gaps=int(np.sum(np.diff(numbers) != 1)),
        wake=np.array([wake_ns(t) for t in inside], dtype=np.int64),
        keys=keys,
        clients=clients,
        dropped=dropped,
        state_period_ns=cell.cell.state_period_ns,
        points=window.record.points,
        busy=window.record.busy,
        state_age_ms=np.array([(at - st.tick_ns) / 1e6 for at, st in states]),
        state_repeats=sum(1 for (_, a), (_, b) in itertools.pairwise(states) if a.tick == b.tick),
        state_samples=len(states),
    )
