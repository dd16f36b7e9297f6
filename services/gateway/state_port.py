"""Port 50241, the whole outbound state path: the broadcaster's ``state`` samples in, MotoROS's
state messages out to every state client (motoros1 §6).

Samples are kept undecoded (``StateFeed``) until a state client is there to read them;
``state_frames`` builds one cycle's frames, encoded once for all clients; ``StateServer`` hands
the bytes to each client's bounded queue; ``StatePort`` runs the fan-out between them.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import threading
from collections import deque
from collections.abc import Callable

import zenoh

from services.gateway.tcp import configure
from shared.bus.keys import CellKeys
from shared.bus.schemas import Decoder, State
from shared.protocol.codec import ByteOrder, Role, encode
from shared.protocol.constants import MAX_JOINTS, MsgType, ValidFields
from shared.protocol.messages import JointFeedback, JointFeedbackEx, RobotStatus
from shared.protocol.replies import state_message

log = logging.getLogger("gateway")

STATE_BACKLOG_FRAMES = 64
"""Frames buffered per state client; a slower client loses the oldest, never stalls others."""
FEED_WAIT_S = 0.2
"""How long the fan-out waits for a sample before it looks whether it should stop."""
FEEDBACK_FIELDS = int(ValidFields.POSITION | ValidFields.VELOCITY)
"""MotoROS 1.9 sends 6 when it can read speed feedback (the 2012 spec's 2 is superseded)."""

_state_decoder = Decoder(State)


def decode_state(payload: bytes) -> State:
    return _state_decoder.decode(payload)


def _joints(values: list[float]) -> tuple[float, ...]:
    return (*values, *([0.0] * (MAX_JOINTS - len(values))))


def state_frames(state: State, byte_order: ByteOrder) -> bytes:
    """One state cycle as MotoROS sends it (motoros1 §6): JOINT_FEEDBACK per group, then
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


class StateClient:
    def __init__(self, sock: socket.socket, peer: tuple[str, int]) -> None:
        self.sock = sock
        self.peer = peer
        self.frames: deque[bytes] = deque(maxlen=STATE_BACKLOG_FRAMES)
        self.ready = threading.Condition()
        self.closed = False
        self.thread = threading.Thread(target=self._write_loop, name="state-client", daemon=True)
        self.thread.start()

    def push(self, data: bytes) -> None:
        with self.ready:
            self.frames.append(data)
            self.ready.notify()

    def _write_loop(self) -> None:
        while True:
            with self.ready:
                while not self.frames and not self.closed:
                    self.ready.wait()
                if self.closed:
                    return
                data = b"".join(self.frames)
                self.frames.clear()
            try:
                self.sock.sendall(data)
            except OSError:
                self.close()
                return

    def close(self) -> None:
        with self.ready:
            self.closed = True
            self.ready.notify()
        with contextlib.suppress(OSError):
            self.sock.shutdown(socket.SHUT_RDWR)
        self.sock.close()


class StateServer:
    """Port 50241: up to 4 clients (motoros1 §6). A 5th is refused while the robot moves,
    otherwise it takes slot 0. The server never reads; a client goes when a send fails."""

    MAX_CLIENTS = 4

    def __init__(self, server: socket.socket, moving: Callable[[], bool]) -> None:
        self.server = server
        self.moving = moving
        self.clients: list[StateClient] = []
        self.lock = threading.Lock()
        self.thread = threading.Thread(target=self._accept_loop, name="state-accept", daemon=True)

    def start(self) -> None:
        self.thread.start()

    def _accept_loop(self) -> None:
        while True:
            try:
                sock, peer = self.server.accept()
            except OSError:
                return
            configure(sock)
            with self.lock:
                self.clients = [c for c in self.clients if not c.closed]
                if len(self.clients) >= self.MAX_CLIENTS:
                    if self.moving():
                        log.warning("state: refused %s:%d, 4 clients and the robot moves", *peer)
                        sock.close()
                        continue
                    self.clients.pop(0).close()
                self.clients.append(StateClient(sock, peer))
            log.info("state: client %s:%d connected", *peer)

    def broadcast(self, data: bytes) -> None:
        with self.lock:
            clients = list(self.clients)
        for client in clients:
            if not client.closed:
                client.push(data)

    def client_count(self) -> int:
        with self.lock:
            return sum(not c.closed for c in self.clients)

    def close(self) -> None:
        self.server.close()
        with self.lock:
            for client in self.clients:
                client.close()


class StatePort:
    """The fan-out: every state sample that arrives while a state client is connected is
    framed once and queued for each client."""

    def __init__(
        self,
        session: zenoh.Session,
        keys: CellKeys,
        server: socket.socket,
        byte_order: ByteOrder,
        moving: Callable[[], bool],
    ) -> None:
        self.clients = StateServer(server, moving)
        self.byte_order = byte_order
        self._feed = StateFeed()
        self._stop = threading.Event()
        self._subscriber = session.declare_subscriber(keys.state, self._feed.keep)
        self._thread = threading.Thread(target=self._fan_out, name="state-fan-out", daemon=True)

    def start(self) -> None:
        self.clients.start()
        self._thread.start()

    def client_count(self) -> int:
        return self.clients.client_count()

    def _fan_out(self) -> None:
        while not self._stop.is_set():
            for payload in self._feed.take(timeout=FEED_WAIT_S):
                if self.clients.client_count():
                    self.clients.broadcast(state_frames(decode_state(payload), self.byte_order))

    def close(self) -> None:
        self._subscriber.undeclare()
        self._stop.set()
        self.clients.close()
        self._thread.join(timeout=1.0)
