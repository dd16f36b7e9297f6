"""The ``motocell`` command line: every command parses, and the light ones stay light."""

from __future__ import annotations

import argparse
import ast
import subprocess
import sys
from pathlib import Path

import pytest

from motocell.services.launcher.core import WELL_KNOWN_ENDPOINT
from motocell.shared import registry
from motocell.tools.cli import build_parser

HEAVY = ("matplotlib", "mcap", "foxglove")
"""The tools extra's libraries: only ``record``, ``view`` and ``plot`` may import them."""

COMMANDS = (
    "up",
    "fault",
    "ps",
    "watch",
    "echo",
    "hz",
    "record",
    "view",
    "plot",
    "bench",
    "credentials",
    "router",
    "demo",
    "service",
)


@pytest.mark.parametrize("command", COMMANDS)
def test_every_command_has_help(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        build_parser().parse_args([command, "--help"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.startswith(f"usage: motocell {command}")


def help_of(command: str, capsys: pytest.CaptureFixture[str]) -> str:
    with pytest.raises(SystemExit):
        build_parser().parse_args([command, "--help"])
    return " ".join(capsys.readouterr().out.split())


@pytest.mark.parametrize("command", ["up", "router"])
def test_the_routers_default_endpoint_is_the_one_used(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    text = help_of(command, capsys)
    assert f"default {WELL_KNOWN_ENDPOINT}" in text
    assert "127.0.0.1:0" not in text


@pytest.mark.parametrize("command", ["ps", "watch"])
def test_observers_say_where_they_look_by_default(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    text = help_of(command, capsys)
    assert f"registered it in {registry.runtime_dir()}" in text
    assert WELL_KNOWN_ENDPOINT in text


def loaded_after(code: str, modules: set[str], cwd: Path) -> list[str]:
    """Which of ``modules`` (full dotted names: a package is loaded whenever any module of
    it is) a fresh interpreter has loaded after running ``code``, away from the source tree
    (``cwd``), as an installed motocell runs."""
    probe = f"{code}\nimport sys\nprint(sorted(set(sys.modules) & {modules!r}))\n"
    done = subprocess.run(
        [sys.executable, "-c", probe],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    )
    return list(ast.literal_eval(done.stdout.splitlines()[-1]))


@pytest.mark.cell
def test_help_imports_none_of_the_tools_extra(tmp_path: Path) -> None:
    code = (
        "import contextlib\n"
        "from motocell.tools import cli\n"
        "with contextlib.suppress(SystemExit):\n"
        "    cli.main(['--help'])"
    )
    assert loaded_after(code, set(HEAVY), tmp_path) == []


@pytest.mark.cell
def test_up_imports_neither_numpy_nor_the_benchmarks_nor_cryptography(tmp_path: Path) -> None:
    # `motocell up` parses its arguments before it starts a single service.
    code = (
        "from motocell.tools import cli\n"
        "cli.build_parser().parse_args(['up', '--port-base', '51240'])"
    )
    assert loaded_after(code, {"motocell.bench", "cryptography", "numpy"}, tmp_path) == []


def test_a_deferred_command_has_its_options_when_run(capsys: pytest.CaptureFixture[str]) -> None:
    args = build_parser().parse_args(["bench", "--quick", "--only", "9"])
    assert (args.quick, args.only) == (True, "9")
    with pytest.raises(SystemExit):
        build_parser().parse_args(["bench", "--help"])
    assert "--quick" in capsys.readouterr().out


def test_abbreviated_options_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_status:
        build_parser().parse_args(["up", "--port-bas", "51240"])
    assert exit_status.value.code == 2
    assert "unrecognized arguments: --port-bas" in capsys.readouterr().err


EVERY_COMMAND = ["up", "fault", "ps", "watch", "echo", "hz", "record", "view", "plot", "bench"]
EVERY_COMMAND += ["credentials", "service", "router", "demo"]


@pytest.mark.parametrize("command", [[], *([c] for c in EVERY_COMMAND)])
def test_version_is_printed_by_every_command(
    command: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_status:
        build_parser().parse_args([*command, "--version"])
    assert exit_status.value.code == 0
    assert capsys.readouterr().out.startswith("motocell ")


def test_every_command_is_tested_for_its_version() -> None:
    parser = build_parser()
    subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert sorted(subparsers.choices) == sorted(EVERY_COMMAND)
