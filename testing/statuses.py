"""Controller statuses for tests and benchmarks: one ready status, changed field by field."""

from __future__ import annotations

from typing import Any

import msgspec

from motocell.shared.bus.schemas import ControllerStatus

READY = ControllerStatus(
    seq=1,
    servo_on=True,
    estop=False,
    hold=False,
    alarms=[],
    error=0,
    play=True,
    remote=True,
    operating=True,
    job_ready=True,
    pfl_active=False,
    incmove_error=False,
    eco=False,
    missing_services=[],
    motion_ready=True,
    not_ready_subcode=0,
    tools=[0],
)
"""A motion-ready controller in PLAY and REMOTE with the INIT_ROS job waiting."""


def ready_status(**changes: Any) -> ControllerStatus:
    """``READY`` with ``changes`` (field=value) applied."""
    return msgspec.structs.replace(READY, **changes)
