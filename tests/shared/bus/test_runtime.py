"""Which Zenoh runtime a process opens its first session with (``shared/bus/runtime.py``)."""

from __future__ import annotations

import os

import pytest

from motocell.shared.bus.runtime import CELL_RUNTIME, ENV, zenoh_runtime


def test_the_runtime_is_in_the_environment_only_while_the_session_opens(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv(ENV, raising=False)
    with zenoh_runtime():
        assert os.environ[ENV] == CELL_RUNTIME
    assert ENV not in os.environ


def test_the_environment_s_own_runtime_is_kept(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(ENV, "(app: (worker_threads: 2))")
    with zenoh_runtime():
        assert os.environ[ENV] == "(app: (worker_threads: 2))"
    assert os.environ[ENV] == "(app: (worker_threads: 2))"


def test_an_error_while_opening_leaves_the_environment_as_it_was(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv(ENV, raising=False)
    with pytest.raises(ConnectionError), zenoh_runtime():
        raise ConnectionError("no router")
    assert ENV not in os.environ
