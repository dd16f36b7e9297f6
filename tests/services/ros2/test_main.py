"""The face's process where ROS 2 is not installed: one line saying what to install, status 2,
before it joins anything; ``motocell up`` refuses such a cell before it starts anything."""

from __future__ import annotations

import argparse
import importlib.util
from importlib.machinery import ModuleSpec
from pathlib import Path

import pytest

from motocell.services.launcher.up import ThisHost
from motocell.services.ros2.__main__ import main
from motocell.shared.config import EXIT_CONFIG, ConfigError, parse_cell

FIND_SPEC = importlib.util.find_spec


def without_rclpy(monkeypatch: pytest.MonkeyPatch) -> None:
    def find_spec(name: str, package: str | None = None) -> ModuleSpec | None:
        return None if name == "rclpy" else FIND_SPEC(name, package)

    monkeypatch.setattr(importlib.util, "find_spec", find_spec)


def test_without_ros2_the_face_says_what_to_install(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    without_rclpy(monkeypatch)
    cell_file = tmp_path / "cell.toml"
    cell_file.write_text("[ros2]\n")
    with pytest.raises(SystemExit) as exited:
        main(["--config", str(cell_file), "--zenoh-connect", "tcp/127.0.0.1:1"])
    assert exited.value.code == EXIT_CONFIG
    assert capsys.readouterr().err == (
        "motocell ros2/0: ROS 2 is not installed here; pip install 'motocell[ros2]'\n"
    )


def test_up_refuses_a_cell_with_a_face_where_ros2_is_missing(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    without_rclpy(monkeypatch)
    args = argparse.Namespace(skip=None, host=None, port_base=None)
    with pytest.raises(ConfigError, match=r"asks for the ROS 2 face .* --skip ros2"):
        ThisHost(parse_cell({"ros2": {}}), args)
    ThisHost(parse_cell({"ros2": {}}), argparse.Namespace(skip=["ros2"], host=None, port_base=None))
