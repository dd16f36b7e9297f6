"""Free ports: picked below the kernel's ephemeral range, so no outgoing connection takes one
between the pick and the bind."""

from __future__ import annotations

import argparse
import socket
from pathlib import Path

import pytest

from motocell.shared import ports
from motocell.shared.ports import free_port, free_port_block, port_free


def ephemeral_low() -> int:
    return int(ports.EPHEMERAL_RANGE.read_text().split()[0])


def test_a_block_lies_below_the_ephemeral_range_and_is_free() -> None:
    for _ in range(50):
        base = free_port_block(3)
        assert base + 2 < ephemeral_low()
        assert all(port_free(base + i) for i in range(3))


def test_a_port_picked_besides_others_is_none_of_them(monkeypatch: pytest.MonkeyPatch) -> None:
    picks = iter([30001, 30002, 30000, 30004])
    monkeypatch.setattr(ports, "free_port", lambda host="127.0.0.1": next(picks))
    assert ports.free_port_besides(range(30000, 30003)) == 30004


def test_a_taken_port_is_not_free() -> None:
    port = free_port()
    with socket.socket() as holder:
        holder.bind(("127.0.0.1", port))
        holder.listen()
        assert not port_free(port)


def test_without_room_below_the_range_the_kernel_chooses(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    whole = tmp_path / "ip_local_port_range"
    whole.write_text("1024\t65000\n")
    monkeypatch.setattr(ports, "EPHEMERAL_RANGE", whole)
    base = free_port_block(3)
    assert all(port_free(base + i) for i in range(3))


def test_an_unreadable_range_means_linux_default(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(ports, "EPHEMERAL_RANGE", tmp_path / "missing")
    assert free_port() < 32768


@pytest.mark.parametrize("text", ["1", "50240", "65533"])
def test_a_service_takes_a_port_base_whose_three_ports_exist(text: str) -> None:
    assert ports.port_base_argument(text) == int(text)


@pytest.mark.parametrize("text", ["0", "-5", "65534", "many"])
def test_a_service_refuses_a_port_base_0_rather_than_meaning_the_default(text: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError):
        ports.port_base_argument(text)
