"""``python -m motocell.services.launcher`` (``motocell up``): the options in ``cli``, the cell
in ``up``; this module wires them. As ``motocell`` does (``tools.__main__``), it holds SIGINT
and SIGTERM from its first line until the launcher's handlers are in place, and stops on SIGINT
whatever disposition it inherits. It imports only what starting the warm parent needs before it
starts it (``warm_parent``): even ``argparse`` and ``logging`` would make it start 5 ms later."""

from __future__ import annotations

import gc
import sys
from collections.abc import Sequence

from motocell.services.launcher.warm_parent import started_zygote
from motocell.shared.signals import hold_stop_signals


def main(argv: Sequence[str] | None = None) -> None:
    # Before the imports below, where a signal would land in the middle of loading Zenoh;
    # ``up.run`` takes them (shared.service.stop_on_signals), then they stay held while the
    # interpreter shuts down.
    hold_stop_signals()
    try:
        _main(argv)
    finally:
        hold_stop_signals()


def _main(argv: Sequence[str] | None) -> None:
    words = sys.argv[1:] if argv is None else argv
    # The warm parent first, so that its imports run beside the launcher's (warm_parent).
    with started_zygote(words) as zygote:
        # Zenoh and the launcher load only once the signals are held, with the collector
        # paused, as the warm parent's imports are (``zygote.warm_up`` says why).
        gc.disable()
        try:
            import argparse  # noqa: PLC0415
            import logging  # noqa: PLC0415

            from motocell.services.launcher.cli import add_arguments  # noqa: PLC0415
            from motocell.services.launcher.up import run  # noqa: PLC0415
        finally:
            gc.enable()
        parser = argparse.ArgumentParser(
            prog="python -m motocell.services.launcher",
            description="Run a whole cell.",
            allow_abbrev=False,
        )
        add_arguments(parser)
        args = parser.parse_args(words)
        args.warm_parent = zygote
        logging.basicConfig(
            level=logging.INFO, format="%(asctime)s motocell %(levelname)s %(message)s"
        )
        sys.exit(run(args))


if __name__ == "__main__":
    main()
