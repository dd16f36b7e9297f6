"""No key the gateway's identity may write crashes a service (docs/security.md).

A session with the gateway's own credentials puts and asks, on every key that identity may
write, what no gateway would send: a ``*`` where a group goes, a group the cell lacks, bytes
that are no msgpack, another key's payload, a point of the wrong shape. The router refuses
some (a wildcard or foreign group chunk); the services ignore and count the rest. The cell
stays whole: every service keeps its process, it stays motion-ready, and a trajectory runs.
"""

from __future__ import annotations

import pytest
import zenoh

from motocell.shared.bus.catalog import Role
from motocell.shared.bus.schemas import CommandRequest, Point, Slot, encode
from motocell.shared.bus.session import open_session
from motocell.shared.protocol.constants import Command, Result
from motocell.testing.client import MotionClient, StateListener
from motocell.testing.running_cell import RunningCell, TickLog
from tests.e2e.test_bus_security import assert_untouched, credentials_of, still_moves

pytestmark = pytest.mark.cell

GARBAGE = b"\xc1\xff\x00 no msgpack"
QUERY_S = 0.5


def forged_puts(cell: RunningCell) -> list[tuple[str, bytes]]:
    """(key, payload): every put key the gateway may use, and the group chunks it may not."""
    keys = cell.keys
    wrong_shape = encode(Point(10**6, 1, 0.5, [0.1] * 3, [0.0] * 3))
    nan_time = encode(Point(10**6, 1, float("nan"), [0.0] * 6, [0.0] * 6))
    point = encode(Point(10**6, 0, 0.0, [0.0] * 6, [0.0] * 6))
    puts = [
        (f"{keys.prefix}/group/{chunk}/point", payload)
        for chunk in ("*", "1", "01", "-1", "99999999999999999999")
        for payload in (point, GARBAGE)
    ]
    for key in (keys.group_point(0), keys.controller_cmd("connections"), keys.metrics("gateway")):
        puts += [(key, GARBAGE), (key, encode(Slot(1, 2))), (key, b"\x90")]
    puts += [(keys.group_point(0), wrong_shape), (keys.group_point(0), nan_time)]
    return puts


def forged_queries(cell: RunningCell) -> list[tuple[str, bytes]]:
    """(key, payload): the queries the gateway may ask, with payloads no gateway sends."""
    keys = cell.keys
    queries = [(keys.controller_cmd("*"), GARBAGE), (keys.executor_cmd("stop"), GARBAGE)]
    queries += [(f"{keys.prefix}/group/{chunk}/slot", GARBAGE) for chunk in ("*", "0", "1")]
    queries.append((keys.controller_cmd("select_tool"), encode(CommandRequest(value=99))))
    # A well-formed request on a wildcard reaches every verb's queryable at once.
    queries += [(keys.controller_cmd("*"), encode(CommandRequest(value=value))) for value in (0, 1)]
    return queries


def test_the_gateways_identity_cannot_crash_a_service_with_any_key_or_payload(
    cell: RunningCell,
    motion: MotionClient,
    state: StateListener,
    ticks: TickLog,
    bus: zenoh.Session,
) -> None:
    assert motion.command(Command.START_TRAJ_MODE).result == Result.SUCCESS
    state.wait_still()
    before = cell.children()
    forger = open_session(
        "client", [cell.zenoh_endpoint], wait=False, credentials=credentials_of(cell, Role.GATEWAY)
    )
    try:
        mark = len(ticks)
        for _ in range(3):
            for key, payload in forged_puts(cell):
                forger.put(key, payload)
            for key, payload in forged_queries(cell):
                list(forger.get(key, payload=payload, timeout=QUERY_S))
        assert_untouched(cell, ticks, bus, mark)
    finally:
        forger.close()
    assert cell.children() == before, "a service was restarted"
    still_moves(motion, state)
    assert cell.children() == before, "a service was restarted"
