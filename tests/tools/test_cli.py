"""The ``motocell`` command line: every command parses, and the light ones stay light: a
command loads its own module only, and ``ps``, ``watch``, ``fault``, ``echo`` and ``hz``, which
are mostly imports, none of the heavy libraries (checked in a fresh interpreter, on their way
from the command line and again after a run against a resting cell)."""

from __future__ import annotations

import argparse
import ast
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from motocell.services.launcher import cli as launcher_cli
from motocell.services.launcher.core.endpoints import WELL_KNOWN_ENDPOINT
from motocell.shared import registry
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing.running_cell import RunningCell, running_cell
from motocell.tools import cli
from motocell.tools.cli import build_parser

HEAVY = ("matplotlib", "mcap", "foxglove")
"""The tools extra's libraries: only ``record``, ``view`` and ``plot`` may import them."""
LIGHT = {
    "ps": ["ps"],
    "watch": ["watch", "--count", "1"],
    "fault": ["fault", "hold", "off"],
    "echo": ["echo", "controller/status", "--count", "1"],
    "hz": ["hz", "controller/status", "--count", "1"],
}
"""The commands a person (or a script) runs again and again, each with arguments that end it
by itself; what they cost is nearly all imports (docs/realtime.md, Start-up)."""
NOT_FOR_LIGHT = {
    *HEAVY,
    "numpy",
    "cryptography",
    "motocell.tools.bench",
    "motocell.services.launcher",
    *(f"motocell.tools.{name}" for name, _ in cli.COMMANDS if name not in LIGHT),
}
"""What none of them needs: the tools extra, numpy (the motion code's), cryptography (TLS
credentials), the benchmarks, the launcher, and the other commands' modules."""
CELL_FILE_READER = "motocell.shared.config"
"""Not needed by ``ps`` and ``fault`` either; ``watch``, ``echo`` and ``hz`` load it through
``shared.service`` (their stop flag)."""


def parse(words: list[str]) -> argparse.Namespace:
    """``words`` parsed as ``motocell`` parses them: ``up`` by the launcher's own parser, which
    ``tools.cli.main`` hands it to, every other command by the command's."""
    if words[:1] == ["up"]:
        return launcher_cli.parser().parse_args(words[1:])
    return build_parser().parse_args(words)


def unwanted(command: str) -> set[str]:
    return NOT_FOR_LIGHT | ({CELL_FILE_READER} if command in {"ps", "fault"} else set())


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
        parse([command, "--help"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.startswith(f"usage: motocell {command}")


def help_of(command: str, capsys: pytest.CaptureFixture[str]) -> str:
    with pytest.raises(SystemExit):
        parse([command, "--help"])
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


def loaded_after(
    code: str, modules: set[str], cwd: Path, env: dict[str, str] | None = None
) -> list[str]:
    """Which of ``modules`` (full dotted names: a package is loaded whenever any module of
    it is) a fresh interpreter has loaded after running ``code``, away from the source tree
    (``cwd``), as an installed motocell runs."""
    probe = f"{code}\nimport sys\nprint(sorted(set(sys.modules) & {modules!r}))\n"
    done = subprocess.run(
        [sys.executable, "-c", probe],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr
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
        "from motocell.services.launcher import cli\n"
        "cli.parser().parse_args(['--port-base', '51240'])"
    )
    assert loaded_after(code, {"motocell.tools.bench", "cryptography", "numpy"}, tmp_path) == []


@pytest.mark.cell
@pytest.mark.parametrize("command", sorted(LIGHT))
def test_a_light_command_loads_no_heavy_module(command: str, tmp_path: Path) -> None:
    code = f"from motocell.tools import cli\ncli.build_parser().parse_args({LIGHT[command]!r})"
    assert loaded_after(code, unwanted(command), tmp_path) == []


@pytest.fixture(scope="module")
def resting_cell() -> Iterator[RunningCell]:
    with running_cell(attempts=2) as cell:
        yield cell


@pytest.mark.cell
@pytest.mark.parametrize("command", sorted(LIGHT))
def test_a_light_command_run_on_a_resting_cell_loads_no_heavy_module(
    command: str, resting_cell: RunningCell, tmp_path: Path
) -> None:
    # Run as `motocell` runs it, to its end: what it imports on its way (decoding, joining the
    # bus) counts too.
    argv = [*LIGHT[command], "--cell", resting_cell.cell.name]
    code = (
        "from motocell.tools import cli\n"
        "try:\n"
        f"    cli.main({argv!r})\n"
        "except SystemExit as exc:\n"
        "    assert not exc.code, exc.code\n"
    )
    env = {**os.environ, RUNTIME_DIR_ENV: str(resting_cell.runtime_dir)}
    assert loaded_after(code, unwanted(command), tmp_path, env) == []


def test_a_deferred_command_has_its_options_when_run(capsys: pytest.CaptureFixture[str]) -> None:
    args = build_parser().parse_args(["bench", "--quick", "--only", "9"])
    assert (args.quick, args.only) == (True, "9")
    with pytest.raises(SystemExit):
        build_parser().parse_args(["bench", "--help"])
    assert "--quick" in capsys.readouterr().out


def test_abbreviated_options_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_status:
        parse(["up", "--port-bas", "51240"])
    assert exit_status.value.code == 2
    assert "unrecognized arguments: --port-bas" in capsys.readouterr().err


EVERY_COMMAND = ["up", "fault", "ps", "watch", "echo", "hz", "record", "view", "plot", "bench"]
EVERY_COMMAND += ["credentials", "site", "service", "router", "demo"]


@pytest.mark.parametrize("command", [[], *([c] for c in EVERY_COMMAND)])
def test_version_is_printed_by_every_command(
    command: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_status:
        parse([*command, "--version"])
    assert exit_status.value.code == 0
    assert capsys.readouterr().out.startswith("motocell ")


def test_every_command_is_tested_for_its_version() -> None:
    parser = build_parser()
    subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert sorted(subparsers.choices) == sorted(EVERY_COMMAND)
