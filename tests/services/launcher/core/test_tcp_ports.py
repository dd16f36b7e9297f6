"""The Simple Message ports of the services run here, and which ``--port-base`` can be a cell's."""

from __future__ import annotations

import pytest

from motocell.services.launcher.core.children import services_here
from motocell.services.launcher.core.tcp_ports import TcpPort, port_base_problem, tcp_ports
from motocell.shared.config import load_cell

ONE_ARM = load_cell(None)


def test_the_ports_are_those_of_the_services_run_here() -> None:
    everything = [TcpPort("motion", 50240), TcpPort("state", 50241), TcpPort("I/O", 50242)]
    served = ONE_ARM.listening_at(None, 50240)
    assert tcp_ports(served, services_here(ONE_ARM, ())) == everything
    assert tcp_ports(served, services_here(ONE_ARM, ("gateway",))) == [everything[1]]
    assert tcp_ports(served, services_here(ONE_ARM, ("broadcaster",))) == everything[::2]


@pytest.mark.parametrize("given", ["1", "50240", "65533", "auto"])
def test_a_port_base_whose_three_ports_exist_or_auto_is_fine(given: str) -> None:
    assert port_base_problem(given) is None


@pytest.mark.parametrize("given", ["0", "-1", "65534", "70000"])
def test_a_port_base_beyond_the_port_range_says_so_and_how_to_get_free_ports(given: str) -> None:
    problem = str(port_base_problem(given))
    assert f"--port-base {given} is out of range" in problem
    assert "`--port-base auto` picks three free ports" in problem


def test_a_port_base_that_is_not_a_number_says_so() -> None:
    assert "--port-base fifty is not a number" in str(port_base_problem("fifty"))
