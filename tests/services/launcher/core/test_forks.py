"""The launcher's and its zygote's messages: each one line, decoded back as sent; a line that is
not one is a ForkProtocolError; a command line reads as ``/proc/<pid>/cmdline`` would."""

from __future__ import annotations

import pytest

from motocell.services.launcher.core.forks import (
    Forked,
    ForkProtocolError,
    ForkRefused,
    ForkRequest,
    command_line,
    decode_reply,
    decode_request,
    encode,
)


def test_a_request_is_one_line_and_decodes_as_sent() -> None:
    request = ForkRequest("motocell.services.gateway", ("--port-base", "50240"))
    line = encode(request)
    assert line.endswith(b"\n") and line.count(b"\n") == 1
    assert decode_request(line) == request


@pytest.mark.parametrize("reply", [Forked(4242), ForkRefused("too long")])
def test_each_reply_decodes_as_sent(reply: Forked | ForkRefused) -> None:
    assert decode_reply(encode(reply)) == reply


@pytest.mark.parametrize("line", [b"", b"{", b'{"type": "Forked", "pid": 1}\n', b"[1, 2]\n"])
def test_a_line_that_is_no_request_is_a_protocol_error(line: bytes) -> None:
    with pytest.raises(ForkProtocolError, match="not a fork request"):
        decode_request(line)


def test_a_request_is_no_reply() -> None:
    with pytest.raises(ForkProtocolError, match="not a reply"):
        decode_reply(encode(ForkRequest("m", ())))


def test_the_command_line_is_python_m_module_args_each_nul_ended() -> None:
    request = ForkRequest("motocell.services.interpolator", ("--group", "1"))
    assert (
        command_line("/py", request) == b"/py\0-m\0motocell.services.interpolator\0--group\x001\0"
    )
