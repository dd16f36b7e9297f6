"""A Foxglove WebSocket client for the tests, written from the protocol's specification
(foxglove/ws-protocol, docs/spec.md) rather than from the server's code, so that it checks
what ``motocell view`` serves as Foxglove would read it.

The protocol: the client offers the subprotocol ``foxglove.sdk.v1``; the server sends JSON text
frames (``serverInfo``, then ``advertise`` with the channels: id, topic, encoding, schemaName,
schema, schemaEncoding); the client sends ``subscribe`` with its own subscription ids; each
message then comes as a binary frame: opcode 0x01, the subscription id (uint32 LE), the log
time (uint64 LE, ns) and the message bytes in the channel's encoding. JSON channels carry JSON;
protobuf channels carry a message whose schema is a base64 ``FileDescriptorSet``.
"""

from __future__ import annotations

import base64
import contextlib
import functools
import json
import socket
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any
from urllib.parse import urlsplit

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.message import Message
from websockets.sync.client import ClientConnection, connect

SUBPROTOCOL = "foxglove.sdk.v1"
MESSAGE_DATA = 0x01
ETHERNET_MSS = 1460
HEADER = struct.Struct("<BIQ")
"""Opcode, subscription id, log time."""


@dataclass(frozen=True)
class Channel:
    id: int
    topic: str
    encoding: str
    schema_name: str
    schema: str
    schema_encoding: str


def _socket_to(url: str, receive_buffer: int) -> socket.socket:
    """A TCP connection to ``url``'s host and port whose receive buffer was set before the
    handshake (the window it advertises is fixed then)."""
    address = urlsplit(url)
    assert address.hostname is not None and address.port is not None, url
    connection = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        connection.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, receive_buffer)
        # Ethernet's segment size: on loopback it is 64 kB, and the kernel sizes the server's
        # send buffer from it, to megabytes.
        connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_MAXSEG, ETHERNET_MSS)
        connection.connect((address.hostname, address.port))
    except OSError:
        connection.close()
        raise
    return connection


@dataclass(frozen=True)
class Received:
    topic: str
    log_time_ns: int
    payload: bytes
    channel: Channel
    received_ns: int
    """CLOCK_MONOTONIC when the frame was read."""

    def json(self) -> Any:
        return json.loads(self.payload)

    def protobuf(self) -> Message:
        descriptors = base64.b64decode(self.channel.schema)
        return protobuf_class(self.channel.schema_name, descriptors).FromString(self.payload)


@functools.cache
def protobuf_class(name: str, descriptors: bytes) -> type[Message]:
    """The message class of ``name`` from a FileDescriptorSet: an MCAP schema's data, or the
    base64-decoded schema a WebSocket server advertises."""
    files = descriptor_pb2.FileDescriptorSet.FromString(descriptors)
    pool = descriptor_pool.DescriptorPool()
    for file in files.file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(name))


class FoxgloveClient:
    """One connection to a Foxglove WebSocket server."""

    def __init__(
        self,
        url: str,
        timeout: float = 10.0,
        max_queue: int | None = None,
        receive_buffer: int | None = None,
    ) -> None:
        """``max_queue``: how many received messages websockets holds before it stops reading
        the socket (its default, 16, when None); ``receive_buffer``: the socket's receive
        buffer in bytes (the kernel's default, which grows to megabytes, when None)."""
        self._stack = contextlib.ExitStack()
        self.connection: ClientConnection = self._stack.enter_context(
            connect(
                url,
                sock=None if receive_buffer is None else _socket_to(url, receive_buffer),
                subprotocols=[SUBPROTOCOL],  # type: ignore[list-item]
                open_timeout=timeout,
                max_queue=16 if max_queue is None else max_queue,
            )
        )
        self.server_info: dict[str, Any] = {}
        self.channels: dict[int, Channel] = {}
        self._subscriptions: dict[int, Channel] = {}

    def read(self, timeout: float) -> Received | dict[str, Any] | None:
        """The next frame: a message, a JSON operation (after taking what it says), or None
        when nothing came within ``timeout`` seconds."""
        try:
            frame = self.connection.recv(timeout=timeout)
        except TimeoutError:
            return None
        if isinstance(frame, str):
            operation: dict[str, Any] = json.loads(frame)
            self._take(operation)
            return operation
        opcode, subscription, log_time = HEADER.unpack_from(frame)
        assert opcode == MESSAGE_DATA, f"unexpected binary opcode {opcode}"
        channel = self._subscriptions[subscription]
        return Received(
            channel.topic, log_time, bytes(frame[HEADER.size :]), channel, time.monotonic_ns()
        )

    def _take(self, operation: dict[str, Any]) -> None:
        if operation["op"] == "serverInfo":
            self.server_info = operation
        elif operation["op"] == "advertise":
            for raw in operation["channels"]:
                channel = Channel(
                    raw["id"],
                    raw["topic"],
                    raw["encoding"],
                    raw["schemaName"],
                    raw["schema"],
                    raw.get("schemaEncoding", ""),
                )
                self.channels[channel.id] = channel
        elif operation["op"] == "unadvertise":
            for channel_id in operation["channelIds"]:
                self.channels.pop(channel_id, None)

    def wait_for_topics(self, topics: set[str], timeout: float) -> dict[str, Channel]:
        """Until every topic in ``topics`` is advertised; TimeoutError naming those missing."""
        deadline = time.monotonic() + timeout
        while True:
            advertised = {channel.topic: channel for channel in self.channels.values()}
            if topics <= advertised.keys():
                return advertised
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise TimeoutError(f"not advertised: {sorted(topics - advertised.keys())}")
            self.read(remaining)

    def subscribe(self, channels: list[Channel]) -> None:
        first = max(self._subscriptions, default=0) + 1
        wanted = {first + n: channel for n, channel in enumerate(channels)}
        self._subscriptions.update(wanted)
        subscriptions = [{"id": sid, "channelId": c.id} for sid, c in wanted.items()]
        self.connection.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))

    def messages_until(
        self, enough: Callable[[list[Received]], bool], timeout: float, what: str
    ) -> list[Received]:
        """Every message until those so far are ``enough``; TimeoutError naming ``what`` if they
        are not within ``timeout`` s."""
        found: list[Received] = []
        deadline = time.monotonic() + timeout
        while not enough(found):
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise TimeoutError(f"{what}: {len(found)} messages in {timeout} s")
            frame = self.read(remaining)
            if isinstance(frame, Received):
                found.append(frame)
        return found

    def next_message(self, topic: str, timeout: float) -> Received:
        deadline = time.monotonic() + timeout
        while (remaining := deadline - time.monotonic()) > 0:
            frame = self.read(remaining)
            if isinstance(frame, Received) and frame.topic == topic:
                return frame
        raise TimeoutError(f"no message on {topic} within {timeout} s")

    def close(self) -> None:
        self._stack.close()

    def __enter__(self) -> FoxgloveClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
