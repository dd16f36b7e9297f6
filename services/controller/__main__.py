"""The simulated controller process: ``adapter`` puts ``core.dispatch`` on the bus; this module
wires it."""

from __future__ import annotations

from collections.abc import Sequence

from motocell.services.controller.adapter import ControllerService
from motocell.shared.service import argument_parser, running_service


def main(argv: Sequence[str] | None = None) -> None:
    args = argument_parser("controller", "The simulated Yaskawa controller.").parse_args(argv)
    with running_service("controller", "0", args) as ctx:
        controller = ControllerService(ctx)
        ctx.alive.announce()
        controller.run()


if __name__ == "__main__":
    main()
