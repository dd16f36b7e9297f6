"""``motocell fault``'s command line: what it accepts, what it refuses in one line, and how it
echoes the fault it injects (no cell needed: nothing is sent when a check fails)."""

from __future__ import annotations

import argparse

import pytest

from motocell.shared.bus.schemas import CommandRequest
from motocell.shared.faults import request_for
from motocell.tools import fault
from motocell.tools.fault import echo


def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    fault.add_arguments(parser)
    return parser.parse_args(argv)


@pytest.mark.parametrize(
    ("argv", "request_"),
    [
        (("hold", "ON"), CommandRequest(value=1)),
        (("HOLD", "Off"), CommandRequest(value=0)),
        (("play", "TEACH"), CommandRequest(value=0)),
        (("alarm", "4100", "2"), CommandRequest(value=1, args=[4100, 2])),
        (("alarm", "4100"), CommandRequest(value=1, args=[4100, 0])),
        (("alarm", "CLEAR"), CommandRequest(value=0)),
        (("error", "2010"), CommandRequest(value=1, args=[2010, 0])),
    ],
)
def test_settings_in_any_case(argv: tuple[str, ...], request_: CommandRequest) -> None:
    args = parse(*argv)
    assert request_for(args.kind, args.setting, args.subcode) == request_


@pytest.mark.parametrize(
    ("argv", "echoed"),
    [(("alarm", "4100", "2"), "alarm 4100 2"), (("hold", "ON"), "hold on")],
)
def test_the_echo_names_the_whole_fault(argv: tuple[str, ...], echoed: str) -> None:
    assert echo(parse(*argv)) == echoed


@pytest.mark.parametrize(
    ("argv", "problem"),
    [
        (("error", "-5"), "error: code -5 is not 1 to 9999"),
        (("alarm", "0"), "alarm: code 0 is not 1 to 9999"),
        (("alarm", "10000"), "alarm: code 10000 is not 1 to 9999"),
        (("alarm", "4100", "-2"), "alarm: subcode -2 is not 0 to 9999"),
        (("alarm", "4100", "10000"), "alarm: subcode 10000 is not 0 to 9999"),
        (("alarm", "clear", "2"), "alarm clear: takes no subcode (got 2)"),
        (("error", "2010", "1"), "error 2010: takes no subcode (got 1)"),
        (("hold", "on", "1"), "hold on: takes no subcode (got 1)"),
        (("hold", "maybe"), "hold: expected on or off, got 'maybe'"),
        (("error", "lots"), "error: expected a code or 'clear', got 'lots'"),
    ],
)
def test_a_bad_fault_is_refused_in_one_line_before_joining_anything(
    argv: tuple[str, ...], problem: str, capsys: pytest.CaptureFixture[str]
) -> None:
    args = parse(*argv)
    assert args.run(args) == 2
    assert capsys.readouterr().err == f"motocell fault: {problem}\n"
