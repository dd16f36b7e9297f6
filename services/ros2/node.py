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
from typing import TypeVar

import rclpy
from builtin_interfaces.msg import Time as TimeMsg
from industrial_msgs.msg import RobotMode, RobotStatus, TriState
from motoros2_interfaces.msg import MotionReadyEnum
from motoros2_interfaces.srv import ResetError, StartTrajMode
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions
from rclpy.time import Time
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from motocell.services.ros2.core.topics import (
    JointValues,
    TopicValues,
    ctrl_group_topic,
    error_codes,
)
from motocell.services.ros2.motoros2_services import Motoros2Services
from motocell.shared.bus.schemas import RobotStatusFields
from motocell.shared.config import Cell, Ros2Face

_Answered = TypeVar("_Answered", StartTrajMode.Response, ResetError.Response)

DISCOVERY_RANGE_ENV = "ROS_AUTOMATIC_DISCOVERY_RANGE"
"""Read by the RMW when rclpy starts: LOCALHOST keeps the face on this host."""


def discovery_range(face: Ros2Face) -> str:
    return "SUBNET" if face.open_discovery else "LOCALHOST"


SPIN_S = 0.1
"""How long the executor waits for work before it looks at the stop flag again."""


def _motion_ready_words() -> dict[int, str]:
    """MotoROS2's words for each ``MotionReadyEnum`` value, from the interface itself."""
    return {
        getattr(MotionReadyEnum, name): getattr(MotionReadyEnum, f"{name}_STR")
        for name in dir(MotionReadyEnum)
        if name.isupper() and hasattr(MotionReadyEnum, f"{name}_STR")
    }


class FaceNode:
    """``loop.Topics`` over an rclpy node in a context of its own, with MotoROS2's services."""

    def __init__(self, cell: Cell, face: Ros2Face, services: Motoros2Services) -> None:
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
        self._joint_states = self.node.create_publisher(JointState, "joint_states", qos)
        self._groups = [
            self.node.create_publisher(JointState, ctrl_group_topic(group), qos)
            for group in cell.groups
        ]
        self._robot_status = self.node.create_publisher(RobotStatus, "robot_status", qos)
        self._services = services
        self._words = _motion_ready_words()
        self.node.create_service(StartTrajMode, "start_traj_mode", self._start_traj_mode)
        self.node.create_service(Trigger, "stop_traj_mode", self._stop_traj_mode)
        self.node.create_service(ResetError, "reset_error", self._reset_error)
        self._executor = SingleThreadedExecutor(context=self._context)
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

    def _reset_error(
        self, request: ResetError.Request, response: ResetError.Response
    ) -> ResetError.Response:
        return self._answer(response, self._services.reset_error())

    def _answer(self, response: _Answered, code: int) -> _Answered:
        response.result_code.value = code
        response.message = self._words.get(code, "")
        return response

    def _stop_traj_mode(
        self, request: Trigger.Request, response: Trigger.Response
    ) -> Trigger.Response:
        response.success, response.message = self._services.stop_traj_mode()
        return response

    def publish(self, values: TopicValues) -> None:
        # The values carry CLOCK_MONOTONIC; ROS stamps are the system clock's.
        stamp = Time(nanoseconds=values.sampled_ns + time.time_ns() - time.monotonic_ns()).to_msg()
        self._joint_states.publish(_joint_state(values.joint_states, stamp))
        for publisher, group in zip(self._groups, values.groups, strict=True):
            publisher.publish(_joint_state(group, stamp))
        self._robot_status.publish(_robot_status(values.status, stamp))

    def close(self) -> None:
        rclpy.shutdown(context=self._context)  # ends the executor's wait
        if self._serving.is_alive():
            self._serving.join()
        self._executor.shutdown()
        self.node.destroy_node()


def _robot_status(status: RobotStatusFields, stamp: TimeMsg) -> RobotStatus:
    """industrial_msgs' RobotStatus takes the state port's ROBOT_STATUS fields as they are: the
    same TriState and RobotMode values."""
    message = RobotStatus()
    message.header.stamp = stamp
    message.mode = RobotMode(val=status.mode)
    for field in ("e_stopped", "drives_powered", "motion_possible", "in_motion", "in_error"):
        setattr(message, field, TriState(val=getattr(status, field)))
    message.error_codes = list(error_codes(status))
    return message


def _joint_state(values: JointValues, stamp: TimeMsg) -> JointState:
    message = JointState()
    message.header.stamp = stamp
    message.name = list(values.names)
    message.position = list(values.positions)
    message.velocity = list(values.velocities)
    return message
