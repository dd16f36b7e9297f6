"""Where a cell's own Zenoh router listens, and which router it links to."""

from __future__ import annotations

from collections.abc import Callable, Sequence

WELL_KNOWN_PORT = 7447
"""The first cell on a machine takes it, so observers find that cell with no arguments."""
WELL_KNOWN_ENDPOINT = f"tcp/127.0.0.1:{WELL_KNOWN_PORT}"


def router_endpoints(
    listen: Sequence[str], well_known_free: bool, spare_port: Callable[[], int], *, link: bool
) -> tuple[list[str], list[str]]:
    """(listen, connect) endpoints of a cell's own router. Unless told where to listen, the
    first cell on a machine takes the well-known port and a later one a spare port. On an
    open bus (``link``) a later cell's router also links to the first, so one observer on the
    well-known port sees every cell; a secured cell's router links to nothing: its access
    control knows only its own cell, and observers find each cell through the registry."""
    if listen:
        return list(listen), []
    if well_known_free:
        return [WELL_KNOWN_ENDPOINT], []
    return [f"tcp/127.0.0.1:{spare_port()}"], [WELL_KNOWN_ENDPOINT] if link else []
