"""Figure 11: headroom: the reply and state goals of figures 4 and 6, alone and beside a
neighbour four-group cell that streams.

    python -m motocell.tools.bench.run --only 11 [--quick]

The neighbour is figure 7's load (``tools.bench.swinging``): a four-group cell of its own, with a
state client at the default 10 ms and a motion client streaming one long 2016 trajectory (every
axis swinging 0.2 rad, points 0.2 s apart, like motoman_driver), the benchmark's observer of
its ticks closed once it moves. It is started before each run "beside" and stopped before each
run "alone" (nothing of it left), and the runs alternate, alone first: A B A B A B. The machine's
other load changes slowly, so the two conditions see the same machine.

- Round trips (figure 4's measurement, ``bench_roundtrip.measure``, on its own cell, one state
  client): per run 1000 of each command and 1000 accepted points of each kind (quick: 300 and
  100), 3 runs per condition; the same goals: every reply p50 <= 0.35 ms, p99 <= 2 ms.
- State (figure 6's measurement, ``loaded.measure_loaded``, on its own cell: 4 groups moving,
  4 state clients at a 4 ms state period): windows of 20 s (quick 2 s), 3 per condition; the
  same goals: every client's rate within 1 %, feedback age p99 <= 3 ms and max <= 10 ms; with
  the executor's lateness p99 and missed periods of the same windows (figure 3's).

A stream the measured cell refuses (NOT_READY after a stall alarm, say) is counted per
condition, the cell recovered (START_TRAJ_MODE) and the run measured again (at most twice), so
that one refusal does not end the figure. Also shown: the neighbour's own CPU (all its
processes, % of one core) while a run beside it lasted, and its refused points (a neighbour
that stopped streaming would be no neighbour).
What figures 4 and 6 measure alone is unchanged; this figure is their A/B beside a neighbour.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from motocell.tools.bench import bench_roundtrip, bench_state
from motocell.tools.bench.loaded import measure_loaded
from motocell.tools.bench.measuring import (
    CostSampler,
    figure_result,
    percentiles,
    process_kinds,
    total,
    workdir,
)
from motocell.tools.bench.swinging import SwingingCell

FIGURE = 11
RUNS = 3
"""Per condition."""
COMMANDS = 1000
POINTS = 1000
QUICK_COMMANDS = 300
QUICK_POINTS = 100
WINDOW_S = 20.0
QUICK_WINDOW_S = 2.0
ALONE = "alone"
BESIDE = "beside a streaming neighbour"
CONDITIONS = (ALONE, BESIDE)
NEIGHBOUR_S = 900.0
"""The longest a neighbour streams (its trajectory's length)."""
NEIGHBOUR_START_S = 30.0
"""Per start of the neighbour, at most: what the state clients' records allow for."""


def alternating(runs: int) -> list[str]:
    """A B A B ...: ``runs`` of each condition, alone first."""
    return [CONDITIONS[i % 2] for i in range(2 * runs)]


@dataclass
class Neighbour:
    """Started for the runs beside it, stopped for the runs alone."""

    directory: Path
    cell: SwingingCell | None = None
    sampler: CostSampler | None = None
    started: int = 0
    cpu: list[float] = field(default_factory=list)
    """Per run beside it: all its processes, % of one core."""
    refused: list[str] = field(default_factory=list)

    def want(self, condition: str) -> None:
        if condition == BESIDE and self.cell is None:
            self.started += 1
            self.cell = SwingingCell(
                self.directory, f"neighbour{self.started}", NEIGHBOUR_S, observe=False
            )
            self.sampler = CostSampler(process_kinds(self.cell.cell))
        elif condition == ALONE:
            self.stop()

    def stop(self) -> None:
        if self.cell is None:
            return
        if self.sampler is not None:
            self.cpu.append(total("all", self.sampler.finish()).cpu_percent)
        record, self.cell, self.sampler = self.cell.close(), None, None
        if record is not None and record.error:
            self.refused.append(record.error)


@contextlib.contextmanager
def neighbour(directory: Path) -> Iterator[Neighbour]:
    found = Neighbour(directory)
    try:
        yield found
    finally:
        found.stop()


def run(quick: bool) -> list[dict[str, Any]]:
    conditions = alternating(RUNS)
    counts = (QUICK_COMMANDS, QUICK_POINTS) if quick else (COMMANDS, POINTS)
    window_s = QUICK_WINDOW_S if quick else WINDOW_S
    replies_refused: list[tuple[int, str]] = []
    state_refused: list[tuple[int, str]] = []
    with workdir() as directory, neighbour(directory) as near:
        series, _ = bench_roundtrip.measure(
            counts, conditions, lambda index: near.want(conditions[index]), replies_refused
        )
        near.stop()
        loaded = measure_loaded(
            len(conditions),
            window_s,
            lambda index: near.want(conditions[index]),
            extra_s=RUNS * NEIGHBOUR_START_S,
            refusals=state_refused,
        )
    executor = {
        c: [r for r, x in zip(loaded, conditions, strict=True) if x == c] for c in CONDITIONS
    }
    states = {c: [bench_state.analyse(r) for r in executor[c]] for c in CONDITIONS}
    note = f"{RUNS} runs per condition, alternating"
    results = roundtrip_results(series, counts, note)
    results += state_results(states, executor, window_s)
    for what, refused in (("round trips", replies_refused), ("state", state_refused)):
        for condition in CONDITIONS:
            mine = [why for index, why in refused if conditions[index] == condition]
            results.append(
                figure_result(
                    FIGURE,
                    f"{what}: streams refused (the run measured again), {condition}",
                    "streams",
                    [len(mine)],
                    goal=("==", 0),
                    note="; ".join(mine),
                )
            )
    results += [
        figure_result(
            FIGURE,
            "  the neighbour's CPU, all its processes, while beside it",
            "% of 1 core",
            near.cpu,
        ),
        figure_result(
            FIGURE,
            "  the neighbour's streams that stopped at a refused point",
            "streams",
            [len(near.refused)],
            note="; ".join(near.refused),
        ),
    ]
    return results


def roundtrip_results(
    series: dict[str, bench_roundtrip.Series], counts: tuple[int, int], note: str
) -> list[dict[str, Any]]:
    results = []
    commands, points = counts
    for name in bench_roundtrip.series_names():
        for q, goal in ((50, bench_roundtrip.P50_GOAL_MS), (99, bench_roundtrip.P99_GOAL_MS)):
            for condition in CONDITIONS:
                runs = series[condition][name]
                values = [percentiles(r, (q,))[0] for r in runs]
                results.append(
                    figure_result(
                        FIGURE, f"{name} p{q}, {condition}", "ms", values, goal=("<=", goal)
                    )
                )
    results[0]["note"] = f"figure 4's; {commands} of each command, {points} points per run; {note}"
    return results


def state_results(
    states: dict[str, list[dict[str, float]]],
    executor: dict[str, list[Any]],
    window_s: float,
) -> list[dict[str, Any]]:
    rows = (
        (
            "state rate, worst client's deviation",
            "rate_deviation",
            "%",
            bench_state.RATE_GOAL_PERCENT,
        ),
        ("feedback age p50 (tick -> frame read)", "age_p50", "ms", None),
        ("feedback age p99 (tick -> frame read)", "age_p99", "ms", bench_state.AGE_P99_GOAL_MS),
        ("feedback age max", "age_max", "ms", bench_state.AGE_MAX_GOAL_MS),
    )
    results = []
    for label, key, unit, goal in rows:
        for condition in CONDITIONS:
            values = [s[key] for s in states[condition]]
            results.append(
                figure_result(
                    FIGURE,
                    f"{label}, {condition}",
                    unit,
                    values,
                    goal=None if goal is None else ("<=", goal),
                )
            )
    for condition in CONDITIONS:
        runs = executor[condition]
        results.append(
            figure_result(
                FIGURE,
                f"executor lateness p99 (figure 3's), {condition}",
                "us",
                [percentiles(r.lateness_ns / 1000, (99,))[0] for r in runs],
            )
        )
        results.append(
            figure_result(
                FIGURE,
                f"executor missed periods (figure 3's), {condition}",
                "periods",
                [float(r.missed) for r in runs],
                note="this VM's floor applies (docs/realtime.md)",
            )
        )
    results[0]["note"] = f"figure 6's; {window_s:g} s windows"
    return results
