"""One cell across three hosts made of network namespaces: ``scripts/multihost`` as an operator
runs it (docs/multihost.md). Each run makes its own namespaces, links and bridge, named by the
tag it prints first, and must leave none of them behind, nor a process or its run directory,
whatever happens."""

from __future__ import annotations

import os
import re
import signal
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from motocell.testing.processes import cmdline, wait_until
from tests.terminal import as_a_terminal_starts

RUN_TIMEOUT_S = 120.0
"""A run takes 8-40 s here; a loaded machine starts a cell's eleven processes slowly."""
CLEAN_UP_S = 60.0
"""How long the script's clean-up may take once told to stop (it stops each process within
10 s, then deletes what it made)."""
LEFTOVER_WAIT_S = 5.0
"""How long a process the script killed may take to be gone."""

pytestmark = [pytest.mark.cell, pytest.mark.timeout(RUN_TIMEOUT_S + CLEAN_UP_S + 60)]
"""pytest-timeout stops a test only after the script's own deadline and its clean-up."""

Report = dict[str, str]


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
def multihost(repo: Path, network_namespaces: None) -> Iterator[Callable[..., tuple[str, Report]]]:
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
        output = _stop(process, signal.SIGTERM)
        return process.returncode, f"{output}\n(hung: stopped after {RUN_TIMEOUT_S} s)"
    except BaseException:
        # pytest-timeout or Ctrl-C: the script must not outlive the test, nor its namespaces.
        _stop(process, signal.SIGTERM)
        raise
    return process.returncode, output


def _stop(script: subprocess.Popen[str], how: signal.Signals) -> str:
    """Signal the script's process group (its trap then cleans up, as on a terminal) and wait
    for the clean-up; its output. A clean-up that hangs is killed: the next test run removes
    what it left (tests/leftovers.py)."""
    os.killpg(script.pid, how)
    try:
        return script.communicate(timeout=CLEAN_UP_S)[0]
    except subprocess.TimeoutExpired:
        os.killpg(script.pid, signal.SIGKILL)
        return script.communicate()[0]


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


def test_ctrl_c_while_the_cell_starts_leaves_nothing(repo: Path, network_namespaces: None) -> None:
    script = subprocess.Popen(
        as_a_terminal_starts(["bash", str(repo / "scripts" / "multihost")]),
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
        output = first + _stop(script, signal.SIGINT)
    assert script.returncode == 130, output
    _assert_left_nothing(output)


def _runs_on(namespace: str) -> bool:
    pids = subprocess.run(
        ["ip", "netns", "pids", namespace], capture_output=True, text=True, check=False
    )
    return bool(pids.stdout.strip())
