"""``motocell echo KEY``: a key's samples as JSON, one line each, as ``rostopic echo`` shows a
topic's messages.

Each line is ``{"key": ..., "payload": {...}}``, the payload decoded by the key's type in the
catalogue (``shared/bus/catalog.py``) with field names; a payload that does not decode (a newer
schema, a stranger's sample on an open bus) is ``{"key": ..., "hex": "..."}``. Pipe it to ``jq``.
"""

from __future__ import annotations

import argparse
import os
import sys

import msgspec

from motocell.shared.bus import catalog
from motocell.shared.service import stop_on_signals
from motocell.tools import cells, listen
from motocell.tools.cells import CellsError
from motocell.tools.listen import Listener, Received


def add_arguments(echo: argparse.ArgumentParser) -> None:
    """The options of ``motocell echo`` (``tools.cli`` names the command)."""
    echo.description = __doc__
    listen.add_arguments(echo)
    echo.add_argument("--count", type=int, metavar="N", help="stop after N samples")
    echo.set_defaults(run=run)


def as_json(sample: Received) -> bytes:
    try:
        value = catalog.decode(sample.key, sample.payload)
    except msgspec.DecodeError:
        value = None
    if value is None:
        return msgspec.json.encode({"key": sample.key, "hex": sample.payload.hex()})
    return msgspec.json.encode({"key": sample.key, "payload": catalog.to_named(value)})


def run(args: argparse.Namespace) -> int:
    with stop_on_signals() as stop:
        try:
            samples = Listener(args)
        except CellsError as exc:
            return cells.failed("echo", exc)
        with samples:
            shown = 0
            while not stop.is_set() and (args.count is None or shown < args.count):
                sample = samples.next(stop)
                if sample is None:
                    continue
                try:
                    sys.stdout.buffer.write(as_json(sample) + b"\n")
                    sys.stdout.flush()
                except BrokenPipeError:
                    # `motocell echo state | head -3`: the reader is gone; so is the point.
                    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
                    break
                shown += 1
    return 0
