"""Zenoh's own threads in a cell's processes: which of its runtimes does the work.

Zenoh runs its work on a few runtimes (application, accept, transmit, receive), each with
threads of its own unless its work is handed over to another's (``ZENOH_RUNTIME``, read once,
when a process opens its first session). With its defaults every sample a process receives
wakes two receive workers and the application thread that fills the channel, and a router
wakes its accept, receive and transmit threads for every sample it passes on. A cell's samples
are small and few (a few hundred a second), so the hand-overs cost more than the work:

- a service receives on the application thread (two wake-ups per sample instead of four) and
  keeps its transmit thread, so the executor's tick leaves without waiting for received work;
- a router does everything on the application thread: a sample in, routed and out, on one
  thread.

Measured on figure 10's moving four-group cell (docs/realtime.md, "Zenoh's threads"). A
``ZENOH_RUNTIME`` already in the environment is someone's own tuning and is kept.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager

ENV = "ZENOH_RUNTIME"
SERVICE_RUNTIME = "(rx: (handover: app))"
ROUTER_RUNTIME = "(rx: (handover: app), acc: (handover: app), tx: (handover: app))"


@contextmanager
def zenoh_runtime(runtime: str) -> Iterator[None]:
    """Open the process's first session inside this: Zenoh takes ``runtime`` then. The
    environment is left as it was, so processes started later (the launcher's services) choose
    their own."""
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
    os.environ[ENV] = runtime
    try:
        yield
    finally:
        os.environ.pop(ENV, None)
