"""A cell's services by name: one vocabulary for the logs, ``motocell watch``, ``motocell up
--skip`` and ``motocell service``.

A service is named ``<service>/<instance>``, as its liveliness token is
(``@motocell/<cell>/alive/<service>/<instance>``): ``gateway/0``, ``interpolator/1``. An
interpolator's instance is its group; every other service has one instance, ``0``, so its bare
name (``gateway``) means it, and so does ``interpolator`` on a cell of one group.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # only for annotations: the launcher imports this module before the heavy ones
    from motocell.shared.config import Cell

PER_GROUP = "interpolator"
"""The service that runs once per control group, its group as its instance."""
ROS2_FACE = "ros2"
"""MotoROS2's ROS 2 API (``services/ros2``): only in a cell whose file has ``[ros2]``."""
SERVICES = ("controller", "executor", "broadcaster", PER_GROUP, "gateway", ROS2_FACE)
"""Every kind of service, in the order a launcher starts them."""
WARM_SERVICES = tuple(service for service in SERVICES if service != ROS2_FACE)
"""The services the warm parent forks: every one but the ROS 2 face, whose rclpy would double
the parent's size for one process."""


def service_module(service: str) -> str:
    """What ``python -m`` runs for a service of this kind."""
    return f"motocell.services.{service}"


WARM_MODULES = tuple(service_module(service) for service in WARM_SERVICES)
"""What the warm parent imports and forks."""


class UnknownServiceError(ValueError):
    """A name that is no service of the cell; the message lists those it has."""


@dataclass(frozen=True)
class ServiceName:
    service: str
    """The kind, which is also its module: ``services.<service>``."""
    instance: str

    def __str__(self) -> str:
        return f"{self.service}/{self.instance}"


def cell_services(cell: Cell) -> list[ServiceName]:
    """The services ``cell`` has, in start order."""
    names = []
    for service in SERVICES:
        if service == ROS2_FACE and cell.ros2 is None:
            continue
        if service == PER_GROUP:
            names += [ServiceName(service, str(group.index)) for group in cell.groups]
        else:
            names.append(ServiceName(service, "0"))
    return names


def service_kind(text: str) -> tuple[str, str | None]:
    """``text`` as (service, instance or None when not given), for a command that knows no
    cell yet; UnknownServiceError for an unknown service or a second instance of a service
    that has one."""
    service, slash, instance = text.partition("/")
    if service not in SERVICES:
        raise UnknownServiceError(f"no service {text} (services: {', '.join(SERVICES)})")
    if slash and service != PER_GROUP and instance != "0":
        raise UnknownServiceError(f"no service {text}: a cell has one {service}, {service}/0")
    if slash and not (instance.isdigit() and str(int(instance)) == instance):
        raise UnknownServiceError(f"no service {text}: {PER_GROUP}/GROUP takes a group number")
    return service, instance if slash else None


def parse_service(text: str, cell: Cell) -> ServiceName:
    """``gateway``, ``gateway/0``, ``interpolator/1`` as one of ``cell``'s services;
    UnknownServiceError, listing them, for a name that is none of them."""
    service, instance = service_kind(text)
    if service == ROS2_FACE and cell.ros2 is None:
        raise UnknownServiceError(
            f"cell {cell.name} has no ROS 2 face: add a [ros2] table to its file (docs/ros2.md)"
        )
    candidates = [name for name in cell_services(cell) if name.service == service]
    if instance is None and len(candidates) == 1:
        return candidates[0]
    if instance is None:
        raise UnknownServiceError(
            f"{text}: cell {cell.name} has one per group; name it: "
            f"{', '.join(map(str, candidates))}"
        )
    if ServiceName(service, instance) not in candidates:
        raise UnknownServiceError(
            f"no service {text} in cell {cell.name} (its services: "
            f"{', '.join(map(str, cell_services(cell)))})"
        )
    return ServiceName(service, instance)
