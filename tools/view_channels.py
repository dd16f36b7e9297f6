"""What ``motocell view`` serves and ``motocell record`` writes for Foxglove: the cells' samples
turned into Foxglove channels, each cell under its own prefix.

For cell ``c`` (``g`` is a group's name in the cell file, ``group<n>`` for a group the view
has no cell file for):

- ``/c/g/joints`` (JSON, ``motocell.GroupState``), from ``state``: the group's feedback positions
  and velocities, its commanded positions, and every other field the state carries per group;
- ``/c/g/tcp`` and ``/c/g/tcp/command`` (``foxglove.PoseInFrame`` in ``c/g/base``), from
  ``state``: an arm's tool centre point at the feedback and at the commanded position;
- ``/c/robot_status`` (JSON, ``motocell.RobotStatusFields``), from ``state``: ROBOT_STATUS;
- ``/c/status`` (JSON, ``motocell.ControllerStatus``), from ``controller/status``: servo,
  PLAY/TEACH, E-stop, HOLD, alarms, motion-ready and its NOT_READY subcode;
- ``/c/executor`` (JSON, ``motocell.ExecutorTick``), from ``executor/tick``: each tick's
  lateness and every group's queue depth;
- ``/c/executor/metrics`` (JSON, ``motocell.ExecutorMetrics``): lateness of the last second;
- ``/c/transforms`` (``foxglove.FrameTransforms``), from ``state``: every group's frames
  (``view_scene``), and each arm's ``c/g/tcp`` in its base frame;
- ``/c/scene`` (``foxglove.SceneUpdate``), from the cell file: the link geometry on those
  frames, sent again every second.

Everything is stamped with the time the sample arrived (ns since the Unix epoch), the log time
of the message and the timestamp of its transforms. A channel is made when its first message
comes; a scene needs the cell's file (the robot models and their placement), the joint topics do
not. Nothing here reads from Foxglove: the channels only publish.
"""

from __future__ import annotations

from collections.abc import Mapping

import foxglove
import msgspec
from foxglove.channels import FrameTransformsChannel, PoseInFrameChannel, SceneUpdateChannel
from foxglove.messages import (
    Color,
    CubePrimitive,
    CylinderPrimitive,
    FrameTransform,
    FrameTransforms,
    Pose,
    PoseInFrame,
    Quaternion,
    SceneEntity,
    SceneUpdate,
    Timestamp,
    Vector3,
)

from motocell.shared.bus import catalog
from motocell.shared.bus.schemas import (
    ControllerStatus,
    ExecutorMetrics,
    GroupState,
    State,
    Tick,
)
from motocell.shared.config import Cell
from motocell.tools.json_schema import json_schema
from motocell.tools.view_scene import CellScene, Shape, Transform, base_frame, tcp_frame

SCENE_EVERY_NS = 1_000_000_000
"""How often a cell's geometry is sent again: the WebSocket protocol keeps no message for a
client that subscribes later, and a recording opened in the middle needs it too."""


class ExecutorTick(msgspec.Struct, frozen=True):
    """One executor tick as the view plots it."""

    tick: int
    lateness_us: float
    """How late the tick woke, in microseconds."""
    missed: int
    """Periods missed since the executor started."""
    depths: list[int]
    """Entries in each group's ring, in group order."""


class ViewChannels:
    """The Foxglove channels of every cell seen, on one ``foxglove.Context``: a WebSocket
    server's (``motocell view``) or an MCAP file's (``motocell record``). Used by one thread."""

    def __init__(self, context: foxglove.Context, cells: Mapping[str, Cell]) -> None:
        """``cells``: the cell files known, by cell name (a cell not in it gets no scene)."""
        self.context = context
        self.cells = dict(cells)
        self.scenes = {name: CellScene(cell) for name, cell in self.cells.items()}
        self._json: dict[str, foxglove.Channel] = {}
        self._transforms: dict[str, FrameTransformsChannel] = {}
        self._scenes: dict[str, SceneUpdateChannel] = {}
        self._pose_channels: dict[str, PoseInFrameChannel] = {}
        self._scene_sent_ns: dict[str, int] = {}

    def publish(self, key: str, value: msgspec.Struct, received_ns: int) -> None:
        """``value`` arrived on ``key`` at ``received_ns``: its messages, if any show it."""
        cell = catalog.cell_of(key)
        if isinstance(value, State):
            self._state(cell, value, received_ns)
        elif isinstance(value, ControllerStatus):
            self._log_json(f"/{cell}/status", cell, value, received_ns)
        elif isinstance(value, Tick):
            self._tick(cell, value, received_ns)
        elif isinstance(value, ExecutorMetrics):
            self._log_json(f"/{cell}/executor/metrics", cell, value, received_ns)

    def topics(self) -> list[str]:
        """Every topic a message went out on, sorted."""
        return sorted(
            [
                *self._json,
                *(channel.topic() for channel in self._transforms.values()),
                *(channel.topic() for channel in self._scenes.values()),
                *self._pose_channels,
            ]
        )

    def group_name(self, cell: str, group_no: int) -> str:
        """The group's name in the cell file; ``group<n>`` without one."""
        known = self.cells.get(cell)
        if known is not None and group_no < len(known.groups):
            return known.groups[group_no].name
        return f"group{group_no}"

    def _state(self, cell: str, state: State, received_ns: int) -> None:
        stamp = _timestamp(received_ns)
        for group in state.groups:
            name = self.group_name(cell, group.group_no)
            self._log_json(f"/{cell}/{name}/joints", cell, group, received_ns)
            self._poses(cell, name, group, stamp, received_ns)
        self._log_json(f"/{cell}/robot_status", cell, state.status, received_ns)
        scene = self.scenes.get(cell)
        if scene is None:
            return
        channel = self._transforms.get(cell)
        if channel is None:
            channel = FrameTransformsChannel(f"/{cell}/transforms", context=self.context)
            self._transforms[cell] = channel
        if channel.has_sinks():
            joints = {group.group_no: group.positions for group in state.groups}
            tcps = [
                Transform(
                    base_frame(cell, self.group_name(cell, group.group_no)),
                    tcp_frame(cell, self.group_name(cell, group.group_no)),
                    (group.tcp.position[0], group.tcp.position[1], group.tcp.position[2]),
                    _quaternion(group.tcp.orientation),
                )
                for group in state.groups
                if group.tcp is not None
            ]
            transforms = [_frame_transform(t, stamp) for t in [*scene.transforms(joints), *tcps]]
            channel.log(FrameTransforms(transforms=transforms), log_time=received_ns)
        if received_ns - self._scene_sent_ns.get(cell, -SCENE_EVERY_NS) >= SCENE_EVERY_NS:
            self._scene(cell, scene, received_ns)

    def _poses(
        self, cell: str, name: str, group: GroupState, stamp: Timestamp, received_ns: int
    ) -> None:
        """The tool centre point, at the feedback and at the commanded position, in the
        group's base frame, as the state carries them (arms only)."""
        for suffix, pose in (("tcp", group.tcp), ("tcp/command", group.command_tcp)):
            if pose is None:
                continue
            topic = f"/{cell}/{name}/{suffix}"
            channel = self._pose_channels.get(topic)
            if channel is None:
                channel = PoseInFrameChannel(topic, context=self.context)
                self._pose_channels[topic] = channel
            if channel.has_sinks():
                x, y, z = pose.position
                qx, qy, qz, qw = _quaternion(pose.orientation)
                shown = Pose(
                    position=Vector3(x=x, y=y, z=z),
                    orientation=Quaternion(x=qx, y=qy, z=qz, w=qw),
                )
                framed = PoseInFrame(timestamp=stamp, frame_id=base_frame(cell, name), pose=shown)
                channel.log(framed, log_time=received_ns)

    def _scene(self, cell: str, scene: CellScene, received_ns: int) -> None:
        channel = self._scenes.get(cell)
        if channel is None:
            channel = SceneUpdateChannel(f"/{cell}/scene", context=self.context)
            self._scenes[cell] = channel
        self._scene_sent_ns[cell] = received_ns
        stamp = _timestamp(received_ns)
        entities = [
            _entity(frame, shapes, stamp) for frame, shapes in sorted(scene.shapes().items())
        ]
        channel.log(SceneUpdate(entities=entities), log_time=received_ns)

    def _tick(self, cell: str, tick: Tick, received_ns: int) -> None:
        depths = [group.depth for group in tick.groups]
        shown = ExecutorTick(tick.tick, tick.lateness_ns / 1000, tick.missed, depths)
        self._log_json(f"/{cell}/executor", cell, shown, received_ns)

    def _log_json(self, topic: str, cell: str, value: msgspec.Struct, received_ns: int) -> None:
        channel = self._json.get(topic)
        if channel is None:
            channel = json_channel(topic, type(value), self.context, {"cell": cell})
            self._json[topic] = channel
        if channel.has_sinks():
            channel.log(msgspec.json.encode(catalog.to_named(value)), log_time=received_ns)


def json_channel(
    topic: str,
    payload_type: type[msgspec.Struct],
    context: foxglove.Context,
    metadata: dict[str, str],
) -> foxglove.Channel:
    """A JSON channel whose schema is ``payload_type``'s named form, ``motocell.<Type>``."""
    schema = foxglove.Schema(
        name=f"motocell.{payload_type.__name__}",
        encoding="jsonschema",
        data=msgspec.json.encode(json_schema(payload_type)),
    )
    return foxglove.Channel(
        topic, schema=schema, message_encoding="json", context=context, metadata=metadata
    )


def _timestamp(ns: int) -> Timestamp:
    return Timestamp(ns // 1_000_000_000, ns % 1_000_000_000)


def _quaternion(values: list[float]) -> tuple[float, float, float, float]:
    x, y, z, w = values
    return (x, y, z, w)


def _frame_transform(transform: Transform, stamp: Timestamp) -> FrameTransform:
    x, y, z = transform.translation
    qx, qy, qz, qw = transform.rotation
    return FrameTransform(
        timestamp=stamp,
        parent_frame_id=transform.parent,
        child_frame_id=transform.child,
        translation=Vector3(x=x, y=y, z=z),
        rotation=Quaternion(x=qx, y=qy, z=qz, w=qw),
    )


def _entity(frame: str, shapes: list[Shape], stamp: Timestamp) -> SceneEntity:
    cylinders = [_cylinder(s) for s in shapes if s.kind == "cylinder"]
    cubes = [_cube(s) for s in shapes if s.kind == "cube"]
    return SceneEntity(
        timestamp=stamp,
        frame_id=frame,
        id=frame,
        frame_locked=True,
        cylinders=cylinders,
        cubes=cubes,
    )


def _pose(shape: Shape) -> Pose:
    x, y, z = shape.position
    qx, qy, qz, qw = shape.orientation
    return Pose(position=Vector3(x=x, y=y, z=z), orientation=Quaternion(x=qx, y=qy, z=qz, w=qw))


def _size(shape: Shape) -> Vector3:
    x, y, z = shape.size
    return Vector3(x=x, y=y, z=z)


def _colour(shape: Shape) -> Color:
    r, g, b, a = shape.colour
    return Color(r=r, g=g, b=b, a=a)


def _cylinder(shape: Shape) -> CylinderPrimitive:
    return CylinderPrimitive(
        pose=_pose(shape), size=_size(shape), bottom_scale=1.0, top_scale=1.0, color=_colour(shape)
    )


def _cube(shape: Shape) -> CubePrimitive:
    return CubePrimitive(pose=_pose(shape), size=_size(shape), color=_colour(shape))
