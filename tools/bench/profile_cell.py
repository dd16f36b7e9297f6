"""Where the services spend their CPU under a benchmark's load: py-spy on a real cell.

    python -m motocell.tools.bench.profile_cell [--scenario points|state] [--seconds 10]
        [--services gateway,...]

Starts a 4-group cell, applies a load, and samples the chosen services with
``py-spy record --format raw`` (install it with ``.venv/bin/pip install py-spy``; it needs
ptrace, i.e. root or CAP_SYS_PTRACE). Prints, per service, the functions with the most samples
on-CPU, by self time and inclusive time, and leaves the collapsed stacks (flame-graph input) in
the output directory.

Scenarios:

- ``points``: figures 4/5, a 2016 trajectory for 4 groups with points 4 ms apart streamed like
  motoman_driver (SUCCESS, then BUSY and a 5 ms back-off), every axis swinging 0.2 rad;
- ``state``: figures 3/6, state period 4 ms, 4 state clients, 4 groups moving (points 100 ms
  apart).

The clients run in processes of their own (``tools.bench.clients``), as in the benchmarks.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from collections import Counter
from contextlib import ExitStack
from pathlib import Path

from motocell.testing.client import ex_messages
from motocell.tools.bench.clients import StateClientProcess, StreamClientProcess, stream_bound_s
from motocell.tools.bench.measuring import (
    Observer,
    bench_cell,
    oscillations,
    positions_of,
    process_kinds,
    wait_moving,
    workdir,
)

TOP = 15


def summarise(raw: Path, top: int = TOP, within: str = "") -> str:
    """Top functions by self and by inclusive samples from py-spy's collapsed stacks (only
    the stacks through a function whose name contains ``within``, if given)."""
    own: Counter[str] = Counter()
    inclusive: Counter[str] = Counter()
    total = 0
    for line in raw.read_text(errors="replace").splitlines():
        stack, _, count_text = line.rpartition(" ")
        if not stack or not count_text.isdigit():
            continue
        count = int(count_text)
        frames = stack.split(";")[1:]  # the first is the thread
        if not frames or (within and not any(within in frame for frame in frames)):
            continue
        total += count
        own[frames[-1]] += count
        for frame in set(frames):
            inclusive[frame] += count
    if not total:
        return "  (no samples)"
    lines = [f"  {total} samples", "  self:"]
    lines += [f"    {100 * n / total:5.1f}%  {frame}" for frame, n in own.most_common(top)]
    lines.append("  inclusive:")
    lines += [f"    {100 * n / total:5.1f}%  {frame}" for frame, n in inclusive.most_common(top)]
    return "\n".join(lines)


def py_spy() -> str | None:
    """py-spy next to this Python (the venv), else on PATH."""
    beside = Path(sys.executable).parent / "py-spy"
    return str(beside) if beside.exists() else shutil.which("py-spy")


def record(
    pid: int, seconds: float, out: Path, *, rate: int, gil: bool, idle: bool = False
) -> subprocess.Popen[bytes]:
    command = [
        *(py_spy() or "py-spy", "record", "--pid", str(pid), "--duration", str(round(seconds))),
        *("--rate", str(rate), "--format", "raw", "--output", str(out), "--nonblocking"),
        *(("--gil",) if gil else ()),
        *(("--idle",) if idle else ()),
    ]
    return subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description="py-spy profiles of a loaded cell")
    parser.add_argument("--scenario", choices=("points", "state"), default="points")
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--rate", type=int, default=250, help="py-spy samples per second")
    parser.add_argument(
        "--services",
        default="gateway,broadcaster,executor,interpolator",
        help="comma-separated service kinds to sample (interpolator = all of them)",
    )
    parser.add_argument(
        "--gil", action="store_true", help="only samples of the thread holding the GIL"
    )
    parser.add_argument(
        "--idle", action="store_true", help="also samples of waiting threads (wall time)"
    )
    parser.add_argument(
        "--within",
        default="",
        help="summarise only stacks through this function, e.g. RequestServer._serve",
    )
    parser.add_argument("--out", default=str(Path(tempfile.gettempdir()) / "motocell-profile"))
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if py_spy() is None:
        print(
            "bench.profile_cell: py-spy is not installed (.venv/bin/pip install py-spy)",
            file=sys.stderr,
        )
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    wanted = set(args.services.split(","))
    state_period = 4.0 if args.scenario == "state" else 10.0
    with ExitStack() as stack:
        directory = stack.enter_context(workdir())
        cell = stack.enter_context(bench_cell(directory, "profile", state_period_ms=state_period))
        observer = stack.enter_context(Observer(cell))
        observer.record_ticks()
        for index in range(4 if args.scenario == "state" else 1):
            client = StateClientProcess(cell, directory / f"state{index}.npz", args.seconds + 60)
            stack.callback(client.kill)
        streamer = stack.enter_context(StreamClientProcess(cell, directory))
        streamer.start_traj_mode()
        starts = positions_of(cell.cell, observer.wait_still(timeout=30.0))
        interval = 0.004 if args.scenario == "points" else 0.1
        plans = oscillations(starts, 0.2, 4.0, args.seconds + 30.0, interval)
        mark = observer.mark()
        streamer.begin(ex_messages(plans), stream_bound_s(args.seconds + 30.0))
        stack.callback(streamer.end)
        wait_moving(observer, mark)
        time.sleep(1.0)
        targets = {
            pid: kind
            for pid, kind in process_kinds(cell).items()
            if kind in wanted or kind.split("/")[0] in wanted
        }
        samplers = []
        for pid, kind in sorted(targets.items(), key=lambda item: item[1]):
            raw = out / f"{args.scenario}-{kind}-{pid}.txt"
            samplers.append(
                (
                    kind,
                    pid,
                    raw,
                    record(pid, args.seconds, raw, rate=args.rate, gil=args.gil, idle=args.idle),
                )
            )
        for kind, pid, raw, sampler in samplers:
            _, err = sampler.communicate(timeout=args.seconds + 60)
            print(f"{kind} (pid {pid}), {args.scenario} load, {args.seconds:g} s: {raw}")
            if sampler.returncode != 0 or not raw.exists():
                print(f"  py-spy failed: {err.decode(errors='replace').strip()}")
                continue
            print(summarise(raw, within=args.within))
    return 0


if __name__ == "__main__":
    sys.exit(main())
