"""Zenoh's own threads in a cell's processes: which of its runtimes does the work.

Zenoh runs its work on a few runtimes (application, accept, transmit, receive), each with
threads of its own unless its work is handed over to another's (``ZENOH_RUNTIME``, read once,
when a process opens its first session). With its defaults every sample a service receives
wakes two receive workers and the application thread that fills the channel, and a router
wakes its accept thread (whose poller owns the sockets it accepted), a receive worker and its
transmit thread for every sample it passes on. A cell's samples are small and a few hundred a
second, so the hand-overs cost more than the work. Every process of a cell, service or router,
receives on the application thread, which also polls the sockets a router accepted, and keeps
its transmit thread: the executor's tick and a router's forwarding leave without waiting
behind received work (a router doing its transmitting on the same thread too costs less
still, but figure 5's slot turnaround p99 then misses its goal).

Measured on figure 10's moving four-group cell (docs/realtime.md, "Zenoh's threads"). A
``ZENOH_RUNTIME`` already in the environment is someone's own tuning and is kept.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager

ENV = "ZENOH_RUNTIME"
CELL_RUNTIME = "(rx: (handover: app), acc: (handover: app))"


@contextmanager
def zenoh_runtime() -> Iterator[None]:
    """Open the process's first session inside this: Zenoh takes ``CELL_RUNTIME`` then. The
    environment is left as it was, so processes started later (the launcher's services) choose
    for themselves, and a user's own value reaches them."""
    if ENV in os.environ:
        try:
            yield
        except BaseException as exc:
            # Zenoh panics on a value it cannot read; pyo3's PanicException has no import path.
            if type(exc).__name__ != "PanicException":
                raise
            raise ConnectionError(
                f"{ENV}={os.environ[ENV]!r} is not a runtime Zenoh can read ({exc}): "
                f"fix it or unset it"
            ) from None
        return
    os.environ[ENV] = CELL_RUNTIME
    try:
        yield
    finally:
        os.environ.pop(ENV, None)
