"""The gateway: Simple Message over TCP on the motion, state and I/O ports, forwarded over Zenoh."""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Sequence

import zenoh

from services.gateway.cell_view import CellView, decode_state
from services.gateway.io import IoHandler
from services.gateway.metrics import GatewayStats
from services.gateway.motion import Answer, MotionHandler
from services.gateway.tcp import RequestServer, StateServer, listen
from shared.bus.schemas import CommandRequest, State
from shared.bus.schemas import encode as encode_payload
from shared.bus.session import publisher
from shared.protocol.codec import ByteOrder, Role, encode
from shared.protocol.constants import MAX_JOINTS, MsgType, ValidFields
from shared.protocol.errors import PeerProtocolError
from shared.protocol.messages import JointFeedback, JointFeedbackEx, Message, RobotStatus
from shared.protocol.replies import invalid_reply, io_error_reply, state_message
from shared.service import argument_parser, running_service

log = logging.getLogger("gateway")

CONNECTIONS_REFRESH_S = 1.0

FEEDBACK_FIELDS = int(ValidFields.POSITION | ValidFields.VELOCITY)
"""MotoROS 1.9 sends 6 when it can read speed feedback (the 2012 spec's 2 is superseded)."""


def _joints(values: list[float]) -> tuple[float, ...]:
    return (*values, *([0.0] * (MAX_JOINTS - len(values))))


def state_frames(state: State, byte_order: ByteOrder) -> bytes:
    """One state cycle as MotoROS sends it (§6): JOINT_FEEDBACK per group, then
    JOINT_FEEDBACK_EX when there are 2+ groups (always 4 slots), then ROBOT_STATUS."""
    zeros = (0.0,) * MAX_JOINTS
    feedback = [
        JointFeedback(
            g.group_no, FEEDBACK_FIELDS, 0.0, _joints(g.positions), _joints(g.velocities), zeros
        )
        for g in state.groups
    ]
    messages = [state_message(MsgType.JOINT_FEEDBACK, body) for body in feedback]
    if len(feedback) >= 2:
        messages.append(
            state_message(
                MsgType.MOTO_JOINT_FEEDBACK_EX, JointFeedbackEx(len(feedback), tuple(feedback))
            )
        )
    s = state.status
    messages.append(
        state_message(
            MsgType.ROBOT_STATUS,
            RobotStatus(
                s.drives_powered,
                s.e_stopped,
                s.error_code,
                s.in_error,
                s.in_motion,
                s.mode,
                s.motion_possible,
            ),
        )
    )
    return b"".join(encode(m, byte_order, Role.CONTROLLER) for m in messages)


class StateFeed:
    """The newest few state samples, undecoded: decoding waits until a state client is there
    to read them, and after a stall the clients get the latest state, not a backlog."""

    def __init__(self, keep: int = 4) -> None:
        self._samples: deque[bytes] = deque(maxlen=keep)
        self._arrived = threading.Condition()

    def keep(self, sample: zenoh.Sample) -> None:
        with self._arrived:
            self._samples.append(sample.payload.to_bytes())
            self._arrived.notify()

    def take(self, timeout: float) -> list[bytes]:
        with self._arrived:
            if not self._samples:
                self._arrived.wait(timeout)
            samples = list(self._samples)
            self._samples.clear()
        return samples


def _motion_error(error: PeerProtocolError) -> Message:
    return invalid_reply(error)


def _io_error(error: PeerProtocolError) -> Message:
    return io_error_reply(error.subcode)


def main(argv: Sequence[str] | None = None) -> None:
    parser = argument_parser("gateway", "Simple Message TCP servers of one controller.")
    parser.add_argument("--host", help="address to listen on (default: the cell file's)")
    parser.add_argument("--port-base", type=int, help="motion port; state and I/O follow")
    parser.add_argument("--byte-order", choices=("little", "big"))
    args = parser.parse_args(argv)
    with running_service("gateway", "0", args) as ctx:
        cell = ctx.cell
        host = args.host or cell.host
        port_base = args.port_base or cell.port_base
        byte_order = ByteOrder(args.byte_order or cell.byte_order)
        view = CellView(cell, ctx.keys, ctx.session)
        io = IoHandler(view)
        motion = MotionHandler(view, io)

        def io_answer(request: object) -> Answer:
            return Answer(io.handle(request))  # type: ignore[arg-type]

        motion_server = RequestServer(
            name="motion",
            server=listen(host, port_base),
            byte_order=byte_order,
            respond=motion.handle,
            error_reply=_motion_error,
            moving=view.moving,
            on_disconnect=motion.stop_motion,
        )
        io_server = RequestServer(
            name="io",
            server=listen(host, port_base + 2),
            byte_order=byte_order,
            respond=io_answer,
            error_reply=_io_error,
            moving=view.moving,
        )
        state_server = StateServer(listen(host, port_base + 1), view.moving)
        states = StateFeed()
        subscriber = ctx.session.declare_subscriber(ctx.keys.state, states.keep)

        def report_connections() -> None:
            """OT#893-#895 show connected motion, state and I/O clients (spec §4.2)."""
            counts = [
                int(motion_server.connected()),
                state_server.client_count(),
                int(io_server.connected()),
            ]
            ctx.session.put(
                ctx.keys.controller_cmd("connections"), encode_payload(CommandRequest(args=counts))
            )

        motion_server.on_change = io_server.on_change = report_connections
        stats = GatewayStats(len(cell.groups))
        motion_server.observe = io_server.observe = stats.observe
        metrics_pub = publisher(ctx.session, ctx.keys.metrics("gateway"), latest=True)
        for server in (motion_server, io_server, state_server):
            server.start()
        log.info("listening on %s:%d-%d (%s-endian)", host, port_base, port_base + 2, byte_order)

        def fan_out() -> None:
            next_report = 0.0
            while not ctx.stop.is_set():
                for payload in states.take(timeout=0.2):
                    if state_server.client_count():
                        state_server.broadcast(state_frames(decode_state(payload), byte_order))
                if time.monotonic() >= next_report:
                    # Also now and then: state clients leave silently, controllers restart.
                    report_connections()
                    metrics_pub.put(
                        encode_payload(
                            stats.snapshot(
                                int(motion_server.connected()),
                                state_server.client_count(),
                                int(io_server.connected()),
                            )
                        )
                    )
                    next_report = time.monotonic() + CONNECTIONS_REFRESH_S

        fan_out_thread = threading.Thread(target=fan_out, name="state-fan-out", daemon=True)
        fan_out_thread.start()
        ctx.stop.wait()
        subscriber.undeclare()
        for server in (motion_server, io_server, state_server):
            server.close()
        fan_out_thread.join(timeout=1.0)


if __name__ == "__main__":
    main()
