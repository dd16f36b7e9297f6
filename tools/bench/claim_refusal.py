"""How long a second process of a running service's name takes to be refused, on an idle or
a loaded machine (the numbers are in docs/realtime.md)

    python -m motocell.tools.bench.claim_refusal [--hogs 8] [--trials 5]

Not part of ``motocell bench``. It starts the default cell, then ``--hogs`` busy loops at
ordinary priority (in this session), and starts a second gateway against the cell ``--trials``
times by each entry: ``motocell service gateway`` and ``python -m motocell.services.gateway``
(both ask for the services' priority after their imports, docs/realtime.md). Each must be
refused with exit status 2; the wall time from spawn to exit is reported, median and largest,
per entry.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

from motocell.shared.config import EXIT_CONFIG
from motocell.shared.ports import free_port_block
from motocell.testing.running_cell import RunningCell, running_cell
from motocell.tools.bench.loaded_priority import hogs

ENTRIES = {
    "motocell service": [sys.executable, "-m", "motocell.tools.cli", "service", "gateway"],
    "python -m": [sys.executable, "-m", "motocell.services.gateway"],
}
REFUSAL_TIMEOUT_S = 300.0


def refusal_s(cell: RunningCell, entry: list[str]) -> float:
    """One second gateway's time from spawn to its refusal."""
    command = [*entry, "--port-base", str(free_port_block(3))]
    command += ["--zenoh-connect", cell.zenoh_endpoint, "--credentials", str(cell.credentials)]
    started = time.monotonic()
    done = subprocess.run(
        command, capture_output=True, text=True, timeout=REFUSAL_TIMEOUT_S, check=False
    )
    took = time.monotonic() - started
    if done.returncode != EXIT_CONFIG or "already running" not in done.stderr:
        raise SystemExit(f"not refused as expected ({done.returncode}): {done.stderr.strip()}")
    return took


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m motocell.tools.bench.claim_refusal")
    parser.add_argument("--hogs", type=int, default=0, help="busy loops beside the cell")
    parser.add_argument("--trials", type=int, default=5, help="refusals per entry")
    args = parser.parse_args(argv)
    times: dict[str, list[float]] = {kind: [] for kind in ENTRIES}
    with running_cell() as cell, hogs(args.hogs, own_session=False):
        for _ in range(args.trials):
            for kind, entry in ENTRIES.items():  # interleaved: the machine's load drifts
                times[kind].append(refusal_s(cell, entry))
    for kind, seconds in times.items():
        print(
            f"hogs {args.hogs:3d}  {kind:17s} median {statistics.median(seconds):.2f} s  "
            f"max {max(seconds):.2f} s  (n={len(seconds)})"
        )


if __name__ == "__main__":
    main()
