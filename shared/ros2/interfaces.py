"""The ROS 2 interface packages PyPI lacks, built once with ROS 2's own rosidl and cached.

MotoROS2's API uses four interface packages that no ``ros-jazzy-*`` wheel carries
(``definitions/README.md`` names their sources). Their upstream definitions ship in this package;
:func:`ensure` runs CMake on each, as colcon would, against the ROS 2 wheels installed beside this
interpreter, and installs the result into ``$XDG_CACHE_HOME/motocell/ros2-interfaces/<digest>``.
The digest covers the definitions, this recipe, the Python version and the ROS 2 wheels'
versions, so any change to them builds anew and an unchanged set is built only once.
:meth:`Interfaces.environment` gives the variables a process needs, at its start, to load them.

``python -m motocell.shared.ros2.interfaces`` builds (or finds) the cache and prints where it is.
"""

from __future__ import annotations

import fcntl
import hashlib
import importlib.metadata
import importlib.util
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy

DEFINITIONS = Path(__file__).resolve().parent / "definitions"
"""The interface packages' sources: upstream definitions, one folder per package."""
PACKAGES = ("control_msgs", "industrial_msgs", "motoros2_interfaces", "tf2_msgs")
"""What is built; each depends only on packages the wheels carry, so the order is free."""
RECIPE = "1"
"""Part of the digest: raise it when the way the packages are built changes."""
ROS_DISTRIBUTION_PREFIX = "ros-"
"""The ROS 2 wheels' distribution names begin with this (``ros-rclpy``, ``ros-jazzy-rclpy``)."""
EXTRA_MODULES = ("rclpy", "rosidl_cmake", "ament_package", "catkin_pkg", "em")
"""Modules the build imports, one per group of the ``ros2`` extra's requirements."""
INSTALL_EXTRA = "install the ROS 2 extra: pip install 'motocell[ros2]'"
INSTALL_TOOLS = "install CMake and a C/C++ compiler (Debian: apt-get install cmake g++)"
INSTALL_HEADERS = "install Python's C headers (Debian: apt-get install python3-dev)"
BUILD_MACHINE_INCLUDES = (
    r"^/opt/python/[^/]+/include/python3\.[0-9]+$",
    r"^/opt/python/[^/]+/lib/python3\.[0-9]+/site-packages/numpy/_core/include$",
)
"""Include directories the wheels' exported CMake targets name on the machine that built them;
they do not exist here, and CMake refuses an imported target whose include directory is missing."""


class NotInstalledError(Exception):
    """Something the build needs is not installed; the message says what to install, in one
    line."""


class BuildError(Exception):
    """CMake failed on a package; the message names the package and the log to read."""


@dataclass(frozen=True)
class Interfaces:
    """The built interface packages: an install prefix as colcon's would be."""

    prefix: Path

    @property
    def site_packages(self) -> Path:
        version = f"python{sys.version_info.major}.{sys.version_info.minor}"
        return self.prefix / "lib" / version / "site-packages"

    def environment(self, base: Mapping[str, str] | None = None) -> dict[str, str]:
        """``base`` (this process's environment by default) with the variables a process needs
        to use the packages: the ament index finds their type support (AMENT_PREFIX_PATH, the
        wheels' own prefix kept after ours), the dynamic loader their libraries (LD_LIBRARY_PATH,
        read only at a process's start), Python their modules (PYTHONPATH)."""
        env = dict(os.environ if base is None else base)
        for name, first in (
            ("AMENT_PREFIX_PATH", [self.prefix, Path(sys.prefix)]),
            ("LD_LIBRARY_PATH", [self.prefix / "lib"]),
            ("PYTHONPATH", [self.site_packages]),
        ):
            env[name] = _prepend([str(path) for path in first], env.get(name, ""))
        return env


def _prepend(first: Sequence[str], existing: str) -> str:
    rest = [part for part in existing.split(os.pathsep) if part and part not in first]
    return os.pathsep.join([*first, *rest])


def ros_wheels() -> list[str]:
    """``name==version`` of each installed ROS 2 wheel, sorted."""
    found = {
        f"{dist.metadata['Name']}=={dist.version}"
        for dist in importlib.metadata.distributions()
        if (dist.metadata["Name"] or "").lower().startswith(ROS_DISTRIBUTION_PREFIX)
    }
    return sorted(found)


def python_version() -> str:
    """This interpreter's version, micro included: the generated extension modules are built
    against its headers."""
    return ".".join(str(part) for part in sys.version_info[:3])


def digest(definitions: Path, python: str, wheels: Iterable[str]) -> str:
    """What names a build: every definition file (path and bytes), the recipe, the Python
    version and the ROS 2 wheels (their C libraries and CMake files are what the build links and
    reads)."""
    h = hashlib.sha256()
    for part in (f"recipe {RECIPE}", f"python {python}", *sorted(wheels)):
        h.update(part.encode() + b"\n")
    for path in sorted(p for p in definitions.rglob("*") if p.is_file()):
        if "__pycache__" in path.parts:
            continue
        data = path.read_bytes()
        h.update(f"{path.relative_to(definitions).as_posix()} {len(data)}\n".encode() + data)
    return h.hexdigest()[:32]


def cache_root(env: Mapping[str, str] | None = None) -> Path:
    """``$XDG_CACHE_HOME/motocell/ros2-interfaces``, ``~/.cache`` when XDG_CACHE_HOME is unset
    or empty (the XDG base directory rule)."""
    env = os.environ if env is None else env
    base = env.get("XDG_CACHE_HOME") or str(Path(env.get("HOME") or Path.home()) / ".cache")
    return Path(base) / "motocell" / "ros2-interfaces"


def missing(
    which: Callable[[str], str | None] | None = None,
    has_module: Callable[[str], bool] | None = None,
    python_include: Path | None = None,
) -> str | None:
    """What to install before a build can run, in one line, or None."""
    which = which or shutil.which
    has_module = has_module or _has_module
    if not all(has_module(name) for name in EXTRA_MODULES):
        return INSTALL_EXTRA
    if which("cmake") is None or not (which("c++") or which("g++")) or not which("cc"):
        return INSTALL_TOOLS
    include = python_include or Path(sysconfig.get_paths()["include"])
    if not (include / "Python.h").is_file():
        return INSTALL_HEADERS
    return None


def _has_module(name: str) -> bool:
    return importlib.util.find_spec(name) is not None


def ensure(root: Path | None = None) -> tuple[Interfaces, bool]:
    """The built packages, building them first if this digest has no install yet; says whether
    it built. Another process building the same digest is waited for, not joined: the lock file
    lets one build at a time, and the install appears under its final name by one rename, when
    complete."""
    root = cache_root() if root is None else root
    final = root / digest(DEFINITIONS, python_version(), ros_wheels())
    if final.is_dir():
        return Interfaces(final), False
    problem = missing()
    if problem is not None:
        raise NotInstalledError(problem)
    root.mkdir(parents=True, exist_ok=True)
    with (root / f"{final.name}.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if final.is_dir():
            return Interfaces(final), False
        for stale in root.glob(f"{final.name}.building-*"):
            # Left by a build that was killed: whoever holds the lock is the only builder.
            shutil.rmtree(stale, ignore_errors=True)
        work = Path(tempfile.mkdtemp(prefix=f"{final.name}.building-", dir=root))
        try:
            _build(work, final)
            (work / "install").rename(final)
        finally:
            shutil.rmtree(work, ignore_errors=True)
    return Interfaces(final), True


def _build(work: Path, final: Path) -> None:
    """Each package configured for its final prefix (the paths CMake writes into the install
    name it), installed under ``work/install`` until the rename."""
    fix = work / "local-includes.cmake"
    fix.write_text(_local_includes_cmake())
    env = dict(os.environ)
    env.update(
        AMENT_PREFIX_PATH=sys.prefix,
        CMAKE_PREFIX_PATH=sys.prefix,
        PATH=_prepend([str(Path(sys.executable).parent)], env.get("PATH", "")),
        # The wheels' bootstrap (a .pth file) starts every Python again with its libraries on
        # LD_LIBRARY_PATH; rosidl's generators are pure Python and need no such second start.
        _ROS_WHEELS_BOOTSTRAP_COMPLETE="1",
    )
    jobs = str(os.cpu_count() or 1)
    for package in PACKAGES:
        build = work / "build" / package
        log = work / f"{package}.log"
        steps = (
            [
                *("cmake", "-S", str(DEFINITIONS / package), "-B", str(build)),
                f"-DCMAKE_INSTALL_PREFIX={final}",
                f"-DPython3_EXECUTABLE={sys.executable}",
                "-DBUILD_TESTING=OFF",
                f"-DCMAKE_PROJECT_INCLUDE={fix}",
            ],
            ["cmake", "--build", str(build), "--parallel", jobs],
            ["cmake", "--install", str(build), "--prefix", str(work / "install")],
        )
        with log.open("w") as out:
            for step in steps:
                done = subprocess.run(
                    step, check=False, env=env, stdout=out, stderr=subprocess.STDOUT
                )
                if done.returncode:
                    kept = final.parent / log.name
                    shutil.copyfile(log, kept)
                    raise BuildError(f"building {package} failed: see {kept}")


def _local_includes_cmake() -> str:
    """A CMake file run at the end of each package's project(), that points the imported
    targets' build-machine include directories at this interpreter's own (its headers, numpy's),
    once every find_package has run. Nothing in the installed wheels is changed."""
    local = (sysconfig.get_paths()["include"], numpy.get_include())
    replaces = "\n".join(
        f'      list(TRANSFORM dirs REPLACE "{pattern}" "{target}")'
        for pattern, target in zip(BUILD_MACHINE_INCLUDES, local, strict=True)
    )
    return f"""\
function(motocell_local_includes)
  get_property(targets DIRECTORY PROPERTY IMPORTED_TARGETS)
  foreach(target IN LISTS targets)
    get_target_property(dirs ${{target}} INTERFACE_INCLUDE_DIRECTORIES)
    if(dirs)
{replaces}
      set_target_properties(${{target}} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${{dirs}}")
    endif()
  endforeach()
endfunction()
cmake_language(DEFER CALL motocell_local_includes)
"""


def main(argv: Sequence[str] | None = None) -> int:
    """Build or find the interfaces and print one line saying where they are."""
    del argv
    try:
        interfaces, built = ensure()
    except NotInstalledError as error:
        print(f"motocell: the ROS 2 interfaces cannot be built: {error}", file=sys.stderr)
        return 2
    except BuildError as error:
        print(f"motocell: the ROS 2 interfaces: {error}", file=sys.stderr)
        return 1
    print(f"ROS 2 interfaces {'built' if built else 'found'} in {interfaces.prefix}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
