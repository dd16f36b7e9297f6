"""The cell's one motion API as the face reaches it: one Simple Message request at a time on
``gateway/cmd/motion`` (docs/ros2.md, One motion source), answered by the gateway's motion
handler of the face."""

from __future__ import annotations

import logging

import msgspec

from motocell.services.ros2.bus import Bus
from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import Decoder, MotionRequest, MotionResponse, encode
from motocell.shared.protocol.codec import ByteOrder, Role, decode_frames
from motocell.shared.protocol.codec import encode as encode_frame
from motocell.shared.protocol.errors import PeerProtocolError
from motocell.shared.protocol.messages import Message

log = logging.getLogger("ros2")

ASK_TIMEOUT_S = 10.0
"""The gateway answers START_TRAJ_MODE within its own 6 s bound on the controller."""

_response_decoder = Decoder(MotionResponse)


class MotionApi:
    def __init__(self, bus: Bus, keys: CellKeys, byte_order: ByteOrder) -> None:
        self._bus = bus
        self._key = keys.gateway_cmd("motion")
        self._byte_order = byte_order

    def request(self, message: Message) -> Message | None:
        """The gateway's reply; None when it did not answer, or answered nothing readable."""
        frame = encode_frame(message, self._byte_order, Role.CLIENT)
        answer = self._bus.ask(self._key, encode(MotionRequest(frame)), ASK_TIMEOUT_S)
        if answer is None:
            return None
        try:
            frames = decode_frames(
                _response_decoder.decode(answer).frame, Role.CLIENT, self._byte_order
            )
        except (msgspec.DecodeError, PeerProtocolError) as error:
            log.warning("an unreadable answer from the gateway: %s", error)
            return None
        return next((reply for reply in frames if isinstance(reply, Message)), None)
