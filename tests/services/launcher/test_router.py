"""What a router takes for many cells: the sessions Zenoh admits, the descriptors it may open."""

from __future__ import annotations

import resource

import pytest

from motocell.services.launcher import router
from motocell.services.launcher.router import OPEN_FILES_CAP, open_files_limit
from motocell.shared.bus.router import MAX_SESSIONS, router_settings, zenoh_config


def test_a_router_admits_the_sessions_of_more_cells_than_zenohs_default() -> None:
    config = zenoh_config(router_settings(["tcp/127.0.0.1:7447"]))
    assert config.get_json("transport/unicast/max_sessions") == str(MAX_SESSIONS)
    assert MAX_SESSIONS > 1000


def test_a_standalone_router_takes_its_hard_open_files_limit() -> None:
    assert open_files_limit(1024, 524288) == 524288
    assert open_files_limit(1024, 1024) == 1024


def test_an_unlimited_hard_limit_is_capped_but_never_lowers_the_soft_one() -> None:
    infinity = resource.RLIM_INFINITY
    assert open_files_limit(1024, infinity) == OPEN_FILES_CAP
    assert open_files_limit(2 * OPEN_FILES_CAP, infinity) == 2 * OPEN_FILES_CAP
    assert open_files_limit(infinity, infinity) == infinity


def test_a_cells_router_listens_on_none_of_the_cells_own_tcp_ports(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Both picked before either is bound: the router on the state port would stop the cell."""
    picks = iter([7447, 7448, 30000])
    monkeypatch.setattr("motocell.shared.ports.free_port", lambda host="127.0.0.1": next(picks))
    monkeypatch.setattr(router, "port_free", lambda port: True)
    listen, _ = router.cell_router_endpoints([], secured=True, tcp_ports=[7446, 7447, 7448])
    assert listen == ["tcp/127.0.0.1:30000"]
