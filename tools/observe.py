"""``motocell ps`` (``tools.ps``) and ``motocell watch`` (``tools.watch``): what runs, and what
it does, for a person at a terminal.

Both are plain Zenoh observers: they subscribe and query, they never command, and they join a
secured cell as its read-only observer identity. With no arguments they cover every cell
running on this machine, each through its own router (``tools.cells`` finds them);
``--zenoh-connect`` reaches cells elsewhere.
"""

from __future__ import annotations

import argparse

from motocell.tools import ps, watch


def add_parsers(commands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    ps.add_parser(commands)
    watch.add_parser(commands)
