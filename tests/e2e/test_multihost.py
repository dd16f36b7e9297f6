"""One cell across three hosts made of network namespaces: ``scripts/multihost`` as an operator
runs it (docs/multihost.md). Each run makes its own namespaces, links and bridge, named by the
tag it prints first, and must leave none of them behind, nor a process or its run directory,
whatever happens."""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from motocell.testkit.processes import cmdline, wait_until

pytestmark = pytest.mark.cell

RUN_TIMEOUT_S = 120.0
"""A run takes 8-40 s here; a loaded machine starts a cell's eleven processes slowly."""
LEFTOVER_WAIT_S = 5.0
"""How long a process the script killed may take to be gone."""

Report = dict[str, str]


def _why_no_namespaces() -> str:
    """Why this machine cannot run the script ("" when it can)."""
    if os.geteuid() != 0:
        return "needs root, to create network namespaces"
    if shutil.which("ip") is None:
        return "needs the ip command (iproute2)"
    probe = f"mhprobe{uuid.uuid4().hex[:6]}"
    added = subprocess.run(
        ["ip", "netns", "add", probe], capture_output=True, text=True, check=False
    )
    if added.returncode != 0:
        return f"`ip netns add` fails here: {added.stderr.strip()}"
    subprocess.run(["ip", "netns", "delete", probe], capture_output=True, check=False)
    return ""


@pytest.fixture(scope="module")
def namespaces() -> None:
    reason = _why_no_namespaces()
    if reason:
        pytest.skip(reason)


def _leftovers(tag: str, directory: str) -> list[str]:
    """This run's namespaces, links and processes still there, and its run directory."""
    listings = [
        subprocess.run(command, capture_output=True, text=True, check=False).stdout
        for command in (["ip", "netns", "list"], ["ip", "-o", "link"])
    ]
    found = [line for listing in listings for line in listing.splitlines() if tag in line]
    found += [
        f"process {pid}: {' '.join(command)}"
        for pid, command in ((int(p), cmdline(int(p))) for p in os.listdir("/proc") if p.isdigit())
        if any(tag in part or directory in part for part in command)
    ]
    return found + ([directory] if Path(directory).exists() else [])


@pytest.fixture
def multihost(repo: Path, namespaces: None) -> Iterator[Callable[..., tuple[str, Report]]]:
    """Runs ``bash scripts/multihost OPTIONS``: its output and its report's ``name: value``
    lines. Afterwards nothing of any run may be left."""
    runs: list[str] = []

    def run(*options: str) -> tuple[str, Report]:
        status, output = _run_script(repo, *options)
        runs.append(output)
        assert status == 0, f"scripts/multihost {' '.join(options)}:\n{output}"
        return output, _report(output)

    yield run
    for output in runs:
        _assert_left_nothing(output)


def _assert_left_nothing(output: str) -> None:
    named = re.search(r"^run (mh[0-9a-f]{6}): .* directory (\S+)$", output, re.MULTILINE)
    assert named, f"the script did not name its run first:\n{output}"
    tag, directory = named.groups()
    try:
        wait_until(lambda: not _leftovers(tag, directory), LEFTOVER_WAIT_S, "the clean-up")
    except TimeoutError:
        pytest.fail(f"the script left {_leftovers(tag, directory)}")


def _run_script(repo: Path, *options: str) -> tuple[int, str]:
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
        output, _ = process.communicate(timeout=60)
        return process.returncode, f"{output}\n(hung: stopped after {RUN_TIMEOUT_S} s)"
    return process.returncode, output


def _report(output: str) -> Report:
    return {
        name.strip(): value.strip()
        for name, _, value in (line.partition(":") for line in output.splitlines())
        if value
    }


def test_the_demo_across_three_hosts_over_a_delayed_link(
    multihost: Callable[..., tuple[str, Report]],
) -> None:
    output, report = multihost("--delay", "1")
    assert re.search(r"^START_TRAJ_MODE -> SUCCESS", output, re.MULTILINE), output
    assert "secured" in report.get("cell INFO cell four ready", ""), output
    assert report.get("points sent", "").startswith("20 (MOTO_JOINT_TRAJ_PT_FULL_EX, 4 groups")
    assert report.get("final error", "").startswith("0 pulse(s)"), output
    assert report.get("link delay", "").startswith("1 ms one way"), output
    for measured in ("following error", "reply latency", "in the gateway", "state age"):
        assert measured in report, output
    assert report.get("empty queue", "").startswith("0 mid-trajectory"), output


def test_killing_the_router_stops_the_cell_safely_and_it_recovers(
    multihost: Callable[..., tuple[str, Report]],
) -> None:
    output, report = multihost("--fault", "router")
    assert report.get("refused", "").startswith("NOT_READY"), output
    assert report.get("moved after told", "").startswith("0 ticks"), output
    assert "SUCCESS" in report.get("recovery", ""), output


def test_cutting_the_interpolators_link_is_told_and_nothing_moves_late(
    multihost: Callable[..., tuple[str, Report]],
) -> None:
    output, report = multihost("--fault", "link")
    assert report.get("NOT_READY told", "never") != "never", output
    assert report.get("moved after told", "").startswith("0 ticks"), output
    assert report.get("new trajectory", "").endswith("0 pulse(s) from the goal (max over 15 axes)")


def test_ctrl_c_while_the_cell_starts_leaves_nothing(repo: Path, namespaces: None) -> None:
    script = subprocess.Popen(
        ["bash", str(repo / "scripts" / "multihost")],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    assert script.stdout is not None
    first = script.stdout.readline()
    tag = first.split(":")[0].removeprefix("run ")
    try:
        wait_until(lambda: _runs_on(f"{tag}-b"), RUN_TIMEOUT_S, "host B's interpolators")
    finally:
        # What a terminal's Ctrl-C does: SIGINT to the script's process group.
        os.killpg(script.pid, signal.SIGINT)
        output = first + script.communicate(timeout=60)[0]
    assert script.returncode == 130, output
    _assert_left_nothing(output)


def _runs_on(namespace: str) -> bool:
    pids = subprocess.run(
        ["ip", "netns", "pids", namespace], capture_output=True, text=True, check=False
    )
    return bool(pids.stdout.strip())
