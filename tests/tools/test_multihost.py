"""What host C of scripts/multihost keeps of the bus (``tools.multihost.Samples``); the
scenario itself runs in tests/e2e/test_multihost.py."""

from __future__ import annotations

from types import SimpleNamespace
from typing import cast

import pytest
import zenoh

from motocell.tools import multihost
from motocell.tools.multihost import Samples


def _sample(payload: bytes) -> zenoh.Sample:
    return cast(zenoh.Sample, SimpleNamespace(payload=SimpleNamespace(to_bytes=lambda: payload)))


def test_the_observer_keeps_only_the_newest_samples(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(multihost, "RECORDED", 3)
    samples = Samples()
    for number in range(5):
        samples.store(_sample(bytes([number])))
    assert [raw for _, raw in samples.all()] == [b"\x02", b"\x03", b"\x04"]
