"""Figure 6: state rate achieved and feedback age (tick -> frame read) with 4 state clients.

    python -m motocell.tools.bench.run --only 6 [--quick]

Measured in the same runs as figure 3 (``tools.bench.loaded``): a 4-group cell with the state period
at one tick (4 ms, so 250 Hz is configured), 4 state clients, all groups moving.

Each state client is a lean recorder in its own process (``tools.bench.state_client``): it reads the
socket in its main thread with the garbage collector off, stamps CLOCK_MONOTONIC when the read
that completes a cycle's ROBOT_STATUS returns, and records into arrays allocated up front. All
processes are on this machine, so that clock is the executor's clock.

Which tick a cycle shows: every axis moves at constant velocity (at least 4 pulses per tick), so
the feedback positions of the 4 groups, converted back to pulses, identify exactly one executor
tick. The benchmark records every ``executor/tick`` (with its feedback pulses and its wake time,
``deadline_ns + lateness_ns``, the same instant as ``State.tick_ns``) and looks each cycle up by
its pulses. Age = read time - that tick's wake time: the whole path from the executor's tick to
a client holding the frame. This needs no assumption about ordering or lost frames, and shows
repeats (the same tick sent twice) and skips (a tick never sent).

Rate = (cycles - 1) / (last - first read time) per client within the window, against
1 / state_period. Goals: age p99 <= 3 ms and max <= 10 ms (median of the runs), every client's
rate within 1 % of the configured one.

Diagnosis rows: the age of the ``state`` sample on Zenoh as this benchmark's observer gets it
(stamped in a callback), while the cell still publishes one.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from motocell.tools.bench.bench_executor import settings
from motocell.tools.bench.loaded import LoadedRun, loaded_runs
from motocell.tools.bench.measuring import figure_result, percentiles

FIGURE = 6
AGE_P99_GOAL_MS = 3.0
AGE_MAX_GOAL_MS = 10.0
RATE_GOAL_PERCENT = 1.0


def analyse(run: LoadedRun) -> dict[str, float]:
    lookup: dict[bytes, int] = {}
    duplicated: set[bytes] = set()
    for index, row in enumerate(run.keys):
        key = row.tobytes()
        if key in lookup:
            duplicated.add(key)
        lookup[key] = index
    for key in duplicated:
        del lookup[key]
    configured_hz = 1e9 / run.state_period_ns
    ages: list[float] = []
    rates: list[float] = []
    cycles = matched = repeats = skips = steps = 0
    for client in run.clients:
        received, pulses = client["received_ns"], client["pulses"]
        if len(received) >= 2:
            rates.append((len(received) - 1) / ((received[-1] - received[0]) / 1e9))
        previous = -1
        for at, row in zip(received.tolist(), pulses, strict=True):
            cycles += 1
            found = lookup.get(row.tobytes())
            if found is None:
                previous = -1
                continue
            index = found
            matched += 1
            ages.append((at - int(run.wake[index])) / 1e6)
            if previous >= 0:
                steps += 1
                if index == previous:
                    repeats += 1
                elif index > previous + 1:
                    skips += index - previous - 1
            previous = index
    p50, p99, pmax = percentiles(ages, (50, 99, 100))
    z50, z99 = percentiles(run.state_age_ms, (50, 99))
    deviation = max((abs(r - configured_hz) / configured_hz * 100 for r in rates), default=100.0)
    return {
        "rate_mean": float(np.mean(rates)) if rates else 0.0,
        "rate_min": min(rates, default=0.0),
        "rate_deviation": deviation,
        "age_p50": p50,
        "age_p99": p99,
        "age_max": pmax,
        "matched": 100.0 * matched / cycles if cycles else 0.0,
        "repeats": 100.0 * repeats / steps if steps else 0.0,
        "skips": 100.0 * skips / steps if steps else 0.0,
        "configured": configured_hz,
        "zenoh_age_p50": z50,
        "zenoh_age_p99": z99,
        "zenoh_repeats": 100.0 * run.state_repeats / max(1, run.state_samples - 1),
        "zenoh_rate": run.state_samples / run.window_s,
        "dropped": float(run.dropped),
    }


def run(quick: bool) -> list[dict[str, Any]]:
    runs = [analyse(r) for r in loaded_runs(*settings(quick))]

    def column(name: str) -> list[float]:
        return [r[name] for r in runs]

    hz = runs[0]["configured"]
    return [
        figure_result(
            FIGURE, f"state rate, mean of 4 clients ({hz:g} Hz set)", "Hz", column("rate_mean")
        ),
        figure_result(FIGURE, "state rate, slowest client", "Hz", column("rate_min")),
        figure_result(
            FIGURE,
            "state rate, worst client's deviation",
            "%",
            column("rate_deviation"),
            goal=("<=", RATE_GOAL_PERCENT),
        ),
        figure_result(FIGURE, "feedback age p50 (tick -> frame read)", "ms", column("age_p50")),
        figure_result(
            FIGURE,
            "feedback age p99 (tick -> frame read)",
            "ms",
            column("age_p99"),
            goal=("<=", AGE_P99_GOAL_MS),
        ),
        figure_result(
            FIGURE, "feedback age max", "ms", column("age_max"), goal=("<=", AGE_MAX_GOAL_MS)
        ),
        figure_result(FIGURE, "state cycles repeating the previous tick", "%", column("repeats")),
        figure_result(FIGURE, "ticks never sent between cycles", "%", column("skips")),
        figure_result(FIGURE, "state cycles matched to a tick", "%", column("matched")),
        figure_result(
            FIGURE, "  diagnosis: records dropped (past a client's bound)", "", column("dropped")
        ),
        figure_result(
            FIGURE, "  diagnosis: age tick -> `state` on Zenoh p50", "ms", column("zenoh_age_p50")
        ),
        figure_result(
            FIGURE, "  diagnosis: age tick -> `state` on Zenoh p99", "ms", column("zenoh_age_p99")
        ),
        figure_result(
            FIGURE, "  diagnosis: `state` samples repeating a tick", "%", column("zenoh_repeats")
        ),
        figure_result(FIGURE, "  diagnosis: `state` samples on Zenoh", "1/s", column("zenoh_rate")),
    ]
