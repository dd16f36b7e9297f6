"""The ROS 2 face seen by a real ROS 2 client (rclpy over FastDDS, in a process of its own, on a
domain and namespace of this test's and on this host only): MotoROS2's topics, names, types and
QoS, carrying exactly the cell's feedback."""

from __future__ import annotations

import contextlib
import json
import os
import random
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from motocell.shared.bus.catalog import Role
from motocell.shared.motion.forward_kinematics import Chain
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.shared.ros2.interfaces import ensure
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell, TickLog, moving, running_cell

pytestmark = pytest.mark.cell

NAME = "rosface"
DOMAIN = random.randrange(1, 101)
"""A domain of this run's: a ROS 2 test elsewhere on the machine is unlikely to share it, and
the namespace below keeps the names apart if one does."""
NAMESPACE = f"/t{os.getpid()}"
JOINT_TOPICS = ["joint_states", "ctrl_groups/r1/joint_states", "ctrl_groups/s1/joint_states"]
TOPICS = [*JOINT_TOPICS, "tf"]
PROBE = Path(__file__).with_name("ros2_probe.py")
PROBE_TIMEOUT_S = 60.0
"""For what takes a second on an idle machine: a bound for a hang, not a speed."""
CELL_FILE = f"""
name = "{NAME}"
[[groups]]
name = "R1"
model = "arm6"
[[groups]]
name = "S1"
model = "positioner2"
[ros2]
ros_domain_id = {DOMAIN}
node_namespace = "{NAMESPACE}"
"""


@pytest.fixture(scope="module")
def cell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[RunningCell]:
    cell_file = tmp_path_factory.mktemp("face") / "cell.toml"
    cell_file.write_text(CELL_FILE)
    with running_cell(cell_file, attempts=2) as running:
        yield running


@contextlib.contextmanager
def probing(count: int) -> Iterator[dict[str, Any]]:
    """A probe that has seen a message of every topic; on exit, once it has ``count`` of each,
    what it saw (filled in)."""
    interfaces, _ = ensure()  # tf2_msgs is one of the interface packages motocell builds
    env = interfaces.environment({**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    options = ["--count", str(count), "--timeout", str(PROBE_TIMEOUT_S)]
    seen: dict[str, Any] = {}
    # Unbuffered: ``readline`` then takes "ready" alone, byte by byte. A buffered one reads
    # ahead, and ``communicate``, which reads the pipe itself, would lose what it took.
    with subprocess.Popen(
        [sys.executable, str(PROBE), str(DOMAIN), NAMESPACE, *TOPICS, *options],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        bufsize=0,
        env=env,
    ) as process:
        assert process.stdout is not None
        try:
            assert process.stdout.readline() == b"ready\n", "the probe saw no message"
            yield seen
            out, err = process.communicate(timeout=PROBE_TIMEOUT_S + 30)
        finally:
            if process.poll() is None:
                process.kill()
    assert process.returncode == 0, err.decode()
    seen.update(json.loads(out))
    for topic in TOPICS:
        assert len(seen["seen"][topic]) >= count, (topic, err.decode())


def probe(count: int) -> dict[str, Any]:
    with probing(count) as seen:
        pass
    return seen


def wheel_hash(type_name: str) -> str:
    """The type hash rosidl wrote for ``type_name`` when the message package was built."""
    package, kind, message = type_name.split("/")
    described = json.loads(
        (Path(sys.prefix) / "share" / package / kind / f"{message}.json").read_text()
    )
    (entry,) = [h for h in described["type_hashes"] if h["type_name"] == type_name]
    return str(entry["hash_string"])


def test_the_graph_is_motoros2s_names_types_and_qos(cell: RunningCell) -> None:
    seen = probe(count=3)
    assert ["motoman_rosface", NAMESPACE] in seen["graph"]["nodes"]
    for topic in JOINT_TOPICS:
        [publisher] = seen["graph"]["publishers"][topic]
        assert (publisher["node"], publisher["namespace"]) == ("motoman_rosface", NAMESPACE)
        assert publisher["type"] == "sensor_msgs/msg/JointState"
        assert publisher["hash"] == wheel_hash("sensor_msgs/msg/JointState")
        assert publisher["reliability"] == "BEST_EFFORT", "MotoROS2's sensor_data default"
    [tf] = seen["graph"]["publishers"]["tf"]
    assert (tf["node"], tf["type"]) == ("motoman_rosface", "tf2_msgs/msg/TFMessage")
    assert tf["reliability"] == "RELIABLE", "MotoROS2's default for tf, which RViz needs"


def test_tf_holds_the_robots_frames_at_the_state_ports_positions(cell: RunningCell) -> None:
    """The arm's four frames (the positioner has none), its flange where the kinematics put
    it for the positions the state port reports, every transform of a message stamped alike."""
    with cell.state() as state:
        port = state.wait_still()
    message = probe(count=3)["seen"]["tf"][-1]
    by_child = {one["child"]: one for one in message["transforms"]}
    assert [(one["parent"], one["child"]) for one in message["transforms"]] == [
        ("world", "r1/base"),
        ("r1/base", "r1/flange"),
        ("r1/flange", "r1/tool0"),
        ("r1/flange", "r1/tcp_0"),
    ]
    flange = Chain(cell.cell.groups[0].model).flange(port.groups[0].positions[:6])
    assert np.allclose(by_child["r1/flange"]["translation"], flange[:3, 3], atol=1e-5)
    assert len({one["stamp_ns"] for one in message["transforms"]}) == 1


def test_at_rest_joint_states_are_the_state_ports_positions_under_motoros2s_names(
    cell: RunningCell,
) -> None:
    with cell.state() as state:
        port = state.wait_still()
    seen = probe(count=20)["seen"]
    arm, positioner = (port.groups[g].positions[:axes] for g, axes in ((0, 6), (1, 2)))
    for message in seen["joint_states"]:
        assert message["name"] == [f"group_1/joint_{a}" for a in range(1, 7)] + [
            "group_2/joint_1",
            "group_2/joint_2",
        ]
        # The state port carries float32.
        assert np.allclose(message["position"], [*arm, *positioner], rtol=0, atol=1e-6)
        assert message["effort"] == [], "the simulated drives have no torque feedback"
    assert seen["ctrl_groups/s1/joint_states"][-1]["name"] == ["group_2/joint_1", "group_2/joint_2"]
    # At rest the face holds the newest state at its 10 ms period, stamped as it publishes.
    stamps = [message["stamp_ns"] for message in seen["joint_states"]]
    assert stamps == sorted(stamps) and len(set(stamps)) == len(stamps)


def test_while_moving_every_joint_state_is_one_ticks_feedback(cell: RunningCell) -> None:
    axis_maps = [AxisMap(group) for group in cell.cell.groups]
    session = cell.session(Role.OBSERVER)
    ticks = TickLog(session, cell.keys)
    try:
        with probing(count=200) as seen, moving(cell, seconds=2.0):
            pass
    finally:
        ticks.subscriber.undeclare()
        session.close()
    fed_back = {
        tuple(
            value
            for axis_map, group in zip(axis_maps, tick.groups, strict=False)
            for value in axis_map.pulses_to_ros(group.feedback_pulses).tolist()
        )
        for tick in ticks.since(0)
    }
    moved = [tuple(m["position"]) for m in seen["seen"]["joint_states"]]
    assert len(set(moved)) > 10, "the probe saw the arm move"
    strays = [position for position in moved if position not in fed_back]
    assert strays == [], f"{len(strays)} of {len(moved)} joint states match no tick"


def test_motocell_ps_lists_the_face(cell: RunningCell) -> None:
    """Once its node is up: the cell is ready without it (the controller does not wait for it)."""
    env = {**os.environ, RUNTIME_DIR_ENV: str(cell.runtime_dir)}

    def face_listed() -> bool:
        done = subprocess.run(
            [sys.executable, "-m", "motocell.tools.cli", "ps"],
            env=env,
            capture_output=True,
            text=True,
            timeout=PROBE_TIMEOUT_S,
            check=True,
        )
        rows = [line.split()[:3] for line in done.stdout.split("\n\n")[0].splitlines()[1:]]
        return [NAME, "ros2", "-"] in rows

    wait_until(face_listed, PROBE_TIMEOUT_S, "motocell ps to list the face")
