"""Figure 10's cases taken apart: what each process and each of its threads costs.

    python -m motocell.tools.bench.thread_cost moving|idle [--seconds 20] [--windows 3]

``moving`` starts the cell of figure 10's fourth case (four groups swinging, the state period
at one tick, 4 state clients); ``idle`` the single-arm cell of its first (nothing connected).
Over each window it reads every thread's CPU time and wake-ups (``/proc/<pid>/task/<tid>``) and
prints them per process and per thread name, in % of one core and per second. An A/B of two
checkouts is this command run by each tree's own Python in turn.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from motocell.testing.running_cell import running_cell
from motocell.tools.bench.bench_cost import moving_cell
from motocell.tools.bench.measuring import (
    START_TIMEOUT_S,
    process_kinds,
    thread_usage,
    workdir,
    write_cell_file,
)

SETTLE_S = 3.0


def thread_name(pid: int, tid: int) -> str:
    try:
        return Path(f"/proc/{pid}/task/{tid}/comm").read_text().strip()
    except OSError:
        return "?"


def window(kinds: dict[int, str], seconds: float) -> dict[str, dict[str, tuple[float, float]]]:
    """{kind: {thread name: (% of one core, wake-ups/s)}}, threads of one name added up."""
    before = {pid: thread_usage(pid) for pid in kinds}
    started = time.monotonic_ns()
    time.sleep(seconds)
    after = {pid: thread_usage(pid) for pid in kinds}
    elapsed = time.monotonic_ns() - started
    found: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(lambda: [0.0, 0.0]))
    for pid, kind in kinds.items():
        for tid, usage in after[pid].items():
            old = before[pid].get(tid)
            if old is None:
                continue
            name = "main" if tid == pid else thread_name(pid, tid)
            row = found[kind][name]
            row[0] += 100 * (usage.cpu_ns - old.cpu_ns) / elapsed
            row[1] += (usage.switches - old.switches) / (elapsed / 1e9)
    return {k: {n: (r[0], r[1]) for n, r in t.items()} for k, t in found.items()}


Found = list[dict[str, dict[str, tuple[float, float]]]]


def idle(seconds: float, windows: int) -> Found:
    with workdir() as directory:
        config = write_cell_file(directory, "thread-cost", models=("arm6",))
        log = directory / "thread-cost.log"
        with running_cell(config, log=log, timeout=START_TIMEOUT_S, attempts=2) as cell:
            kinds = process_kinds(cell)
            time.sleep(SETTLE_S)
            return [window(kinds, seconds) for _ in range(windows)]


def moving(seconds: float, windows: int) -> Found:
    with workdir() as directory:
        cell = moving_cell(directory, "moving-cost", windows * seconds + SETTLE_S + 60.0)
        try:
            kinds = process_kinds(cell.cell)
            time.sleep(SETTLE_S)
            return [window(kinds, seconds) for _ in range(windows)]
        finally:
            record = cell.close()
            if record is not None:
                record.check()


def print_table(found: Found) -> None:
    totals = [sum(c for t in w.values() for c, _ in t.values()) for w in found]
    print(f"all processes: {' '.join(f'{t:.2f}' for t in totals)} % of one core")
    for kind in sorted(found[0], key=lambda k: -sum(c for c, _ in found[0][k].values())):
        cpu = [sum(c for c, _ in w.get(kind, {}).values()) for w in found]
        wake = [sum(s for _, s in w.get(kind, {}).values()) for w in found]
        print(f"  {kind:14s} {' '.join(f'{c:5.2f}' for c in cpu)} %   {wake[0]:7.1f} wake-ups/s")
        for name, (c, s) in sorted(found[0][kind].items(), key=lambda item: -item[1][0]):
            if s >= 0.1:
                print(f"      {name:16s} {c:5.2f} %   {s:7.1f}/s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=("moving", "idle"))
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--windows", type=int, default=3)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    found = (moving if args.case == "moving" else idle)(args.seconds, args.windows)
    print_table(found)
    if args.json is not None:
        data: Any = found
        args.json.write_text(json.dumps(data))


if __name__ == "__main__":
    main()
