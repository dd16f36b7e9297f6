"""Zenoh's errors as a user reads them: what to do about a taken port or a mistyped endpoint,
and never a path into Zenoh's Rust sources (``at /root/.cargo/.../orchestrator.rs:447``).
Real Zenoh errors, from real sessions and routers on loopback."""

from __future__ import annotations

import socket
from collections.abc import Iterator

import pytest
import zenoh

from motocell.shared.bus.router import router_settings, zenoh_config
from motocell.shared.bus.session import open_session, zenoh_problem, zenoh_reason
from motocell.shared.ports import free_port


@pytest.fixture
def taken_port() -> Iterator[int]:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        yield taken.getsockname()[1]


def router_error(*listen: str) -> zenoh.ZError:
    with pytest.raises(zenoh.ZError) as raised:
        zenoh.open(zenoh_config(router_settings(listen))).close()
    return raised.value


def test_zenohs_own_message_carries_rust_source_paths(taken_port: int) -> None:
    """Why the translation exists: this is what Zenoh 1.x says."""
    assert ".rs:" in str(router_error(f"tcp/127.0.0.1:{taken_port}"))


def test_a_taken_listening_port_is_said_plainly(taken_port: int) -> None:
    assert zenoh_problem(router_error(f"tcp/127.0.0.1:{taken_port}")) == (
        "the port is taken by another process"
    )


@pytest.mark.parametrize(
    ("endpoint", "said"),
    [
        ("127.0.0.1:7447", "127.0.0.1:7447 is not a Zenoh endpoint: write tcp/HOST:PORT"),
        ("tcp/127.0.0.1:99999", "a port is a number from 1 to 65535"),
        ("tcp/127.0.0.1", "write an endpoint as tcp/HOST:PORT"),
        ("udx/127.0.0.1:7447", "Zenoh has no protocol udx"),
        ("tcp/192.0.2.1:7447", "that address is not one of this machine's"),
    ],
)
def test_a_mistyped_listening_endpoint_says_what_to_write(endpoint: str, said: str) -> None:
    problem = zenoh_problem(router_error(endpoint))
    assert said in problem
    assert ".rs" not in problem


def test_an_error_without_advice_keeps_zenohs_words_without_its_source_paths() -> None:
    with pytest.raises(zenoh.ZError) as raised:
        zenoh.Config.from_file("/nonexistent/router.json5")
    assert zenoh_reason(raised.value) == "No such file or directory (os error 2)"
    assert zenoh_problem(raised.value) == zenoh_reason(raised.value)


def test_a_session_to_a_mistyped_endpoint_is_refused_at_once_with_what_to_write() -> None:
    with pytest.raises(ConnectionError, match=r"^127\.0\.0\.1:7447 is not a Zenoh endpoint"):
        open_session("client", ["127.0.0.1:7447"])


def test_a_session_where_no_router_listens_says_so_without_source_paths() -> None:
    with pytest.raises(ConnectionError) as raised:
        open_session("client", [f"tcp/127.0.0.1:{free_port()}"], wait=False)
    assert "no Zenoh router answers" in str(raised.value)
    assert ".rs" not in str(raised.value)
