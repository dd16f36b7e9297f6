"""Where a cell's own router listens and which router it links to."""

from __future__ import annotations

from motocell.services.launcher.core.endpoints import WELL_KNOWN_ENDPOINT, router_endpoints


def no_spare_port() -> int:
    raise AssertionError("no spare port should be needed")


def test_a_router_listens_where_it_is_told() -> None:
    listen, connect = router_endpoints(["tcp/127.0.0.1:9000"], False, no_spare_port, link=True)
    assert (listen, connect) == (["tcp/127.0.0.1:9000"], [])


def test_the_first_cell_takes_the_well_known_port() -> None:
    assert router_endpoints([], True, no_spare_port, link=True) == ([WELL_KNOWN_ENDPOINT], [])


def test_a_later_cell_listens_on_a_spare_port_and_links_to_the_first() -> None:
    listen, connect = router_endpoints([], False, lambda: 9123, link=True)
    assert (listen, connect) == (["tcp/127.0.0.1:9123"], [WELL_KNOWN_ENDPOINT])


def test_a_secured_cell_links_to_no_other_router() -> None:
    listen, connect = router_endpoints([], False, lambda: 9123, link=False)
    assert (listen, connect) == (["tcp/127.0.0.1:9123"], [])
