"""The interface cache's naming and its one-line refusals, without building anything."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from motocell.shared.ros2 import interfaces
from motocell.shared.ros2.interfaces import Interfaces

WHEELS = ["ros-rclpy==7.1.6", "ros-rmw==7.3.2"]


def definitions(tmp_path: Path) -> Path:
    shutil.copytree(interfaces.DEFINITIONS, tmp_path / "definitions")
    return tmp_path / "definitions"


def test_the_digest_is_stable_and_ignores_the_order_of_the_wheels(tmp_path: Path) -> None:
    here = definitions(tmp_path)
    first = interfaces.digest(here, "3.11.7", WHEELS)
    assert first == interfaces.digest(here, "3.11.7", reversed(WHEELS))
    assert first == interfaces.digest(interfaces.DEFINITIONS, "3.11.7", WHEELS)


@pytest.mark.parametrize("change", ["python", "wheel", "definition", "new file"])
def test_any_input_of_the_build_changes_the_digest(tmp_path: Path, change: str) -> None:
    here = definitions(tmp_path)
    before = interfaces.digest(here, "3.11.7", WHEELS)
    python, wheels = "3.11.7", list(WHEELS)
    if change == "python":
        python = "3.12.1"
    elif change == "wheel":
        wheels[0] = "ros-rclpy==7.1.7"
    elif change == "definition":
        status = here / "industrial_msgs" / "msg" / "RobotStatus.msg"
        status.write_text(status.read_text() + "\n")
    else:
        (here / "tf2_msgs" / "msg" / "TF2Error.msg").write_text("uint8 NO_ERROR = 0\n")
    assert interfaces.digest(here, python, wheels) != before


def test_every_package_ships_its_build_files_and_licence() -> None:
    for package in interfaces.PACKAGES:
        folder = interfaces.DEFINITIONS / package
        assert (folder / "package.xml").read_text().count('<package format="3">') == 1
        assert "rosidl_generate_interfaces(" in (folder / "CMakeLists.txt").read_text()
        assert any((folder / kind).is_dir() for kind in ("msg", "srv", "action"))
        assert (
            (folder / "LICENSE").is_file()
            or (folder / "LICENSES").is_dir()
            or (package == "industrial_msgs")
        ), package


def test_the_cache_follows_xdg_cache_home() -> None:
    assert interfaces.cache_root({"XDG_CACHE_HOME": "/c", "HOME": "/h"}) == Path(
        "/c/motocell/ros2-interfaces"
    )
    for env in ({"HOME": "/h"}, {"XDG_CACHE_HOME": "", "HOME": "/h"}):
        assert interfaces.cache_root(env) == Path("/h/.cache/motocell/ros2-interfaces")


def test_the_environment_puts_the_interfaces_first_and_keeps_the_rest() -> None:
    prefix = Path("/cache/abc")
    env = Interfaces(prefix).environment(
        {"LD_LIBRARY_PATH": "/x:/cache/abc/lib", "PYTHONPATH": "", "OTHER": "1"}
    )
    assert env["LD_LIBRARY_PATH"] == "/cache/abc/lib:/x"
    assert env["PYTHONPATH"] == str(Interfaces(prefix).site_packages)
    assert env["AMENT_PREFIX_PATH"].split(":")[0] == "/cache/abc"
    assert env["OTHER"] == "1"


def test_what_is_missing_is_said_in_one_line(tmp_path: Path) -> None:
    (tmp_path / "Python.h").write_text("")
    tools = {"cmake": "/usr/bin/cmake", "cc": "/usr/bin/cc", "c++": "/usr/bin/c++"}

    def which(name: str) -> str | None:
        return tools.get(name)

    def everything(name: str) -> bool:
        return True

    assert interfaces.missing(which, everything, tmp_path) is None
    assert interfaces.missing(which, lambda name: name != "rclpy", tmp_path) == (
        interfaces.INSTALL_EXTRA
    )
    assert interfaces.missing(lambda name: None, everything, tmp_path) == interfaces.INSTALL_TOOLS
    assert interfaces.missing(which, everything, tmp_path / "none") == interfaces.INSTALL_HEADERS


def test_the_command_refuses_in_one_line_with_status_2(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setattr(shutil, "which", lambda name: None)
    monkeypatch.setattr(interfaces, "ros_wheels", lambda: ["ros-none==0"])
    assert interfaces.main([]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1
    assert "install" in err
    assert not (tmp_path / "motocell").exists()


class FakeBuild:
    """Stands for CMake: counts the builds and leaves an install, or fails."""

    def __init__(self, fail: bool = False) -> None:
        self.builds = 0
        self.fail = fail

    def __call__(self, work: Path, final: Path) -> None:
        self.builds += 1
        if self.fail:
            raise interfaces.BuildError("building industrial_msgs failed")
        (work / "install" / "lib").mkdir(parents=True)


@pytest.fixture
def fake_build(monkeypatch: pytest.MonkeyPatch) -> FakeBuild:
    build = FakeBuild()
    monkeypatch.setattr(interfaces, "_build", build)
    monkeypatch.setattr(interfaces, "missing", lambda: None)
    monkeypatch.setattr(interfaces, "ros_wheels", lambda: WHEELS)
    return build


def test_a_digest_is_built_once_and_replaces_a_killed_build(
    tmp_path: Path, fake_build: FakeBuild
) -> None:
    name = interfaces.digest(interfaces.DEFINITIONS, interfaces.python_version(), WHEELS)
    (tmp_path / f"{name}.building-killed").mkdir()
    first, built = interfaces.ensure(tmp_path)
    assert (first.prefix, built) == (tmp_path / name, True)
    assert (first.prefix / "lib").is_dir()
    assert interfaces.ensure(tmp_path) == (first, False)
    assert fake_build.builds == 1
    assert sorted(path.name for path in tmp_path.iterdir()) == [name, f"{name}.lock"]


def test_a_failed_build_leaves_no_install(tmp_path: Path, fake_build: FakeBuild) -> None:
    fake_build.fail = True
    with pytest.raises(interfaces.BuildError):
        interfaces.ensure(tmp_path)
    assert [path.suffix for path in tmp_path.iterdir()] == [".lock"]
