"""The ``motocell`` command (also ``python -m tools``): ``tools.cli``, loaded and run under a
guard, so that a Ctrl-C at any moment, while Zenoh and the command modules load (about 0.2 s)
included, ends the command quietly instead of with a KeyboardInterrupt traceback. Commands
that run until stopped (``up``, ``router``, ``watch``) stop cleanly on SIGINT themselves; this
covers the moments before their handlers are in place."""

from __future__ import annotations

import sys
from collections.abc import Sequence

INTERRUPTED = 130
"""The status a shell gives a command that SIGINT ended (128 + 2)."""


def main(argv: Sequence[str] | None = None) -> None:
    try:
        # Imported here, not at the top: the guard must already be in place while it loads.
        from motocell.tools import cli  # noqa: PLC0415

        cli.main(argv)
    except KeyboardInterrupt:
        sys.exit(INTERRUPTED)


if __name__ == "__main__":
    main()
