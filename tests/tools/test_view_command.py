"""``motocell view``'s refusals before it joins any cell: one line on stderr and status 2, as
``motocell up`` gives for a port it cannot have."""

from __future__ import annotations

import socket

import pytest

from motocell.tools import cli


def refused(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    with pytest.raises(SystemExit) as exit_status:
        cli.main(argv)
    assert exit_status.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1, lines
    return lines[0]


def test_a_taken_port(capsys: pytest.CaptureFixture[str]) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        line = refused(["view", "--port", str(port)], capsys)
    assert line == (
        f"motocell view: cannot serve Foxglove on 127.0.0.1:{port}: it is taken by another "
        "process (stop that process, or choose --port N; 0 takes any free port)"
    )


@pytest.mark.parametrize("port", ["65536", "-1"])
def test_a_port_out_of_range(port: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert "a port is a number from 1 to 65535" in refused(["view", "--port", port], capsys)


def test_a_duration_not_positive(capsys: pytest.CaptureFixture[str]) -> None:
    line = refused(["view", "--port", "0", "--duration", "0"], capsys)
    assert line == "motocell view: --duration must be positive"


@pytest.mark.parametrize("rate", ["0", "-5", "nan", "inf"])
def test_a_rate_not_above_0(rate: str, capsys: pytest.CaptureFixture[str]) -> None:
    line = refused(["view", "--port", "0", "--rate", rate], capsys)
    assert line == "motocell view: --rate must be a number of Hz above 0"
