"""One cell across three hosts made of network namespaces: ``scripts/multihost`` as an operator
runs it (docs/multihost.md). Each run makes its own namespaces, links and bridge and must leave
none of them behind, nor a process, whatever happens."""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

pytestmark = pytest.mark.cell

RUN_TIMEOUT_S = 120.0
"""A run takes 8-20 s here; a loaded machine starts a cell's eleven processes slowly."""


def _namespaces_work() -> bool:
    if os.geteuid() != 0 or shutil.which("ip") is None:
        return False
    probe = f"mhprobe{uuid.uuid4().hex[:6]}"
    added = subprocess.run(["ip", "netns", "add", probe], capture_output=True, check=False)
    if added.returncode != 0:
        return False
    subprocess.run(["ip", "netns", "delete", probe], capture_output=True, check=False)
    return True


needs_namespaces = pytest.mark.skipif(
    not _namespaces_work(), reason="needs root and `ip netns` (network namespaces)"
)


def _ours(listing: str, tag: str) -> list[str]:
    return [line for line in listing.splitlines() if tag in line]


def _leftovers(tag: str) -> list[str]:
    namespaces = subprocess.run(
        ["ip", "netns", "list"], capture_output=True, text=True, check=False
    ).stdout
    links = subprocess.run(["ip", "-o", "link"], capture_output=True, text=True, check=False).stdout
    return _ours(namespaces, tag) + _ours(links, tag)


@pytest.fixture
def multihost(repo: Path) -> Iterator[list[subprocess.CompletedProcess[str]]]:
    """Runs of ``bash scripts/multihost``; afterwards, nothing of theirs may be left."""
    runs: list[subprocess.CompletedProcess[str]] = []
    yield runs
    for run in runs:
        tag = re.search(r"bridge (mh[0-9a-f]{5})br", run.stdout)
        if tag:
            assert _leftovers(tag.group(1)) == [], "the script left namespaces or links"


def run_script(repo: Path, *options: str) -> subprocess.CompletedProcess[str]:
    process = subprocess.Popen(
        ["bash", str(repo / "scripts" / "multihost"), *options],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    try:
        output, _ = process.communicate(timeout=RUN_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        # SIGTERM runs the script's clean-up (its trap); wait for it to finish.
        os.killpg(process.pid, signal.SIGTERM)
        output, _ = process.communicate(timeout=30)
        raise AssertionError(f"scripts/multihost {options} hung:\n{output}") from None
    return subprocess.CompletedProcess(process.args, process.returncode, output)


def lines(output: str) -> dict[str, str]:
    """The report's ``name: value`` lines."""
    return {
        name.strip(): value.strip()
        for name, _, value in (line.partition(":") for line in output.splitlines())
        if value
    }


@needs_namespaces
def test_the_demo_across_three_hosts_over_a_delayed_link(
    repo: Path, multihost: list[subprocess.CompletedProcess[str]]
) -> None:
    run = run_script(repo, "--delay", "1")
    multihost.append(run)
    assert run.returncode == 0, run.stdout
    report = lines(run.stdout)
    assert re.search(r"^START_TRAJ_MODE -> SUCCESS", run.stdout, re.MULTILINE), run.stdout
    assert "secured" in report["cell INFO cell four ready"], run.stdout
    assert report["points sent"].startswith("20 (MOTO_JOINT_TRAJ_PT_FULL_EX, 4 groups"), run.stdout
    assert report["final error"].startswith("0 pulse(s)"), run.stdout
    assert report["link delay"].startswith("1 ms one way"), run.stdout
    for measured in ("reply latency", "in the gateway", "state age", "empty queue"):
        assert measured in report, run.stdout


@needs_namespaces
def test_killing_the_router_stops_the_cell_safely_and_it_recovers(
    repo: Path, multihost: list[subprocess.CompletedProcess[str]]
) -> None:
    run = run_script(repo, "--fault", "router")
    multihost.append(run)
    report = lines(run.stdout)
    assert report["refused"].startswith("NOT_READY"), run.stdout
    assert report["moved after told"].startswith("0 ticks"), run.stdout
    assert "SUCCESS" in report["recovery"], run.stdout
    assert run.returncode == 0, run.stdout


@needs_namespaces
def test_cutting_the_interpolators_link_is_told_and_nothing_moves_late(
    repo: Path, multihost: list[subprocess.CompletedProcess[str]]
) -> None:
    run = run_script(repo, "--fault", "link")
    multihost.append(run)
    report = lines(run.stdout)
    assert report["new trajectory"].endswith("0 pulse(s) from the goal (max over 15 axes)")
    assert report["NOT_READY told"] != "never", run.stdout
    assert report["moved after told"].startswith("0 ticks"), run.stdout
    assert run.returncode == 0, run.stdout
