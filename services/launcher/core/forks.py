"""What the launcher and its warm parent (``launcher.zygote``) say over their socket: the
launcher asks for a service, the zygote answers with the process it forked or why it did not.
Each message is one line of JSON. Pure: bytes in, messages out."""

from __future__ import annotations

from collections.abc import Sequence

import msgspec


class ForkRequest(msgspec.Struct, frozen=True, tag=True):
    """Start ``python -m module *args`` as a fork of the warm parent."""

    module: str
    args: tuple[str, ...]


class Forked(msgspec.Struct, frozen=True, tag=True):
    pid: int
    """The service's process, already the launcher's child (its subreaper's)."""


class ForkRefused(msgspec.Struct, frozen=True, tag=True):
    """Not forked; the launcher starts it as a process of its own instead."""

    reason: str


Reply = Forked | ForkRefused


class ForkProtocolError(Exception):
    """A line that is not the message it should be."""


_requests = msgspec.json.Decoder(ForkRequest)
_replies = msgspec.json.Decoder(Reply)


def encode(message: ForkRequest | Forked | ForkRefused) -> bytes:
    return msgspec.json.encode(message) + b"\n"


def decode_request(line: bytes) -> ForkRequest:
    try:
        return _requests.decode(line)
    except msgspec.DecodeError as exc:
        raise ForkProtocolError(f"not a fork request: {exc}") from exc


def decode_reply(line: bytes) -> Reply:
    try:
        return _replies.decode(line)
    except msgspec.DecodeError as exc:
        raise ForkProtocolError(f"not a reply to a fork request: {exc}") from exc


def command_line(python: str, request: ForkRequest) -> bytes:
    """What ``/proc/<pid>/cmdline`` of a service started with ``python -m`` holds: its words,
    each ended by a NUL."""
    return nul_ended((python, "-m", request.module, *request.args))


def nul_ended(words: Sequence[str]) -> bytes:
    """``words`` as ``/proc/<pid>/cmdline`` holds them: each ended by a NUL."""
    return b"".join(word.encode() + b"\0" for word in words)
