"""The clean-up of what earlier runs left (``tests/leftovers.py``): what it removes, what it
keeps, and the cells it stops first. The owners here are a pid no process has."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import msgspec
import pytest

from motocell.shared.registry import CellEntry
from motocell.testing.processes import alive, wait_until
from tests.leftovers import (
    LINKS,
    NAMESPACES,
    clean_directories,
    clean_network,
    directory_owner,
    network_owner,
    suite_tag,
    why_no_namespaces,
)


def test_names_say_whose_they_are() -> None:
    assert network_owner("mh00ff10-a") == 0xFF10
    assert network_owner("mh00ff10br") == 0xFF10
    assert network_owner(f"{suite_tag()}-host") == os.getpid()
    assert network_owner("eth0") is network_owner("mhprobe1a2b3c") is None
    assert directory_owner("motocell-multihost-mh00ff10-Ab12") == 0xFF10
    assert directory_owner("motocell-cell-4242-x1y2z3") == 4242
    assert directory_owner("motocell-tests-4242-x1y2z3") == 4242
    assert directory_owner("motocell-bench-x1y2z3") is directory_owner("motocell-cell-ab") is None


def register(directory: Path, name: str, pid: int) -> None:
    (directory / "cells").mkdir(parents=True)
    entry = CellEntry(name=name, pid=pid, host="127.0.0.1", port_base=1, zenoh_endpoint="tcp/h:1")
    (directory / "cells" / f"{name}.json").write_bytes(msgspec.json.encode(entry))


def test_the_directories_of_gone_owners_are_removed_and_the_others_kept(
    tmp_path: Path, dead_pid: int
) -> None:
    gone = [
        tmp_path / f"motocell-cell-{dead_pid}-a1",
        tmp_path / f"motocell-tests-{dead_pid}-b2",
        tmp_path / f"motocell-multihost-mh{dead_pid:06x}-c3",
    ]
    kept = [
        tmp_path / f"motocell-cell-{os.getpid()}-d4",
        tmp_path / "motocell-bench-e5",
        tmp_path / "motocell-cell-f6",
    ]
    for directory in gone + kept:
        directory.mkdir()
    # A registered cell whose pid now runs something else (this process): not stopped.
    register(gone[0], "reused", os.getpid())

    removed = clean_directories([tmp_path], lambda owner: owner == dead_pid)

    assert removed == [
        f"directory {path} (its owner, pid {dead_pid}, is gone)" for path in sorted(gone)
    ]
    assert sorted(tmp_path.iterdir()) == sorted(kept)


@pytest.fixture
def launcher() -> Iterator[subprocess.Popen[bytes]]:
    """A process whose arguments are a launcher's; SIGTERM ends it, as it ends a launcher."""
    code = "import signal; signal.pause()"
    process = subprocess.Popen([sys.executable, "-c", code, "motocell.services.launcher"])
    yield process
    process.kill()
    process.wait()


@pytest.mark.cell
def test_a_cell_left_running_is_stopped_before_its_directory_goes(
    tmp_path: Path, dead_pid: int, launcher: subprocess.Popen[bytes]
) -> None:
    directory = tmp_path / f"motocell-cell-{dead_pid}-a1"
    register(directory, "orphan", launcher.pid)

    removed = clean_directories([tmp_path], lambda owner: owner == dead_pid)

    assert removed == [
        f"cell orphan: its launcher, pid {launcher.pid}, stopped",
        f"directory {directory} (its owner, pid {dead_pid}, is gone)",
    ]
    assert launcher.wait(timeout=5) == -15
    assert not directory.exists()


def ip(*args: str) -> str:
    return subprocess.run(["ip", *args], check=True, capture_output=True, text=True).stdout


def runs_inside(namespace: str) -> bool:
    return bool(ip("netns", "pids", namespace).split())


@pytest.fixture
def network_leftovers(dead_pid: int) -> Iterator[tuple[str, str, subprocess.Popen[bytes]]]:
    """A namespace with a process inside and a link, as a run killed outright leaves them:
    named for an owner that is gone. Deleted afterwards should the cleaner miss them."""
    reason = why_no_namespaces()
    if reason:
        pytest.skip(reason)
    namespace, link = f"mt{dead_pid:06x}-x", f"mt{dead_pid:06x}t"
    inside: subprocess.Popen[bytes] | None = None
    try:
        ip("netns", "add", namespace)
        ip("tuntap", "add", "dev", link, "mode", "tap")  # as scripts/multihost's delay line
        inside = subprocess.Popen(["ip", "netns", "exec", namespace, "sleep", "600"])
        wait_until(lambda: runs_inside(namespace), 30.0, "a process inside the namespace")
        yield namespace, link, inside
    finally:
        if inside is not None:
            inside.kill()
            inside.wait()
        subprocess.run(["ip", "netns", "delete", namespace], capture_output=True, check=False)
        subprocess.run(["ip", "link", "delete", link], capture_output=True, check=False)


@pytest.mark.cell
def test_namespaces_and_links_of_gone_owners_are_removed_with_what_runs_inside(
    network_leftovers: tuple[str, str, subprocess.Popen[bytes]], dead_pid: int
) -> None:
    namespace, link, inside = network_leftovers
    other = f"{suite_tag()}-y"  # this process's: alive, so kept
    ip("netns", "add", other)
    try:
        removed = clean_network(lambda owner: owner == dead_pid)
        assert (NAMESPACES / other).exists()
    finally:
        ip("netns", "delete", other)

    assert removed == [
        f"network namespace {namespace} (its owner, pid {dead_pid}, is gone, 1 process(es) killed)",
        f"link {link} (its owner, pid {dead_pid}, is gone)",
    ]
    assert inside.wait(timeout=5) == -9
    assert not (NAMESPACES / namespace).exists()
    assert not (LINKS / link).exists()
    assert not alive(inside.pid)
