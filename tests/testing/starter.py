"""A program that starts a cell with ``motocell.testing.cell()`` and holds it until its stdin
closes (tests/testing/test_lifeline.py runs it, then kills it or closes its stdin).

Once the cell is whole it writes the file ``--ready`` names, in JSON: what of the cell a test
looks for afterwards, its processes, ports and directories, as ``Started``. ``--from-thread``
starts the cell from a thread that ends at once, the cell then held by the main thread;
``--router`` also starts a router of its own (``running_cell.zenoh_router``), its port among
the cell's.
"""

from __future__ import annotations

import argparse
import sys
import threading
from contextlib import ExitStack
from pathlib import Path

import msgspec

from motocell.testing import CellUnderTest, cell
from motocell.testing.processes import descendants
from motocell.testing.running_cell import router_on_free_port


class Started(msgspec.Struct, frozen=True):
    pids: list[int]
    """The launcher and every process below it."""
    ports: list[int]
    """The cell's TCP ports and its router's."""
    directories: list[str]
    """Every directory the harness made for the cell: its run directory, its cell file's."""


def describe(started: CellUnderTest) -> Started:
    running = started.running
    launcher = running.process.pid
    router_port = int(running.zenoh_endpoint.rsplit(":", 1)[1])
    assert running.config is not None, "cell() always writes a cell file"
    return Started(
        pids=[launcher, *sorted(descendants(launcher))],
        ports=[started.motion_port, started.state_port, started.io_port, router_port],
        directories=[str(running.runtime_dir), str(Path(running.config).parent)],
    )


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--ready", type=Path, required=True)
    parser.add_argument("--from-thread", action="store_true")
    parser.add_argument("--router", action="store_true")
    args = parser.parse_args()
    with ExitStack() as stack:
        router_ports = []
        if args.router:
            endpoint = stack.enter_context(router_on_free_port())
            router_ports.append(int(endpoint.rsplit(":", 1)[1]))
        if args.from_thread:
            found: list[CellUnderTest] = []
            starter = threading.Thread(
                target=lambda: found.append(stack.enter_context(cell())), name="starter"
            )
            starter.start()
            starter.join()
            (started,) = found
        else:
            started = stack.enter_context(cell())
        draft = args.ready.with_suffix(".draft")
        described = describe(started)
        described.ports.extend(router_ports)
        draft.write_bytes(msgspec.json.encode(described))
        draft.replace(args.ready)  # whole, never half written
        sys.stdin.read()


if __name__ == "__main__":
    main()
