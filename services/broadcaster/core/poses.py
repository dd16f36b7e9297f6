"""The arms' flange and TCP poses for the ``state`` sample (docs/poses.md)."""

from __future__ import annotations

import msgspec
import numpy as np

from motocell.shared.bus.schemas import CartesianPose, GroupState, State
from motocell.shared.config import Cell
from motocell.shared.motion.forward_kinematics import Chain, pose, tool_transform
from motocell.shared.protocol.constants import TOOL_NUMBERS


class Poses:
    """The flange and TCP poses of every arm group, at the feedback and the commanded position
    (docs/poses.md). Positioners and tracks carry no tool, so get none."""

    def __init__(self, cell: Cell) -> None:
        self.chains = {
            group.index: Chain(group.model) for group in cell.groups if group.model.kind == "robot"
        }
        self.tools = [tool_transform(cell.tool(number)) for number in TOOL_NUMBERS]

    def add(self, state: State, tools: list[int]) -> State:
        """``state`` with the poses of its arms; ``tools`` is the selected tool per group."""
        groups = [
            self._group(group, tools[group.group_no] if group.group_no < len(tools) else 0)
            for group in state.groups
        ]
        return msgspec.structs.replace(state, groups=groups)

    def _group(self, group: GroupState, tool: int) -> GroupState:
        chain = self.chains.get(group.group_no)
        if chain is None:
            return group
        # Both positions in one pass: 2 flanges, then 2 TCPs, then 4 poses at once.
        flanges = chain.flange(np.array([group.positions, group.command_positions]))
        frames = np.concatenate([flanges, flanges @ self.tools[tool]])
        positions, orientations = pose(frames)
        flange, command_flange, tcp, command_tcp = (
            CartesianPose(position, orientation)
            for position, orientation in zip(positions.tolist(), orientations.tolist(), strict=True)
        )
        return msgspec.structs.replace(
            group,
            tool=tool,
            flange=flange,
            tcp=tcp,
            command_flange=command_flange,
            command_tcp=command_tcp,
        )
