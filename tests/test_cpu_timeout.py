"""A property's timeout counts CPU seconds (``tests/cpu_timeout.py``): one that does not end is
stopped once it has spent them, however loaded the machine; one that waits is not; any other
test keeps pytest-timeout's wall-clock bound."""

from __future__ import annotations

import textwrap

import pytest

from tests.cpu_timeout import CpuTimeout

pytest_plugins = ["pytester"]

INNER = """
import time

import pytest
from hypothesis import given, settings, strategies as st


@settings(max_examples=5, deadline=None, database=None)
@given(st.integers())
def test_property_never_ends(n):
    while True:
        pass


@settings(max_examples=1, deadline=None, database=None)
@given(st.integers())
def test_property_waits_past_the_timeout(n):
    time.sleep(1.5)


def test_plain_waits_past_the_timeout():
    time.sleep(1.5)
"""


@pytest.fixture
def inner(pytester: pytest.Pytester) -> pytest.Pytester:
    pytester.makeini("[pytest]\ntimeout = 1\n")
    pytester.makepyfile(test_inner=textwrap.dedent(INNER))
    return pytester


def test_a_property_that_does_not_end_is_stopped_after_its_cpu_seconds(
    inner: pytest.Pytester,
) -> None:
    result = inner.runpytest_inprocess(
        "-p", "no:cacheprovider", "-o", "timeout=0.3", "-k", "never_ends", plugins=[CpuTimeout()]
    )
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(
        ["*CpuTimeoutError: the property spent more than 0.3 s of CPU time"]
    )


@pytest.mark.cell  # waits 1.5 s twice: tests/lanes.py
def test_waiting_counts_for_a_property_only_in_cpu_and_for_any_other_test_in_wall_time(
    inner: pytest.Pytester,
) -> None:
    result = inner.runpytest_inprocess(
        "-p", "no:cacheprovider", "-k", "waits_past", plugins=[CpuTimeout()]
    )
    result.assert_outcomes(passed=1, failed=1)
    result.stdout.fnmatch_lines(["FAILED test_inner.py::test_plain_waits_past_the_timeout*"])
