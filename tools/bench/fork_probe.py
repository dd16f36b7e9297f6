"""What a fork of a warm parent un-shares, by what the fork does after it.

    python -m motocell.tools.bench.fork_probe [--json]

This process does what the launcher's zygote does before it forks (imports every forked
service's ``__main__`` module, then ``gc.freeze()``), then forks once per probe. Each child
does one thing and waits; this process then reads, from the child's smaps, its private dirty
MiB in the mappings it has from this process (``memory_map.inherited_kib``: pages it copied on
writing them) and its private MiB in all. The probes:

- ``idle``: nothing (what a fork costs by itself);
- ``gc.collect``: a full collection (the frozen objects are not walked);
- ``read every module global``: takes a reference to every value of every loaded module's
  namespace once, and drops it: what CPython's reference counts alone write;
- ``zenoh.open``: a peer session with scouting off, joining nothing. Zenoh's code pages the
  child is the first to read count in its private pages in all (clean ones); in a cell every
  service reads them, so they are shared there.
"""

from __future__ import annotations

import argparse
import gc
import importlib
import json
import os
import signal
import sys
from collections.abc import Callable, Sequence
from typing import Any

from motocell.tools.bench.memory_map import (
    KindTotal,
    Mapping,
    by_kind,
    inherited_kib,
    read_mappings,
)

FORKED = ("broadcaster", "controller", "executor", "gateway", "interpolator")
"""The services the launcher forks (all but the ROS 2 face)."""

kept: list[Any] = []
"""What a probe made, held until the child is read."""


def read_every_module_global() -> None:
    for module in list(sys.modules.values()):
        for value in list(vars(module).values()):
            del value


def open_zenoh() -> None:
    import zenoh  # noqa: PLC0415 (imported by the services already)

    from motocell.shared.bus.session import bus_config  # noqa: PLC0415

    kept.append(zenoh.open(bus_config("peer")))


PROBES: dict[str, Callable[[], None]] = {
    "idle": lambda: None,
    "gc.collect": lambda: kept.append(gc.collect()),
    "read every module global": read_every_module_global,
    "zenoh.open": open_zenoh,
}


def warm_up() -> None:
    for service in FORKED:
        importlib.import_module(f"motocell.services.{service}.__main__")
    gc.freeze()


def probe(run: Callable[[], None], parent: list[Mapping]) -> tuple[float, float]:
    """The child's private dirty MiB in mappings from ``parent``, and its private MiB in all."""
    done_read, done_write = os.pipe()
    child = os.fork()
    if child == 0:
        os.close(done_read)
        run()
        os.write(done_write, b".")
        signal.pause()  # until read and killed
        os._exit(0)
    os.close(done_write)
    try:
        with os.fdopen(done_read, "rb") as done:
            if not done.read(1):
                raise RuntimeError("the probe's child ended before it was read")
        mappings = read_mappings(child)
    finally:
        os.kill(child, signal.SIGKILL)
        os.waitpid(child, 0)
    whole = sum(by_kind(mappings).values(), KindTotal()).private_kib
    return inherited_kib(mappings, parent) / 1024, whole / 1024


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="fork_probe", description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true", help="one JSON object instead of lines")
    args = parser.parse_args(argv)
    warm_up()
    parent = read_mappings(os.getpid())
    results = {name: probe(run, parent) for name, run in PROBES.items()}
    if args.json:
        print(json.dumps(results))
    else:
        for name, (inherited, whole) in results.items():
            print(f"{name:>26}: {inherited:5.1f} MiB private from the parent, {whole:5.1f} all")
    return 0


if __name__ == "__main__":
    sys.exit(main())
