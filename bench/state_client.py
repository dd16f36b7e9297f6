"""One state-port client in its own process, for the state benchmarks (figures 3 and 6).

    python -m bench.state_client --port P --config CELL.toml --out OUT.npz

Connects a ``testkit.client.StateListener``, prints ``ready``, records every state cycle until a
line (or EOF) arrives on stdin, then writes ``received_ns`` (CLOCK_MONOTONIC when the cycle's
ROBOT_STATUS was read) and ``pulses`` (each group's feedback positions converted back to pulses,
Motoman order, groups concatenated) to OUT.npz. Running each client in its own process keeps
the receive times free of the benchmark process's own threads (Zenoh, streaming).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from shared.config import load_cell
from shared.motion.kinematics import AxisMap
from shared.protocol.codec import ByteOrder
from testkit.client import StateListener

KEEP = 1_000_000


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--config", required=True)
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    cell = load_cell(args.config)
    maps = [AxisMap(group) for group in cell.groups]
    listener = StateListener(args.host, args.port, ByteOrder(cell.byte_order), keep=KEEP)
    print("ready", flush=True)
    sys.stdin.readline()
    listener.close()
    with listener.changed:
        cycles = list(listener.cycles)
    listener.frames.clear()
    received = np.array([c.received_ns for c in cycles], dtype=np.int64)
    width = sum(m.axes for m in maps)
    pulses = np.full((len(cycles), width), np.iinfo(np.int64).min, dtype=np.int64)
    for row, cycle in enumerate(cycles):
        if len(cycle.groups) != len(maps):
            continue
        parts = [
            m.ros_to_pulses(np.array(cycle.groups[g].positions[: m.axes], dtype=np.float64))
            for g, m in enumerate(maps)
        ]
        pulses[row] = np.concatenate(parts)
    np.savez(args.out, received_ns=received, pulses=pulses)


if __name__ == "__main__":
    main()
