"""The ROS 2 face's way into the cell's one motion API: its requests on ``gateway/cmd/motion``,
each one Simple Message frame, answered by a motion handler of its own (``Source.ROS2``) as the
motion port's client's are by the TCP server (docs/ros2.md, One motion source).

Zenoh's threads only queue a query; the face's thread of the gateway answers them one at a
time, in order, as a connection's thread does: decode, decide, reply, then publish what was
accepted (``Response.then``). M-register requests go to the I/O port's handler (the motion
port has none; MotoROS2 serves them). When the face's process goes (its liveliness token), its
motion stops and it gives trajectory mode up, as when the motion port's client disconnects
(MotoROS2's ``stop_motion_on_disconnect``).
"""

from __future__ import annotations

import logging
import queue
import threading
from dataclasses import dataclass

import msgspec

from motocell.services.gateway.bus import Answer, Bus
from motocell.services.gateway.core.motion import M_REGISTER_TYPES, MotionHandler
from motocell.services.gateway.core.response import Response
from motocell.services.gateway.core.robot_io import RobotIoHandler
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import Decoder, MotionRequest, MotionResponse, encode
from motocell.shared.protocol.codec import ByteOrder, Role, decode_frames
from motocell.shared.protocol.codec import encode as encode_frame
from motocell.shared.protocol.constants import InvalidSubcode
from motocell.shared.protocol.errors import PeerProtocolError
from motocell.shared.protocol.messages import Message, UnknownMessage
from motocell.shared.service_names import ROS2_FACE

log = logging.getLogger("gateway")

INBOX_SIZE = 16
"""Queries waiting for the face's thread. The face asks one at a time; more are a peer gone
wrong, answered at once with an empty frame rather than queued without bound."""

_request_decoder = Decoder(MotionRequest)


@dataclass(frozen=True)
class _Query:
    payload: bytes
    answer: Answer


class _FaceGone:
    """The face's liveliness token went."""


class _Stop:
    pass


class FacePort:
    def __init__(
        self,
        bus: Bus,
        keys: CellKeys,
        byte_order: ByteOrder,
        motion: MotionHandler,
        io: RobotIoHandler,
    ) -> None:
        self._byte_order = byte_order
        self._motion = motion
        self._io = io
        self._inbox: queue.Queue[_Query | _FaceGone | _Stop] = queue.Queue(INBOX_SIZE)
        self._face_key = keys.alive(ROS2_FACE, "0")
        self._face_present = False
        self._tokens = bus.tokens(self._face_key, self._tokens_changed)
        self._queries = bus.answer(keys.gateway_cmd("motion"), self._offer)
        self._thread = threading.Thread(target=self._serve, name="gateway-face", daemon=True)

    def start(self) -> None:
        self._thread.start()
        self._tokens.ask()

    def close(self) -> None:
        self._queries.undeclare()
        self._tokens.close()
        self._inbox.put(_Stop())
        self._thread.join()

    # -- Zenoh's threads: queue, nothing else ------------------------------------------------
    def _offer(self, payload: bytes, answer: Answer) -> None:
        try:
            self._inbox.put_nowait(_Query(payload, answer))
        except queue.Full:
            log.warning("ROS 2 face: more than %d requests waiting; one refused", INBOX_SIZE)
            answer(encode(MotionResponse(b"")))

    def _tokens_changed(self) -> None:
        present = self._face_key in self._tokens.present()
        if self._face_present and not present:
            self._inbox.put(_FaceGone())
        self._face_present = present

    # -- the face's thread ---------------------------------------------------------------------
    def _serve(self) -> None:
        while True:
            item = self._inbox.get()
            match item:
                case _Stop():
                    return
                case _FaceGone():
                    log.info("the ROS 2 face is gone: its motion, if any, stops")
                    self._motion.disconnected()
                case _Query():
                    self._answer(item)

    def _answer(self, query: _Query) -> None:
        response = self._respond(query.payload)
        reply = response.reply
        try:
            frame = b"" if reply is None else encode_frame(reply, self._byte_order, Role.CONTROLLER)
            query.answer(encode(MotionResponse(frame)))
        finally:
            # As on the motion port: a point counted as pending must reach its interpolator.
            if response.then is not None:
                response.then()

    def _respond(self, payload: bytes) -> Response:
        try:
            request = self._request(payload)
        except PeerProtocolError as refused:
            return Response(self._motion.error_reply(refused))
        if request.msg_type in M_REGISTER_TYPES:
            return self._io.respond(request)
        return self._motion.respond(request)

    def _request(self, payload: bytes) -> Message | UnknownMessage:
        """The one frame a query carries; PeerProtocolError for anything else."""
        try:
            frame = _request_decoder.decode(payload).frame
        except msgspec.DecodeError:
            raise PeerProtocolError("not a MotionRequest", InvalidSubcode.MSGSIZE) from None
        frames = decode_frames(frame, Role.CONTROLLER, self._byte_order)
        if len(frames) != 1:
            raise PeerProtocolError(f"{len(frames)} frames, not one", InvalidSubcode.MSGSIZE)
        return frames[0]
