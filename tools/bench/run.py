"""The whole benchmark suite: one table, and JSON in bench-results/ (under the current directory).

    motocell bench [--quick] [--only 3,6] [--out DIR] (or: python -m motocell.tools.bench.run ...)

Figures (goals are for a 2-core machine running the whole cell):

1. codec decode/encode frames/s                               (bench.bench_codec)
2. interpolation entries/s per group                          (bench.bench_interpolation)
3. executor lateness and missed periods under load            (bench.bench_executor)
4. motion-port round trips: commands, CHECK_QUEUE_CNT, points (bench.bench_roundtrip)
5. streaming point by point: motoman_driver, paced clients,
   slot turnaround, the pending-point FIFO                    (bench.bench_streaming)
6. state rate and feedback age with 4 clients                 (bench.bench_state; runs of 3)
7. cells per machine: idle single-arm cells within half the
   CPU; four four-group cells driven side by side             (bench.bench_scale)
8. accuracy against the float64 closed form                   (bench.bench_accuracy)
9. start-up and stop                                          (bench.bench_startup)
10. cost: CPU and wake-ups per process, idle and moving       (bench.bench_cost)
11. headroom: figures 4 and 6 alone and beside a streaming
    neighbour cell, alternating                               (bench.bench_headroom)
12. ROS 2 face: its CPU idle and moving, joint_states rate
    and age at an rclpy subscriber                            (bench.bench_ros2)
13. cell start cost: CPU, wall and memory of a cell from spawn
    to motion-ready, single-arm and four-group                (bench.bench_start_cost)
14. a cell per test: 50 plugin tests, each its own cell       (bench.bench_plugin)
15. a factory floor: 100 single-arm cells ready, at rest, and
    8 of them streaming side by side                          (bench.bench_floor)

Every figure is the median and [min-max] of at least 3 runs. Benchmarks report; they never fail
on a time. The clients that measure are processes of their own (``tools.bench.clients``: the state
clients and the motion client, garbage collector off, records preallocated), so the benchmark is
never the slowest part. Before the results the suite prints each figure's conditions: whether
the executor ran SCHED_FIFO (``ExecutorMetrics.realtime``) and the 1-minute load average at its
start and end, with a warning (also in the JSON) when either exceeds 0.7 x the CPUs, which makes
that figure's numbers unreliable.

The full suite takes a quarter of an hour or more (figures 1-9 alone take about 15 minutes on an
idle 2-vCPU VM; figures 3 and 7: 3 x 60 s windows each), ``--quick`` a few minutes. Results:
``<UTC timestamp>.json`` and ``latest.json`` in ``--out``, by default ``bench-results`` under the
current directory (ignored by git in a checkout's root), so an installed motocell never writes
into its own package.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
import traceback
from collections.abc import Callable, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from motocell.testing.processes import descendants
from motocell.tools.bench import (
    bench_accuracy,
    bench_codec,
    bench_cost,
    bench_executor,
    bench_floor,
    bench_headroom,
    bench_interpolation,
    bench_plugin,
    bench_ros2,
    bench_roundtrip,
    bench_scale,
    bench_start_cost,
    bench_startup,
    bench_state,
    bench_streaming,
)
from motocell.tools.bench.measuring import EXECUTOR_MODES, RESULTS_DIR, machine_info

Results = list[dict[str, Any]]

LOAD_SHARE = 0.7


FIGURES: dict[int, tuple[str, Callable[[bool], Results]]] = {
    1: ("codec throughput", bench_codec.run),
    2: ("interpolation throughput", bench_interpolation.run),
    3: ("executor lateness", bench_executor.run),
    4: ("round trips", bench_roundtrip.run),
    5: ("streaming point by point", bench_streaming.run),
    6: ("state rate and age", bench_state.run),
    7: ("scale", bench_scale.run),
    8: ("accuracy", bench_accuracy.run),
    9: ("start-up", bench_startup.run),
    10: ("cost", bench_cost.run),
    11: ("headroom beside a neighbour", bench_headroom.run),
    12: ("ROS 2 face", bench_ros2.run),
    13: ("cell start cost", bench_start_cost.run),
    14: ("a cell per test", bench_plugin.run),
    15: ("a factory floor", bench_floor.run),
}


def fmt(value: float, unit: str) -> str:
    if math.isnan(value):
        return "-"
    if value == int(value) and abs(value) < 1e15:
        return f"{int(value):,}"
    if unit == "pulse":
        return f"{value:.6f}"
    magnitude = abs(value)
    if magnitude >= 10_000:
        return f"{value:,.0f}"
    if magnitude >= 100:
        return f"{value:.0f}"
    if magnitude >= 10:
        return f"{value:.1f}"
    if magnitude >= 1:
        return f"{value:.2f}"
    return f"{value:.3f}"


def table(results: Results) -> str:
    header = ["fig", "value", "median", "[min - max]", "unit", "goal", "met"]
    rows = [header]
    for r in results:
        if "error" in r:
            error = str(r["error"])
            error = error if len(error) <= 90 else error[:87] + "..."
            rows.append([str(r["figure"]), f"ERROR: {error}", "", "", "", "", ""])
            continue
        unit = str(r["unit"])
        met = r.get("met")
        rows.append(
            [
                str(r["figure"]),
                str(r["name"]),
                fmt(r["median"], unit),
                f"[{fmt(r['min'], unit)} - {fmt(r['max'], unit)}]",
                unit,
                str(r.get("goal", "")),
                "" if met is None else ("yes" if met else "NO"),
            ]
        )
    return markdown(rows, right={2, 3})


def markdown(rows: list[list[str]], right: set[int]) -> str:
    """A Markdown table, the first row its header; columns in ``right`` right-aligned."""
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]

    def line(row: list[str]) -> str:
        cells = [
            cell.rjust(widths[i]) if i in right else cell.ljust(widths[i])
            for i, cell in enumerate(row)
        ]
        return "| " + " | ".join(cells) + " |"

    separator = (
        "|"
        + "|".join(
            ("-" * (w + 1) + ":") if i in right else ("-" * (w + 2)) for i, w in enumerate(widths)
        )
        + "|"
    )
    return "\n".join([line(rows[0]), separator, *(line(row) for row in rows[1:])])


def load_limit(cpus: int) -> float:
    """The 1-minute load average above which a figure's numbers are not to be trusted: the
    benchmark then shares the machine with other work (LOAD_SHARE of the CPUs)."""
    return LOAD_SHARE * cpus


def load_warning(before: float, after: float, cpus: int) -> str | None:
    """Why a figure whose load average was ``before`` at its start and ``after`` at its end is
    unreliable; None when both are within ``load_limit``."""
    limit = load_limit(cpus)
    if max(before, after) <= limit:
        return None
    return (
        f"load average {before:.2f} at start, {after:.2f} at end: above {limit:g} "
        f"({LOAD_SHARE:g} x {cpus} CPUs), unreliable"
    )


def executor_text(realtime: bool | None) -> str:
    if realtime is None:
        return "-"
    return "SCHED_FIFO" if realtime else "NOT SCHED_FIFO"


def conditions(figures: dict[str, dict[str, Any]]) -> str:
    """Per figure: how the executor ran, the load average around it, whether it is reliable."""
    rows = [["fig", "title", "executor", "load average start / end", "reliable", "s"]]
    for figure, entry in figures.items():
        before, after = entry["loadavg_before"][0], entry["loadavg_after"][0]
        rows.append(
            [
                figure,
                str(entry["title"]),
                executor_text(entry["executor_realtime"]),
                f"{before:.2f} / {after:.2f}",
                "NO" if entry["unreliable"] else "yes",
                f"{entry['seconds']:.0f}",
            ]
        )
    return markdown(rows, right={5})


def warnings(figures: dict[str, dict[str, Any]]) -> list[str]:
    lines = []
    for figure, entry in figures.items():
        if entry["unreliable"]:
            lines.append(f"WARNING: figure {figure}: {entry['unreliable']}")
        if entry["executor_realtime"] is False:
            lines.append(
                f"WARNING: figure {figure}: the executor ran without SCHED_FIFO "
                "(run as root, or grant CAP_SYS_NICE and an rtprio limit)"
            )
    return lines


def parse_only(text: str | None) -> list[int]:
    if not text:
        return list(FIGURES)
    chosen = []
    for part in text.split(","):
        figure = int(part)
        if figure not in FIGURES:
            raise SystemExit(f"--only: no figure {figure} (figures: 1-{len(FIGURES)})")
        chosen.append(figure)
    return sorted(set(chosen))


def write(report: dict[str, Any], stamp: str, directory: Path) -> list[Path]:
    directory.mkdir(parents=True, exist_ok=True)
    text = json.dumps(report, indent=1, default=str) + "\n"
    paths = [directory / f"{stamp}.json", directory / "latest.json"]
    for path in paths:
        path.write_text(text)
    return paths


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--quick", action="store_true", help="every benchmark briefly (a few minutes)"
    )
    parser.add_argument("--only", metavar="N,N", help="only these figures, e.g. 3,6")
    parser.add_argument(
        "--out",
        type=Path,
        default=RESULTS_DIR,
        metavar="DIR",
        help=f"where the JSON results go (default: {RESULTS_DIR} under the current directory)",
    )


def run(args: argparse.Namespace) -> int:
    return run_suite(args.quick, parse_only(args.only), args.out)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m motocell.tools.bench.run", description=__doc__.split("\n")[0]
    )
    add_arguments(parser)
    return run(parser.parse_args(argv))


def run_figure(figure: int, quick: bool, results: Results) -> dict[str, Any]:
    """Measure one figure into ``results``; its entry for the report (conditions, errors)."""
    title, bench = FIGURES[figure]
    print(f"  [{figure}] {title} ...", end="", flush=True)
    begun = time.monotonic()
    entry: dict[str, Any] = {"title": title, "loadavg_before": os.getloadavg()}
    EXECUTOR_MODES.clear()
    try:
        results += bench(quick)
    except Exception as exc:
        traceback.print_exc()
        entry["error"] = f"{type(exc).__name__}: {exc}"
        results.append({"figure": figure, "error": entry["error"]})
    entry["seconds"] = round(time.monotonic() - begun, 1)
    entry["loadavg_after"] = os.getloadavg()
    entry["executor_realtime"] = EXECUTOR_MODES.realtime()
    entry["load_limit"] = load_limit(os.cpu_count() or 1)
    entry["unreliable"] = load_warning(
        entry["loadavg_before"][0], entry["loadavg_after"][0], os.cpu_count() or 1
    )
    load = entry["loadavg_after"][0]
    print(f" {entry['seconds']:.0f} s (load average {load:.1f})", flush=True)
    return entry


def run_suite(quick: bool, figures: list[int], out: Path) -> int:
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    report: dict[str, Any] = {
        "timestamp": stamp,
        "quick": quick,
        "figures": {},
        "machine": machine_info(),
        "results": [],
    }
    results: Results = report["results"]
    started = time.monotonic()
    mode = "quick" if quick else "full"
    print(f"motocell benchmarks ({mode}), figures {', '.join(map(str, figures))}", flush=True)
    status = 0
    try:
        for figure in figures:
            entry = report["figures"][str(figure)] = run_figure(figure, quick, results)
            status = 1 if "error" in entry else status
    except KeyboardInterrupt:
        report["interrupted"] = True
        status = 130
        print("\ninterrupted; writing what was measured", file=sys.stderr)
    report["seconds"] = round(time.monotonic() - started, 1)
    report["machine"]["loadavg_at_end"] = os.getloadavg()
    report["warnings"] = warnings(report["figures"])
    print()
    print(conditions(report["figures"]))
    print()
    if report["warnings"]:
        print("\n".join(report["warnings"]) + "\n")
    print(table(results))
    machine = report["machine"]
    print(
        f"\n{machine['nproc']} x {machine['cpu_model']}, Python {machine['python']}, "
        f"kernel {machine['kernel']}; load average at start "
        f"{machine['loadavg_at_start'][0]:.2f}, at end {machine['loadavg_at_end'][0]:.2f}; "
        f"{report['seconds']:.0f} s"
    )
    for path in write(report, stamp, out):
        print(f"written: {path}")
    leftovers = descendants(os.getpid())
    if leftovers:
        print(f"warning: processes left running: {sorted(leftovers)}", file=sys.stderr)
        status = status or 1
    return status


if __name__ == "__main__":
    sys.exit(main())
