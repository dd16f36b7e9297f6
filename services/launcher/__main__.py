"""``python -m motocell.services.launcher`` (``motocell up``): the options in ``cli``, the cell
in ``up``; this module wires them. As ``motocell`` does (``tools.__main__``), it holds SIGINT
and SIGTERM from its first line until the launcher's handlers are in place, and stops on SIGINT
whatever disposition it inherits.

A run that forks services needs room in its arguments for theirs (``launcher_names.ROOM``):
started without it, the launcher starts its own interpreter again with it, before it loads
anything. Once its modules are loaded it forks its warm parent (``warm_parent``), then writes
its own command line back without the room."""

from __future__ import annotations

import gc
import os
import sys

from motocell.services.launcher.warm_parent import fork_zygote
from motocell.shared.launcher_names import ROOM_OPTION, with_room, without_room
from motocell.shared.signals import hold_stop_signals

NOTHING_TO_FORK = frozenset({"--cold", "-h", "--help", "--version"})
"""Words of a launcher's command line after which it forks no service, so needs no room."""


def main() -> None:
    # Before the imports below, where a signal would land in the middle of loading Zenoh;
    # ``up.run`` takes them (shared.service.stop_on_signals), then they stay held while the
    # interpreter shuts down.
    hold_stop_signals()
    try:
        launch(sys.argv[1:])
    finally:
        hold_stop_signals()


def launch(words: list[str]) -> None:
    """Run the launcher with ``words``, its signals held (also ``motocell up``'s, which
    ``tools.cli`` hands here); it ends by ``sys.exit``."""
    if ROOM_OPTION not in sys._xoptions and needs_room(words):
        # The same command, its interpreter's options kept; the held signals stay held.
        os.execv(sys.executable, with_room(sys.orig_argv))
    # Zenoh and the launcher load with the collector paused, as the warm parent's imports
    # are (``zygote.warm_up`` says why).
    gc.disable()
    try:
        import logging  # noqa: PLC0415

        from motocell.services.launcher.cli import parser  # noqa: PLC0415
        from motocell.services.launcher.command_line import rewrite_command_line  # noqa: PLC0415
        from motocell.services.launcher.core.forks import nul_ended  # noqa: PLC0415
        from motocell.services.launcher.heap_holes import fill_heap_holes  # noqa: PLC0415
        from motocell.services.launcher.up import run  # noqa: PLC0415
    finally:
        gc.enable()
    args = parser().parse_args(words)  # a wrong option, --help and --version end here
    zygote = None
    if not args.cold:
        # The launcher's own allocations from here on would otherwise fill its heap's holes,
        # on pages the zygote and every service share with it (``heap_holes``); frozen,
        # neither process's collections write to the pages they share.
        fill_heap_holes()
        gc.freeze()
        zygote = fork_zygote()  # outside any with or try: in the zygote, this ends the process
    if ROOM_OPTION in sys._xoptions:
        rewrite_command_line(nul_ended(without_room(sys.orig_argv)))
    try:
        args.warm_parent = zygote
        logging.basicConfig(
            level=logging.INFO, format="%(asctime)s motocell %(levelname)s %(message)s"
        )
        sys.exit(run(args))
    finally:
        if zygote is not None:
            zygote.close()


def needs_room(words: list[str]) -> bool:
    """Whether a launcher run with ``words`` forks services."""
    return not NOTHING_TO_FORK.intersection(words)


if __name__ == "__main__":
    main()
