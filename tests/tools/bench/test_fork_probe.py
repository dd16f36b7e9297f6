"""``python -m motocell.tools.bench.fork_probe``: forks of a process that imported the forked
services' modules, each read for the pages it un-shared."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from motocell.tools.bench.fork_probe import PROBES

pytestmark = pytest.mark.cell

TIMEOUT_S = 120.0
"""A bound for a hang: the run takes about a second."""


def test_each_probe_is_read_and_references_alone_unshare_more_than_an_idle_fork() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "motocell.tools.bench.fork_probe", "--json"],
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    results = json.loads(done.stdout)
    assert list(results) == list(PROBES)
    for inherited, whole in results.values():
        assert 0 < inherited <= whole
    # A reference count is written in the object: the pages of every module global, copied.
    assert results["read every module global"][0] > 2 * results["idle"][0]
