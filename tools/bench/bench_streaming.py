"""Figure 5: streaming a 4-group trajectory point by point.

    python -m motocell.tools.bench.run --only 5 [--quick]

4-group cells (default 10 ms state period, one state client connected). Each run streams
MOTO_JOINT_TRAJ_PT_FULL_EX (2016) points of a constant-velocity trajectory on every axis (so
every executed period moves every axis) from a motion client in its own process
(``tools.bench.stream_client``). The clients (``VARIANTS``), each run 3 times:

- motoman_driver: 2000 points 4 ms apart (quick: 100), the next point at once after SUCCESS, a
  BUSY point resent after 5 ms. Goals: 0 empty-queue periods, finish - nominal <= 50 ms;
- paced 4 ms (diagnostic): point i sent no earlier than i x 4 ms after the first, no lookahead,
  BUSY resent after 5 ms;
- BUSY retry 1 ms (diagnostic): as motoman_driver but resending after 1 ms, to show what the
  cell sustains when the client's back-off is not the limit;
- paced 8 ms: 1000 points 8 ms apart (quick: 50), paced, with MotoROS's one pending point.
  Goals: 0 empty-queue periods and slot turnaround p99 <= 2 ms;
- paced 4 ms with ``pending_points = 4`` (a cell of its own; motocell's deeper pending-point
  FIFO, a cell-file setting). Goal: 0 empty-queue periods;
- paced 8 ms again with ``start_buffer_periods = 0`` (diagnostic, a cell of its own): MotoROS's
  exact start timing, without the default 3-period start buffer that gives a client without
  look-ahead its margin against late points (docs/behaviour.md, "Start buffer").

From the ``executor/tick`` stream (``analyse``):

- empty-queue periods: for each group, the ticks between its first and its last moving tick
  that did not move it (its ring was empty: the executor had nothing to apply), summed over
  the groups (``empty_periods``). With no starvation each group's moving span is exactly
  (points - 1) x spacing;
- finish - nominal: wake time of the tick that applied the last point minus the time the first
  point was sent, minus the nominal duration;
- start latency: first point sent -> first moving tick; BUSY replies per accepted point.

Slot turnaround (``slot_turnaround_ms``, group 0, pending-point depth 1): the client reading a
point's SUCCESS -> this benchmark's observer seeing the interpolator's ``group/0/slot`` report
it taken (``Slot.taken_id``). The gateway answers BUSY until then, so a paced client whose next
point comes sooner gets BUSY and loses 5 ms.
"""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from motocell.shared.bus.schemas import Decoder, Point, Slot, Tick
from motocell.testing.client import ex_messages
from motocell.tools.bench.clients import (
    StateClientProcess,
    StreamClientProcess,
    StreamRecord,
    stream_bound_s,
)
from motocell.tools.bench.measuring import (
    Extensions,
    Observer,
    bench_cell,
    figure_result,
    gc_paused,
    percentiles,
    positions_of,
    ramps,
    wake_ns,
    workdir,
)
from motocell.tools.bench.stream_client import BUSY_RETRY_S

FIGURE = 5
RUNS = 3
SPEED = 0.2
"""rad/s (m/s) on every axis; each run travels 8 s x SPEED = 1.6 rad, alternately up and back
from the initial position, within every model's joint range."""
FINISH_GOAL_MS = 50.0
TURNAROUND_P99_GOAL_MS = 2.0
QUICK_DIVISOR = 20
RECORDING_S = 600.0
"""Bound of the state client's record (it only loads the cell here)."""


@dataclass(frozen=True)
class Variant:
    """One client, and the goals it is held to."""

    name: str
    spacing_s: float
    points: int
    paced: bool = False
    busy_retry_s: float = BUSY_RETRY_S
    extensions: Extensions = ()
    """motocell's opt-in cell-file settings; variants that share them share a cell."""
    empty_goal: bool = False
    finish_goal: bool = False
    turnaround: bool = False
    """Report the slot turnaround (with its goal)."""


PENDING_4 = (("pending_points", 4),)
NO_START_BUFFER = (("start_buffer_periods", 0),)
VARIANTS = (
    Variant("motoman_driver", 0.004, 2000, empty_goal=True, finish_goal=True),
    Variant("paced 4 ms", 0.004, 2000, paced=True),
    Variant("BUSY retry 1 ms", 0.004, 2000, busy_retry_s=0.001),
    Variant("paced 8 ms", 0.008, 1000, paced=True, empty_goal=True, turnaround=True),
    Variant(
        "paced 4 ms, pending_points 4",
        0.004,
        2000,
        paced=True,
        extensions=PENDING_4,
        empty_goal=True,
    ),
    Variant("paced 8 ms, no start buffer", 0.008, 1000, paced=True, extensions=NO_START_BUFFER),
)


def empty_periods(numbers: np.ndarray, moving: np.ndarray) -> tuple[int, int]:
    """(empty, lost) for one group, from the tick samples an observer got (their tick numbers,
    and whether each moved the group): ticks between the first and the last moving tick that
    did not move it, and tick numbers in that span with no sample at all (lost by the
    observer: ticks are published with DROP, so a gap is counted as lost, not as empty)."""
    where = np.flatnonzero(moving)
    if where.size == 0:
        raise RuntimeError("the group never moved")
    first, last = int(where[0]), int(where[-1])
    seen = last - first + 1
    return seen - where.size, int(numbers[last] - numbers[first] + 1) - seen


def analyse(
    ticks: list[Tick], points: int, spacing_s: float, first_sent_ns: int
) -> dict[str, float]:
    numbers = np.array([t.tick for t in ticks], dtype=np.int64)
    empty = lost = 0
    firsts: list[int] = []
    lasts: list[int] = []
    for g in range(len(ticks[0].groups)):
        moving = np.array([any(t.groups[g].increment) for t in ticks])
        group_empty, group_lost = empty_periods(numbers, moving)
        empty += group_empty
        lost += group_lost
        where = np.flatnonzero(moving)
        firsts.append(int(where[0]))
        lasts.append(int(where[-1]))
    start, finish = ticks[min(firsts)], ticks[max(lasts)]
    nominal_ns = (points - 1) * spacing_s * 1e9
    return {
        "empty": float(empty),
        "lost": float(lost),
        "finish_over_ms": (wake_ns(finish) - first_sent_ns - nominal_ns) / 1e6,
        "start_ms": (wake_ns(start) - first_sent_ns) / 1e6,
        "start_spread": float(numbers[max(firsts)] - numbers[min(firsts)]),
    }


def slot_turnaround_ms(
    accepted_ns: np.ndarray, points: Sequence[tuple[int, int]], taken: Sequence[tuple[int, int]]
) -> list[float]:
    """For each point of one stream, in order, as (sequence, the gateway's point id): when the
    first slot report covering it was seen (``taken`` holds (seen ns, ``Slot.taken_id``) in
    arrival order) minus when the client read its SUCCESS (``accepted_ns[sequence]``; 0: never
    accepted, skipped)."""
    result = []
    cursor = 0
    for sequence, point_id in points:
        while cursor < len(taken) and taken[cursor][1] < point_id:
            cursor += 1
        if cursor == len(taken):
            break
        accepted = int(accepted_ns[sequence])
        if accepted:
            result.append((taken[cursor][0] - accepted) / 1e6)
    return result


Rows = dict[str, dict[str, list[float]]]


@dataclass
class Recorders:
    """What one cell's runs need."""

    observer: Observer
    streamer: StreamClientProcess
    points: list[tuple[int, bytes]]
    """``group/0/point`` samples (seen ns, raw)."""
    slots: list[tuple[int, bytes]]
    """``group/0/slot`` samples (seen ns, raw)."""


def _turnaround(recorders: Recorders, first_point: int, record: StreamRecord) -> list[float]:
    point, slot = Decoder(Point), Decoder(Slot)
    published = [point.decode(raw) for _, raw in recorders.points[first_point:]]
    taken = [(at, slot.decode(raw).taken_id) for at, raw in list(recorders.slots)]
    ids = [(p.sequence, p.point_id) for p in published]
    return slot_turnaround_ms(record.accepted_ns, ids, taken)


def _stream_once(
    recorders: Recorders,
    starts: dict[int, tuple[float, ...]],
    variant: Variant,
    count: int,
    direction: float,
) -> dict[str, float]:
    observer, streamer = recorders.observer, recorders.streamer
    plans = ramps(starts, direction * SPEED, (count - 1) * variant.spacing_s, variant.spacing_s)
    mark = observer.mark()
    first_point = len(recorders.points)
    record = streamer.stream(
        ex_messages(plans),
        stream_bound_s(count * variant.spacing_s),
        busy_retry_s=variant.busy_retry_s,
        pace_s=variant.spacing_s if variant.paced else 0.0,
    ).check()
    observer.wait_still(timeout=30.0)
    result = analyse(observer.ticks_since(mark), count, variant.spacing_s, record.first_sent_ns)
    result["busy"] = record.busy / max(1, record.points)
    turnaround = _turnaround(recorders, first_point, record) if variant.turnaround else []
    if turnaround:
        result["turnaround_p50"], result["turnaround_p99"] = percentiles(turnaround, (50, 99))
    return result


def _measure(
    index: int, extensions: Extensions, variants: Sequence[Variant], quick: bool, rows: Rows
) -> None:
    """Every run of ``variants`` on one cell with these ``extensions``."""
    with contextlib.ExitStack() as stack:
        directory = stack.enter_context(workdir())
        cell = stack.enter_context(bench_cell(directory, f"bench5c{index}", extensions=extensions))
        observer = stack.enter_context(Observer(cell))
        observer.record_ticks()
        points = observer.record(cell.keys.group_point(0))
        slots = observer.record(cell.keys.group_slot(0))
        state = StateClientProcess(cell, directory / "state.npz", RECORDING_S)
        stack.callback(state.kill)
        streamer = stack.enter_context(StreamClientProcess(cell, directory))
        stack.enter_context(gc_paused())
        streamer.start_traj_mode()
        recorders = Recorders(observer, streamer, points, slots)
        direction = -1.0  # the first run goes up: every model's ranges reach 1.6 rad up
        for _ in range(RUNS):
            for variant in variants:
                direction = -direction
                count = variant.points // QUICK_DIVISOR if quick else variant.points
                starts = positions_of(cell.cell, observer.wait_still())
                result = _stream_once(recorders, starts, variant, count, direction)
                for key, value in result.items():
                    rows[variant.name].setdefault(key, []).append(value)


def run(quick: bool) -> list[dict[str, Any]]:
    rows: Rows = {v.name: {} for v in VARIANTS}
    cells = list(dict.fromkeys(v.extensions for v in VARIANTS))
    for index, extensions in enumerate(cells):
        variants = [v for v in VARIANTS if v.extensions == extensions]
        _measure(index, extensions, variants, quick, rows)
    results = []
    for variant in VARIANTS:
        results += _variant_results(variant, rows[variant.name], quick)
    return results


def _variant_results(
    variant: Variant, r: dict[str, list[float]], quick: bool
) -> list[dict[str, Any]]:
    name = f"[{variant.name}] "
    count = variant.points // QUICK_DIVISOR if quick else variant.points
    where = f"{count} points x 4 groups, {variant.spacing_s * 1000:g} ms apart"
    results = [
        figure_result(
            FIGURE,
            name + "empty-queue periods mid-trajectory",
            "periods",
            r["empty"],
            goal=("==", 0) if variant.empty_goal else None,
            rule="all",
            note=where,
        ),
        figure_result(
            FIGURE,
            name + "finish - nominal",
            "ms",
            r["finish_over_ms"],
            goal=("<=", FINISH_GOAL_MS) if variant.finish_goal else None,
        ),
        figure_result(
            FIGURE, name + "start latency (first point sent -> first move)", "ms", r["start_ms"]
        ),
        figure_result(FIGURE, name + "groups' start ticks spread", "ticks", r["start_spread"]),
        figure_result(FIGURE, name + "BUSY replies per accepted point", "", r["busy"]),
        figure_result(FIGURE, name + "tick samples the observer lost", "ticks", r["lost"]),
    ]
    if variant.turnaround:
        goal = ("<=", TURNAROUND_P99_GOAL_MS)
        results += [
            figure_result(
                FIGURE,
                name + "slot turnaround p50 (SUCCESS read -> slot taken seen)",
                "ms",
                r.get("turnaround_p50", []),
                note="group 0, per run",
            ),
            figure_result(
                FIGURE, name + "slot turnaround p99", "ms", r.get("turnaround_p99", []), goal=goal
            ),
        ]
    return results
