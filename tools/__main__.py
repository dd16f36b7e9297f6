"""The ``motocell`` command (also ``python -m tools``): ``tools.cli``, loaded and run so that a
Ctrl-C or SIGTERM at any moment ends the command quietly, never with a KeyboardInterrupt
traceback and never lost.

From its first line the command holds SIGINT and SIGTERM (``shared.signals``): one that arrives
while Zenoh and the command modules load (0.2 s, seconds on a loaded machine) waits in the
kernel instead of landing in an import. Commands that run until stopped (``up``, ``router``,
``watch``, ``echo``, ``hz``, ``record``, and the service ``service`` becomes) take them once
their handlers are in place (``shared.service.stop_on_signals``), so one that came early stops
them cleanly there; every other command gets them back before it runs (``cli.main``).

SIGINT stops motocell whatever disposition it inherits: a shell script starts ``motocell up &``
with SIGINT ignored, and a cell that a script started must still stop on the SIGINT that
``kill -INT`` or the script's Ctrl-C sends. What runs before this module, Python's own start-up,
is outside its reach (docs/topology.md, Stopping a cell).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from motocell.shared.signals import hold_stop_signals

INTERRUPTED = 130
"""The status a shell gives a command that SIGINT ended (128 + 2)."""


def main(argv: Sequence[str] | None = None) -> None:
    hold_stop_signals()
    try:
        # Imported here, not at the top: the signals must be held while it loads.
        from motocell.tools import cli  # noqa: PLC0415

        cli.main(argv)
    except KeyboardInterrupt:
        sys.exit(INTERRUPTED)
    finally:
        # The command is done: a signal now would only interrupt Python's shutdown (the
        # threads' join, atexit) with a traceback. It stays pending until the process exits.
        hold_stop_signals()


if __name__ == "__main__":
    main()
