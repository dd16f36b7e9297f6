"""The face's rclpy node: MotoROS2's names, types and QoS (docs/ros2.md). Only this module
imports ROS 2, and only the face's process loads it: a cell without ``[ros2]`` never does.

The node is a plain one: no parameter services and no ``rosout`` publisher, since MotoROS2 (a
micro-ROS node) offers neither, and a client listing the graph sees MotoROS2's endpoints.
rclpy's own signal handlers are off: the service's stop flag owns SIGINT and SIGTERM. Topics
are published from the face's loop thread; services are served by an executor on a thread of
its own, one request at a time, as MotoROS2 serves them.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from typing import Any, TypeVar

import rclpy
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from geometry_msgs.msg import TransformStamped
from industrial_msgs.msg import RobotMode, RobotStatus, TriState
from motoros2_interfaces.msg import (
    InitTrajEnum,
    IoResultCodes,
    MotionReadyEnum,
    QueueResultEnum,
    SelectionResultCodes,
)
from motoros2_interfaces.srv import (
    QueueTrajPoint,
    ReadGroupIO,
    ReadMRegister,
    ReadSingleIO,
    ResetError,
    SelectMotionTool,
    StartPointQueueMode,
    StartTrajMode,
    WriteGroupIO,
    WriteMRegister,
    WriteSingleIO,
)
from rclpy.action.server import ActionServer, CancelResponse, GoalResponse, ServerGoalHandle
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.context import Context
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_msgs.msg import Header
from std_srvs.srv import Trigger
from tf2_msgs.msg import TFMessage

from motocell.services.ros2.core.codes import READY
from motocell.services.ros2.core.goal import (
    INVALID_GOAL,
    MAX_POINTS,
    Goal,
    GoalPoint,
    InitTraj,
    ending_words,
    error_code,
    plan,
)
from motocell.services.ros2.core.joint_state_cdr import JointStateCdr
from motocell.services.ros2.core.point_queue import MotionMode, QueuedPoint
from motocell.services.ros2.core.tf import Frames, FrameTransform
from motocell.services.ros2.core.topics import (
    TopicValues,
    ctrl_group_topic,
    error_codes,
    group_spans,
    names_by_group,
)
from motocell.services.ros2.goal_runner import GoalRunner, positions_of
from motocell.services.ros2.motoros2_services import Motoros2Services
from motocell.shared.bus.schemas import RobotStatusFields, State
from motocell.shared.config import Cell, Ros2Face

_Answered = TypeVar(
    "_Answered", StartTrajMode.Response, StartPointQueueMode.Response, ResetError.Response
)

DISCOVERY_RANGE_ENV = "ROS_AUTOMATIC_DISCOVERY_RANGE"
"""Read by the RMW when rclpy starts: LOCALHOST keeps the face on this host."""


def discovery_range(face: Ros2Face) -> str:
    return "SUBNET" if face.open_discovery else "LOCALHOST"


ROBOT_STATUS = "robot_status"
UNSPECIFIED = "Unspecified error occurred while adding the trajectory point to the queue."
"""MotoROS2's words for a queued point refused for a reason it has no words for."""

SPIN_S = 5.0
"""A bound on the executor's wait for work, not a rate: the context's shutdown wakes it
(rclpy's executor wakes itself on it), and each of its wake-ups costs about half a
millisecond (it builds its wait set anew), ten times a second with a 0.1 s bound."""


def _words(enum: type) -> dict[int, str]:
    """MotoROS2's words for each value of one of its enum messages, from the interface itself."""
    return {
        getattr(enum, name): getattr(enum, f"{name}_STR")
        for name in dir(enum)
        if name.isupper() and hasattr(enum, f"{name}_STR")
    }


class FaceNode:
    """``loop.Topics`` over an rclpy node in a context of its own, with MotoROS2's services."""

    def __init__(
        self,
        cell: Cell,
        face: Ros2Face,
        services: Motoros2Services,
        runner: GoalRunner,
        newest: Callable[[], State | None],
        *,
        readers_changed: Callable[[], None],
    ) -> None:
        """``readers_changed``: called (on the executor's thread) when a subscription to a
        topic of the face comes or goes."""
        os.environ[DISCOVERY_RANGE_ENV] = discovery_range(face)
        self._context = Context()
        rclpy.init(
            context=self._context,
            domain_id=face.ros_domain_id,
            signal_handler_options=SignalHandlerOptions.NO,
        )
        self.node = Node(
            face.node_name,
            namespace=face.node_namespace or None,
            context=self._context,
            enable_rosout=False,
            start_parameter_services=False,
        )
        qos = qos_profile_sensor_data  # MotoROS2's default for joint_states
        self._readers = Readers(readers_changed)
        self._joint_topics = ["joint_states", *map(ctrl_group_topic, cell.groups)]
        self._joint_publishers = [
            self.node.create_publisher(
                JointState, topic, qos, event_callbacks=self._readers.events(topic)
            )
            for topic in self._joint_topics
        ]
        names = [list(group) for group in names_by_group(cell, face)]
        spans = group_spans(cell.groups)
        self._joint_spans = [(0, spans[-1][1]), *spans]
        self._joint_messages = [JointStateCdr(_flat(names)), *map(JointStateCdr, names)]
        """Each topic's message as bytes: its names laid out once (``core.joint_state_cdr``)."""
        self._robot_status = self.node.create_publisher(
            RobotStatus, ROBOT_STATUS, qos, event_callbacks=self._readers.events(ROBOT_STATUS)
        )
        self._status_message = RobotStatus()
        self._status_for: RobotStatusFields | None = None
        # MotoROS2 makes the publisher whatever publish_tf says; tf's QoS is the default one
        # (reliable), which RViz needs.
        self._tf_topic = "tf" if face.namespace_tf else "/tf"
        self._tf = self.node.create_publisher(
            TFMessage, self._tf_topic, 10, event_callbacks=self._readers.events(self._tf_topic)
        )
        self._frames = Frames(cell, face) if face.publish_tf else None
        self._tf_message = TFMessage()
        self._tf_for: State | None = None
        self._services = services
        self._words = _words(MotionReadyEnum)
        self._init_words = _words(InitTrajEnum)
        self.node.create_service(StartTrajMode, "start_traj_mode", self._start_traj_mode)
        self.node.create_service(
            StartPointQueueMode, "start_point_queue_mode", self._start_point_queue_mode
        )
        self._queue_words = _words(QueueResultEnum)
        self.node.create_service(QueueTrajPoint, "queue_traj_point", self._queue_traj_point)
        self.node.create_service(Trigger, "stop_traj_mode", self._stop_traj_mode)
        self.node.create_service(ResetError, "reset_error", self._reset_error)
        self._io_words = _words(IoResultCodes)
        self._selection_words = _words(SelectionResultCodes)
        for kind, name, read in (
            (ReadSingleIO, "read_single_io", services.read_single_io),
            (ReadGroupIO, "read_group_io", services.read_group_io),
            (ReadMRegister, "read_mregister", services.read_mregister),
        ):
            self.node.create_service(kind, name, self._reading(read))
        for kind, name, write in (
            (WriteSingleIO, "write_single_io", services.write_single_io),
            (WriteGroupIO, "write_group_io", services.write_group_io),
            (WriteMRegister, "write_mregister", services.write_mregister),
        ):
            self.node.create_service(kind, name, self._writing(write))
        self.node.create_service(SelectMotionTool, "select_motion_tool", self._select_motion_tool)
        self._groups_of_cell = cell.groups
        self._names = names
        self._runner = runner
        self._newest = newest
        self._running = threading.Lock()
        """One goal at a time, as MotoROS2 runs them."""
        # The goal runs on one of the executor's threads while the other takes its cancel.
        ActionServer(
            self.node,
            FollowJointTrajectory,
            "follow_joint_trajectory",
            execute_callback=self._follow,
            goal_callback=lambda request: GoalResponse.ACCEPT,
            cancel_callback=lambda handle: CancelResponse.ACCEPT,
            callback_group=ReentrantCallbackGroup(),
        )
        self._executor = MultiThreadedExecutor(num_threads=2, context=self._context)
        self._executor.add_node(self.node)
        self._serving = threading.Thread(target=self._serve, name="ros2-services")

    def start(self) -> None:
        self._serving.start()

    def _serve(self) -> None:
        try:
            while self._context.ok():
                self._executor.spin_once(timeout_sec=SPIN_S)
        except ExternalShutdownException:
            pass  # the context was shut down while it waited: the face stops

    def _start_traj_mode(
        self, request: StartTrajMode.Request, response: StartTrajMode.Response
    ) -> StartTrajMode.Response:
        return self._answer(response, self._services.start_traj_mode())

    def _start_point_queue_mode(
        self, request: StartPointQueueMode.Request, response: StartPointQueueMode.Response
    ) -> StartPointQueueMode.Response:
        return self._answer(response, self._services.start_point_queue_mode())

    def _queue_traj_point(
        self, request: QueueTrajPoint.Request, response: QueueTrajPoint.Response
    ) -> QueueTrajPoint.Response:
        point = request.point
        code = self._services.queue_traj_point(
            QueuedPoint(
                tuple(request.joint_names),
                _nanoseconds(point.time_from_start),
                tuple(point.positions),
                tuple(point.velocities),
            )
        )
        response.result_code.value = code
        response.message = self._queue_message(code)
        return response

    def _queue_message(self, code: int) -> str:
        """MotoROS2's words for a ``queue_traj_point`` answer: a first point's refusal is an
        InitTraj code, worded as InitTraj words it, but for UNSPECIFIED."""
        if code in self._queue_words:
            return self._queue_words[code]
        if code == InitTraj.UNSPECIFIED:
            return UNSPECIFIED
        return self._init_words.get(code, UNSPECIFIED)

    def _reset_error(
        self, request: ResetError.Request, response: ResetError.Response
    ) -> ResetError.Response:
        return self._answer(response, self._services.reset_error())

    def _answer(self, response: _Answered, code: int) -> _Answered:
        response.result_code.value = code
        response.message = self._words.get(code, "")
        return response

    def _reading(self, read: Callable[[int], tuple[int, int]]) -> Callable[[Any, Any], Any]:
        def serve(request: Any, response: Any) -> Any:
            code, value = read(request.address)
            response.value = value if code == 0 else 0
            return self._io_answer(response, code)

        return serve

    def _writing(self, write: Callable[[int, int], int]) -> Callable[[Any, Any], Any]:
        def serve(request: Any, response: Any) -> Any:
            return self._io_answer(response, write(request.address, request.value))

        return serve

    def _io_answer(self, response: Any, code: int) -> Any:
        response.result_code = code
        response.message = self._io_words.get(code, "")
        response.success = code == 0
        return response

    def _select_motion_tool(
        self, request: SelectMotionTool.Request, response: SelectMotionTool.Response
    ) -> SelectMotionTool.Response:
        code = self._services.select_motion_tool(request.group_number, request.tool_number)
        response.result_code.value = code
        response.message = self._selection_words.get(code, "")
        response.success = code == 0
        return response

    def _stop_traj_mode(
        self, request: Trigger.Request, response: Trigger.Response
    ) -> Trigger.Response:
        response.success, response.message = self._services.stop_traj_mode()
        return response

    # -- follow_joint_trajectory ----------------------------------------------------------
    def _follow(self, handle: ServerGoalHandle) -> FollowJointTrajectory.Result:
        """Every goal is accepted; one MotoROS2 refuses is aborted at once with its reason
        (``core.goal``)."""
        if not self._running.acquire(blocking=False):
            return self._refuse(handle, 203, "Already running a trajectory.")
        try:
            return self._run(handle, _goal(handle.request))
        finally:
            self._running.release()

    def _run(self, handle: ServerGoalHandle, goal: Goal) -> FollowJointTrajectory.Result:
        if len(goal.points) > MAX_POINTS:
            return self._refuse(handle, InitTraj.TOO_BIG, self._init_words[InitTraj.TOO_BIG])
        ready = self._services.motion_ready()
        if ready != READY:
            return self._refuse(handle, ready, self._words.get(ready, ""))
        if self._services.modes.mode is not MotionMode.TRAJECTORY:
            wrong = InitTraj.WRONG_MODE
            return self._refuse(handle, wrong, self._init_words[wrong])
        planned = plan(goal, self._names)
        if isinstance(planned, InitTraj):
            return self._refuse(handle, planned, self._init_words.get(planned, ""))
        ending = self._runner.run(
            planned,
            cancelled=lambda: handle.is_cancel_requested,
            feedback=lambda state: handle.publish_feedback(self._feedback(state)),
        )
        result = FollowJointTrajectory.Result()
        result.error_code = ending.error_code
        result.error_string = ending_words(ending, planned, _flat(self._names))
        if handle.is_cancel_requested:
            handle.canceled()
        elif ending.error_code == 0:
            handle.succeed()
        else:
            handle.abort()
        return result

    def _refuse(
        self, handle: ServerGoalHandle, code: int, words: str
    ) -> FollowJointTrajectory.Result:
        result = FollowJointTrajectory.Result()
        result.error_code = error_code(INVALID_GOAL, code)
        result.error_string = words
        handle.abort()
        return result

    def _feedback(self, state: State) -> FollowJointTrajectory.Feedback:
        feedback = FollowJointTrajectory.Feedback()
        feedback.header.stamp = self.node.get_clock().now().to_msg()
        feedback.joint_names = _flat(self._names)
        actual = positions_of(state, self._groups_of_cell)
        desired = [
            value
            for group in self._groups_of_cell
            for value in state.groups[group.index].command_positions[: group.axes]
        ]
        feedback.actual.positions = actual
        feedback.desired.positions = desired
        feedback.error.positions = [want - have for want, have in zip(desired, actual, strict=True)]
        return feedback

    def observed(self) -> bool:
        return self._readers.any()

    def publish(self, values: TopicValues) -> None:
        """Every topic someone subscribes to; a message nobody reads is neither built nor sent
        (rclpy would serialise it for no reader)."""
        read = [self._readers.read(topic) for topic in self._joint_topics]
        status_read = self._readers.read(ROBOT_STATUS)
        tf_read = self._frames is not None and self._readers.read(self._tf_topic)
        if not (any(read) or status_read or tf_read):
            return
        # The values carry CLOCK_MONOTONIC; ROS stamps are the system clock's.
        stamp = divmod(values.sampled_ns + time.time_ns() - time.monotonic_ns(), 10**9)
        if any(read):
            self._publish_joints(values, stamp, read)
        if status_read:
            if values.status != self._status_for:
                self._status_message = _robot_status(values.status)
                self._status_for = values.status
            _stamp(self._status_message.header, stamp)
            self._robot_status.publish(self._status_message)
        if tf_read:
            self._publish_tf(values.sample, stamp)

    def _publish_tf(self, sample: State, stamp: tuple[int, int]) -> None:
        if sample is not self._tf_for and self._frames is not None:
            # A new sample's poses; a resting robot's sample is the one already turned into
            # transforms, sent again.
            transforms = self._frames.transforms(sample)
            self._tf_message = TFMessage(transforms=[_transform(one) for one in transforms])
            self._tf_for = sample
        for transform in self._tf_message.transforms:
            _stamp(transform.header, stamp)
        self._tf.publish(self._tf_message)

    def _publish_joints(
        self, values: TopicValues, stamp: tuple[int, int], read: list[bool]
    ) -> None:
        for index, wanted in enumerate(read):
            if wanted:
                start, end = self._joint_spans[index]
                message = self._joint_messages[index].encode(
                    stamp, values.positions[start:end], values.velocities[start:end]
                )
                self._joint_publishers[index].publish(message)

    def close(self) -> None:
        rclpy.shutdown(context=self._context)  # ends the executor's wait
        if self._serving.is_alive():
            self._serving.join()
        self._executor.shutdown()
        self.node.destroy_node()


class Readers:
    """How many subscriptions match each topic of the face, kept by rclpy's
    publication-matched events (on the executor's thread): the loop reads a number each period
    instead of asking the RMW for each topic. A change rings ``changed``."""

    def __init__(self, changed: Callable[[], None]) -> None:
        self._counts: dict[str, int] = {}
        self._changed = changed

    def events(self, topic: str) -> PublisherEventCallbacks:
        def matched(info: Any) -> None:
            self._counts[topic] = int(info.current_count)
            self._changed()

        return PublisherEventCallbacks(matched=matched)

    def read(self, topic: str) -> bool:
        return self._counts.get(topic, 0) > 0

    def any(self) -> bool:
        return any(count > 0 for count in list(self._counts.values()))


def _stamp(header: Header, stamp: tuple[int, int]) -> None:
    """``stamp`` (seconds, nanoseconds) into a message's header, in place: a new ``Time``
    message, or rclpy's ``Time.to_msg``, costs several times as much, every period."""
    header.stamp.sec, header.stamp.nanosec = stamp


def _robot_status(status: RobotStatusFields) -> RobotStatus:
    """industrial_msgs' RobotStatus takes the state port's ROBOT_STATUS fields as they are: the
    same TriState and RobotMode values."""
    message = RobotStatus()
    message.mode = RobotMode(val=status.mode)
    for field in ("e_stopped", "drives_powered", "motion_possible", "in_motion", "in_error"):
        setattr(message, field, TriState(val=getattr(status, field)))
    message.error_codes = list(error_codes(status))
    return message


def _transform(frames: FrameTransform) -> TransformStamped:
    message = TransformStamped()
    message.header.frame_id = frames.parent
    message.child_frame_id = frames.child
    translation, rotation = message.transform.translation, message.transform.rotation
    translation.x, translation.y, translation.z = frames.translation
    rotation.x, rotation.y, rotation.z, rotation.w = frames.rotation
    return message


def _nanoseconds(duration: Duration) -> int:
    return int(duration.sec) * 1_000_000_000 + int(duration.nanosec)


def _goal(request: FollowJointTrajectory.Goal) -> Goal:
    trajectory = request.trajectory
    return Goal(
        joint_names=tuple(trajectory.joint_names),
        points=tuple(
            GoalPoint(
                _nanoseconds(point.time_from_start),
                tuple(point.positions),
                tuple(point.velocities),
            )
            for point in trajectory.points
        ),
        position_tolerances={
            tolerance.name: tolerance.position for tolerance in request.goal_tolerance
        },
        time_tolerance_ns=_nanoseconds(request.goal_time_tolerance),
    )


def _flat(names: list[list[str]]) -> list[str]:
    return [name for group in names for name in group]
