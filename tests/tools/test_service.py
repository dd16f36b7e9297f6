"""``motocell service NAME``: a cell's service by hand, by the names logs and ``--skip`` use;
its arguments are checked before it joins Zenoh."""

from __future__ import annotations

import subprocess
import sys

import pytest

import motocell.tools.__main__ as entry
from motocell.shared.config import EXIT_CONFIG
from motocell.shared.ports import free_port
from motocell.shared.service_names import UnknownServiceError
from motocell.tools import cli
from motocell.tools.service import service_command

PYTHON = sys.executable
NOWHERE = f"tcp/127.0.0.1:{free_port()}"
"""No router there: a service that got as far as joining Zenoh would say so."""


def motocell(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [PYTHON, "-m", "tools", *args], capture_output=True, text=True, timeout=60, check=False
    )


@pytest.mark.parametrize("name", ["gateway", "gateway/0"])
def test_a_service_runs_as_its_module_with_this_interpreter(name: str) -> None:
    assert service_command(name, ["--config", "c.toml"]) == [
        *(PYTHON, "-m", "motocell.services.gateway", "--config", "c.toml")
    ]


def test_an_interpolator_named_by_its_group_gets_the_group() -> None:
    assert service_command("interpolator/2", []) == [
        *(PYTHON, "-m", "motocell.services.interpolator", "--group", "2")
    ]
    assert service_command("interpolator", ["--group", "1"])[-2:] == ["--group", "1"]


@pytest.mark.parametrize("name", ["bogus", "gateway/1", "launcher"])
def test_a_name_that_is_no_service_is_refused(name: str) -> None:
    with pytest.raises(UnknownServiceError, match=f"no service {name}"):
        service_command(name, [])


def test_a_group_given_twice_is_refused() -> None:
    with pytest.raises(UnknownServiceError, match="leave out --group"):
        service_command("interpolator/1", ["--group=1"])


@pytest.mark.cell
def test_the_usage_line_names_the_command_that_runs_it() -> None:
    result = motocell("service", "interpolator", "--help")
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("usage: motocell service interpolator ")


@pytest.mark.cell
def test_an_unknown_service_is_one_line_and_status_2() -> None:
    result = motocell("service", "bogus")
    assert result.returncode == EXIT_CONFIG
    assert result.stderr == (
        "motocell service: no service bogus (services: controller, executor, broadcaster, "
        "interpolator, gateway, ros2)\n"
    )


@pytest.mark.cell
def test_a_group_the_cell_lacks_is_refused_before_joining_zenoh() -> None:
    result = motocell("service", "interpolator/3", "--zenoh-connect", NOWHERE)
    assert result.returncode == EXIT_CONFIG
    assert "no service interpolator/3 in cell" in result.stderr
    assert "router" not in result.stderr


def test_a_ctrl_c_before_the_command_can_handle_it_ends_it_quietly(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def interrupted(argv: object = None) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "main", interrupted)
    with pytest.raises(SystemExit) as exited:
        entry.main([])
    assert exited.value.code == entry.INTERRUPTED
