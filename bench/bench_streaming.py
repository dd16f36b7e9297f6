"""Figure 5: streaming a 4-group trajectory with points every 4 ms (one interpolation period).

    python -m bench.run --only 5 [--quick]

A 4-group cell (default 10 ms state period, one state client connected). Each run streams
2000 MOTO_JOINT_TRAJ_PT_FULL_EX (2016) points 4 ms apart (quick: 100), constant velocity on
every axis so that every executed period moves every axis. Three clients, each run 3 times:

- motoman_driver (the goal's client): the next point at once after SUCCESS, a BUSY point
  resent after 5 ms (``testkit.client.stream_ex`` semantics);
- paced 4 ms: point i is sent no earlier than i x 4 ms after the first, BUSY resent after 5 ms;
- BUSY retry 1 ms (diagnostic): as motoman_driver but resending after 1 ms, to show what the
  cell sustains when the client's back-off is not the limit.

From the ``executor/tick`` stream:

- empty-queue periods: for each group, the ticks between its first and its last moving tick
  that did not move it (its ring was empty: the executor had nothing to apply), summed over
  the groups. With no starvation each group's moving span is exactly (points - 1) ticks;
- finish - nominal: wake time of the tick that applied the last point minus the time the first
  point was sent, minus the nominal duration (points - 1) x 4 ms;
- start latency: first point sent -> first moving tick; BUSY replies per accepted point.

Diagnosis: the slot turnaround, seen by a Zenoh observer: a point published to group 0 ->
that group's interpolator reporting it taken (``Slot.taken_id``). The gateway answers BUSY
until then, so a client that sends the next point sooner gets BUSY and, at 5 ms back-off,
can accept at most one point per ~5-6 ms, slower than the 4 ms the executor consumes.
"""

from __future__ import annotations

from typing import Any

from bench.harness import (
    BUSY_RETRY_S,
    Observer,
    Streamer,
    bench_cell,
    figure_result,
    percentiles,
    positions_of,
    ramps,
    start_traj_mode,
    wake_ns,
    workdir,
)
from shared.bus.schemas import Decoder, Point, Slot, Tick
from testkit.client import ex_messages

FIGURE = 5
RUNS = 3
POINTS = 2000
QUICK_POINTS = 100
INTERVAL_S = 0.004
SPEED = 0.2
FINISH_GOAL_MS = 50.0


def analyse(ticks: list[Tick], points: int, first_sent_ns: int) -> dict[str, float]:
    """By tick number, so a tick sample the observer missed (the tick key may be published
    with DROP congestion control) is counted as lost, not as an empty period."""
    groups = len(ticks[0].groups)
    empty = lost = 0
    first_moving: list[Tick] = []
    last_moving: list[Tick] = []
    for g in range(groups):
        moving = [t for t in ticks if any(t.groups[g].increment)]
        if not moving:
            raise RuntimeError(f"group {g} never moved")
        first, last = moving[0], moving[-1]
        seen = sum(1 for t in ticks if first.tick <= t.tick <= last.tick)
        empty += seen - len(moving)
        lost += (last.tick - first.tick + 1) - seen
        first_moving.append(first)
        last_moving.append(last)
    start = min(first_moving, key=lambda t: t.tick)
    finish = max(last_moving, key=lambda t: t.tick)
    starts = [t.tick for t in first_moving]
    entries = points - 1
    return {
        "empty": float(empty),
        "lost": float(lost),
        "finish_over_ms": (wake_ns(finish) - first_sent_ns - entries * INTERVAL_S * 1e9) / 1e6,
        "start_ms": (wake_ns(start) - first_sent_ns) / 1e6,
        "start_spread": float(max(starts) - min(starts)),
    }


def slot_turnaround_ms(
    points: list[tuple[int, bytes]], slots: list[tuple[int, bytes]]
) -> list[float]:
    """For every point the gateway published to group 0: when the observer saw the
    interpolator's slot report it taken, minus when it saw the point."""
    point_decoder, slot_decoder = Decoder(Point), Decoder(Slot)
    taken = [(at, slot_decoder.decode(raw).taken_id) for at, raw in slots]
    result = []
    cursor = 0
    for at, raw in points:
        point_id = point_decoder.decode(raw).point_id
        while cursor < len(taken) and (taken[cursor][0] < at or taken[cursor][1] < point_id):
            cursor += 1
        if cursor == len(taken):
            break
        result.append((taken[cursor][0] - at) / 1e6)
    return result


VARIANTS = {
    "motoman_driver": (0.0, BUSY_RETRY_S),
    "paced 4 ms": (INTERVAL_S, BUSY_RETRY_S),
    "BUSY retry 1 ms": (0.0, 0.001),
}
"""(pace, BUSY retry). motoman_driver: the next point at once after SUCCESS, a BUSY point
resent after 5 ms (the goal's client). Paced: point i sent no earlier than i x 4 ms after the
first, BUSY resent after 5 ms. BUSY retry 1 ms: a diagnostic client that backs off less, to
show what the cell sustains when the client is not the limit."""


def run(quick: bool) -> list[dict[str, Any]]:
    points = QUICK_POINTS if quick else POINTS
    rows: dict[str, dict[str, list[float]]] = {v: {} for v in VARIANTS}
    turnaround: list[float] = []
    with (
        workdir() as directory,
        bench_cell(directory, "bench5") as cell,
        Observer(cell) as observer,
        cell.state(),
        cell.motion() as motion,
    ):
        observer.record_ticks()
        point_samples = observer.record(cell.keys.group_point(0))
        slot_samples = observer.record(cell.keys.group_slot(0))
        start_traj_mode(motion)
        direction = 1.0
        for _ in range(RUNS):
            for variant, (pace, retry) in VARIANTS.items():
                direction = -direction
                starts = positions_of(cell.cell, observer.wait_still())
                duration = (points - 1) * INTERVAL_S
                plans = ramps(starts, direction * SPEED, duration, INTERVAL_S)
                mark = observer.mark()
                first_point = len(point_samples)
                messages = ex_messages(plans)
                streamer = Streamer(motion, messages, busy_retry_s=retry, pace_s=pace)
                streamer.run()  # in this thread
                if streamer.error is not None:
                    raise RuntimeError(f"streaming failed: {streamer.error}")
                observer.wait_still(timeout=30.0)
                result = analyse(observer.ticks_since(mark), points, streamer.first_sent_ns)
                result["busy"] = streamer.busy / streamer.points
                for key, value in result.items():
                    rows[variant].setdefault(key, []).append(value)
                if variant == "motoman_driver":
                    turnaround += slot_turnaround_ms(
                        point_samples[first_point:], list(slot_samples)
                    )
    where = f"{points} points x 4 groups, 4 ms apart"
    results = []
    for variant, r in rows.items():
        name = f"[{variant}] "
        goals = variant == "motoman_driver"
        results += [
            figure_result(
                FIGURE,
                name + "empty-queue periods mid-trajectory",
                "periods",
                r["empty"],
                goal=("==", 0) if goals else None,
                rule="all",
                note=where,
            ),
            figure_result(
                FIGURE,
                name + "finish - nominal",
                "ms",
                r["finish_over_ms"],
                goal=("<=", FINISH_GOAL_MS) if goals else None,
            ),
            figure_result(
                FIGURE, name + "start latency (first point sent -> first move)", "ms", r["start_ms"]
            ),
            figure_result(FIGURE, name + "groups' start ticks spread", "ticks", r["start_spread"]),
            figure_result(FIGURE, name + "BUSY replies per accepted point", "", r["busy"]),
            figure_result(FIGURE, name + "tick samples the observer lost", "ticks", r["lost"]),
        ]
    p50, p99 = percentiles(turnaround, (50, 99))
    results.append(
        figure_result(
            FIGURE,
            "  diagnosis: slot turnaround p50 (point published -> slot taken)",
            "ms",
            [p50],
            note=f"group 0, all runs pooled, {len(turnaround)} points",
        )
    )
    results.append(figure_result(FIGURE, "  diagnosis: slot turnaround p99", "ms", [p99]))
    return results
