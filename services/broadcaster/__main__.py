"""The state broadcaster: at the state period, one snapshot of the cell for the gateway's state
port and for anyone watching Zenoh. ``core`` decides when and what; this module wires Zenoh."""

from __future__ import annotations

from collections.abc import Sequence

from services.broadcaster.controller_watch import ControllerWatch
from services.broadcaster.core import Broadcaster
from shared.bus.schemas import Decoder, Tick, encode
from shared.bus.session import Inbox, payload_of, publisher
from shared.service import ServiceContext, argument_parser, running_service


def run(ctx: ServiceContext) -> None:
    keys = ctx.keys
    session = ctx.session
    broadcaster = Broadcaster(ctx.cell, ControllerWatch(session, keys))
    state_pub = publisher(session, keys.state, realtime=True, latest=True)
    ticks = Inbox(maxsize=64)
    tick_subscriber = session.declare_subscriber(
        keys.executor_tick, ticks.feed("tick", payload_of(Decoder(Tick)))
    )
    while not ctx.stop.is_set():
        item = ticks.get(timeout=broadcaster.silence_s)
        state = broadcaster.on_silence() if item is None else broadcaster.on_tick(item[1])
        if state is not None:
            state_pub.put(encode(state))
    tick_subscriber.undeclare()


def main(argv: Sequence[str] | None = None) -> None:
    args = argument_parser("broadcaster", "Controller state at the state period.").parse_args(argv)
    with running_service("broadcaster", "0", args) as ctx:
        run(ctx)


if __name__ == "__main__":
    main()
