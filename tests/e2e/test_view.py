"""``motocell view`` against a real cell: a Foxglove WebSocket client (``tests.foxglove_ws``,
written from the protocol's specification) connects, subscribes and decodes what the view
serves, and compares it with the state port; clients that never read or vanish do not hurt it."""

from __future__ import annotations

import os
import re
import signal
import socket
import struct
import subprocess
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect
from websockets.typing import Subprotocol

from motocell.shared.motion.forward_kinematics import Chain, tool_transform
from motocell.shared.ports import free_port
from motocell.shared.protocol.constants import Command, Result
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing.client import Feedback, smooth_move, stream
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell, moving
from motocell.tools.view import OFFERED_BY
from motocell.tools.view_layout import layout_text
from tests.foxglove_ws import SUBPROTOCOL, FoxgloveClient, Received
from tests.frames import foxglove_steps, in_root, pose_matrix, rotation, vector

pytestmark = pytest.mark.cell

FLOAT32_RAD = 2e-7
"""The state port carries float32 (motoros1 §6); the view the float64 the state holds."""
POSE_TOLERANCE_M = 1e-5
"""A flange pose from float32 joints, about a metre from the base: 1e-7 rad x 1 m, and margin."""
MOVE = (0.4, -0.3, 0.3, 0.5, -0.4, 0.6)
STALLED_TICKS = 1000
"""Executor ticks (4 s) a client does not read: with the other topics it subscribed, the
server has more than twice ``tools.view.MESSAGE_BACKLOG`` messages for it, more than its queue
and the sockets' buffers hold."""
DEADLINE_S = 60.0
"""For what an idle machine does at once: a bound for a hang, not a speed."""
EVERY_SAMPLE = "1000"
"""A ``--rate`` above every rate of the cell (ticks at 250 Hz): the view sends each sample, as
the tests of what it sends and of its backlog need."""
CAPPED_HZ = 20.0
READY = re.compile(r"ws://(?P<host>[\d.]+):(?P<port>\d+)")


class View:
    """``motocell view`` as a process: the URL it serves, and its output lines."""

    def __init__(self, cell: RunningCell, *options: str) -> None:
        env = {**os.environ, RUNTIME_DIR_ENV: str(cell.runtime_dir)}
        command = [sys.executable, "-W", "error", "-m", "motocell.tools.cli", "view"]
        command += ["--port", str(free_port()), "--cell", cell.cell.name, *options]
        self.process = subprocess.Popen(
            command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env
        )
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        try:
            wait_until(lambda: self.url is not None, DEADLINE_S, "the view to serve")
        except BaseException:
            self.stop()  # no fixture will: neither the process nor its pipe outlives the test
            raise

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.append(line.rstrip("\n"))

    @property
    def url(self) -> str | None:
        if self.process.poll() is not None:
            raise ChildProcessError(f"the view exited: {self.lines}")
        found = [READY.search(line) for line in list(self.lines)]
        return next((match.group(0) for match in found if match), None)

    def client(
        self, max_queue: int | None = None, receive_buffer: int | None = None
    ) -> FoxgloveClient:
        assert self.url is not None
        return FoxgloveClient(self.url, max_queue=max_queue, receive_buffer=receive_buffer)

    def stop(self) -> int:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
        try:
            return self.process.wait(timeout=10)
        finally:
            if self.process.poll() is None:
                self.process.kill()
                self.process.wait()
            self._reader.join(timeout=5)
            assert self.process.stdout is not None
            self.process.stdout.close()


@pytest.fixture(scope="module")
def layout_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("view") / "layout.json"


@pytest.fixture(scope="module")
def view(cell: RunningCell, layout_file: Path) -> Iterator[View]:
    served = View(cell, "--layout", str(layout_file), "--rate", EVERY_SAMPLE)
    yield served
    assert served.stop() == 0, served.lines


def test_it_writes_the_layout_of_the_cell_it_views(
    view: View, cell: RunningCell, layout_file: Path
) -> None:
    assert layout_file.read_text() == layout_text([cell.cell])
    assert f"wrote the Foxglove layout {layout_file}" in view.lines


def test_it_speaks_foxglove_sdk_v1_and_refuses_a_client_offering_only_the_older_name(
    view: View,
) -> None:
    # What docs/observing.md tells Lichtblick and old Foxglove Studio users.
    assert view.url is not None
    with pytest.raises(InvalidStatus) as refused:
        connect(view.url, subprotocols=[Subprotocol("foxglove.websocket.v1")], open_timeout=10)
    assert refused.value.response.status_code == 400
    wait_until(
        lambda: any(line.endswith(f"handshake failed ({OFFERED_BY})") for line in view.lines),
        DEADLINE_S,
        "the view to say which subprotocol the refused client lacked",
    )
    with connect(view.url, subprotocols=[Subprotocol(SUBPROTOCOL)], open_timeout=10) as client:
        assert client.subprotocol == "foxglove.sdk.v1"


def test_a_second_view_on_its_port_is_one_line_and_status_2(view: View) -> None:
    host, port = view_address(view)
    command = [sys.executable, "-m", "motocell.tools.cli", "view", "--port", str(port)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=30, check=False)
    assert (done.returncode, done.stdout) == (2, "")
    assert done.stderr.splitlines() == [
        f"motocell view: cannot serve Foxglove on {host}:{port}: it is taken by another "
        "process (stop that process, or choose --port N; 0 takes any free port)"
    ]


def topics(cell: RunningCell) -> dict[str, str]:
    name, group = cell.cell.name, cell.cell.groups[0].name
    return {
        "joints": f"/{name}/{group}/joints",
        "transforms": f"/{name}/transforms",
        "scene": f"/{name}/scene",
        "status": f"/{name}/status",
        "robot_status": f"/{name}/robot_status",
        "executor": f"/{name}/executor",
        "tcp": f"/{name}/{group}/tcp",
    }


def subscribed(
    view: View,
    cell: RunningCell,
    *kinds: str,
    max_queue: int | None = None,
    receive_buffer: int | None = None,
) -> FoxgloveClient:
    client = view.client(max_queue, receive_buffer)
    try:
        wanted = {topics(cell)[kind] for kind in kinds}
        advertised = client.wait_for_topics(wanted, DEADLINE_S)
        client.subscribe([advertised[topic] for topic in sorted(wanted)])
    except BaseException:
        # Not the caller's yet: left open, its socket would outlive the test.
        client.close()
        raise
    return client


def test_it_offers_the_cells_topics_and_nothing_to_command(view: View, cell: RunningCell) -> None:
    with view.client() as client:
        advertised = client.wait_for_topics(set(topics(cell).values()), DEADLINE_S)
        assert client.server_info["capabilities"] == []
        assert not {"services", "parameters", "clientPublish"} & set(client.server_info)
    joints = advertised[topics(cell)["joints"]]
    assert (joints.encoding, joints.schema_name) == ("json", "motocell.GroupState")
    transforms = advertised[topics(cell)["transforms"]]
    assert (transforms.encoding, transforms.schema_name) == (
        "protobuf",
        "foxglove.FrameTransforms",
    )
    assert advertised[topics(cell)["scene"]].schema_name == "foxglove.SceneUpdate"


def test_the_scene_draws_every_link_on_its_frame(view: View, cell: RunningCell) -> None:
    group = cell.cell.groups[0]
    with subscribed(view, cell, "scene") as client:
        scene = client.next_message(topics(cell)["scene"], DEADLINE_S).protobuf()
    frames = {entity.frame_id for entity in scene.entities}  # type: ignore[attr-defined]
    prefix = f"{cell.cell.name}/{group.name}"
    # The last link's length lies along the one before (its d), so link6 carries nothing.
    assert frames == {
        f"{prefix}/base",
        *(f"{prefix}/link{n}" for n in range(1, 6)),
        f"{prefix}/flange",
    }
    assert all(entity.frame_locked for entity in scene.entities)  # type: ignore[attr-defined]


def in_cell(transforms: Any, cell: str, group: str, frame_name: str) -> np.ndarray[Any, Any]:
    """A group's frame as a 4x4 pose in the cell's frame, from a FrameTransforms message."""
    return in_root(foxglove_steps(transforms), cell)[f"{cell}/{group}/{frame_name}"]


def same_joints(cycle: Feedback, positions: list[float], axes: int) -> bool:
    port = np.array(cycle.groups[0].positions[:axes])
    return bool(np.allclose(port, positions, rtol=0, atol=FLOAT32_RAD))


def test_joints_and_tool_pose_agree_with_the_state_port(view: View, cell: RunningCell) -> None:
    """Each joint state the view sends while the arm moves is one the state port sent (the same
    snapshot, so zero periods apart), in the same order; each tool pose, and each transform
    tree's flange, is where the kinematics of one of those state port snapshots puts it."""
    group = cell.cell.groups[0]
    axes = group.axes
    with cell.state() as state, cell.motion() as motion:
        state.wait_for(lambda f: f.status is not None, DEADLINE_S)
        with subscribed(view, cell, "joints", "transforms", "tcp") as client:
            reply = motion.command(Command.START_TRAJ_MODE)
            assert (reply.result, reply.subcode) == (Result.SUCCESS, 0)
            start = np.array(state.wait_still().groups[0].positions[:axes])
            trajectory = smooth_move(tuple(start), tuple(start + MOVE), duration=1.0, points=11)
            assert stream(motion, trajectory).points == len(trajectory)
            state.wait_for(lambda f: not same_joints(f, list(start), axes), DEADLINE_S)
            received = client.messages_until(
                lambda found: min(map(len, sent_while_moving(found, cell, start))) >= 20,
                DEADLINE_S,
                "20 joint states, tool poses and transform trees while the arm moves",
            )
        cycles = [c for c in state.cycles if 0 in c.groups]
    moving, tcps, trees = sent_while_moving(received, cell, start)
    matched = [_match(cycles, m.json()["positions"], axes) for m in moving]
    assert matched == sorted(matched), "the view's joint states came out of order"

    # The tool 0 of a cell file without tools is all zero: the TCP is the flange.
    chain = Chain(group.model)
    flanges = chain.flange(np.array([c.groups[0].positions[:axes] for c in cycles]))
    placement = tool_transform([*group.base.xyz, *group.base.rpy])
    for message in tcps[-50:]:
        pose: Any = message.protobuf()
        assert pose.frame_id == f"{cell.cell.name}/{group.name}/base"
        found = pose_matrix(vector(pose.pose.position), rotation(pose.pose.orientation))
        _assert_near_one(flanges, found)
    for message in trees[-50:]:
        tree = message.protobuf()
        _assert_near_one(placement @ flanges, in_cell(tree, cell.cell.name, group.name, "flange"))
        _assert_near_one(placement @ flanges, in_cell(tree, cell.cell.name, group.name, "tcp"))


def sent_while_moving(
    received: list[Received], cell: RunningCell, start: np.ndarray[Any, Any]
) -> tuple[list[Received], list[Received], list[Received]]:
    """The joint states that are not at ``start``, and the tool poses and transform trees."""
    names = topics(cell)
    joints = [m for m in received if m.topic == names["joints"]]
    return (
        [m for m in joints if not np.allclose(m.json()["positions"], start, atol=1e-3)],
        [m for m in received if m.topic == names["tcp"]],
        [m for m in received if m.topic == names["transforms"]],
    )


def _match(cycles: list[Feedback], positions: list[float], axes: int) -> int:
    for index, cycle in enumerate(cycles):
        if same_joints(cycle, positions, axes):
            return index
    raise AssertionError(f"no state port cycle had the joints {positions}")


def _assert_near_one(candidates: np.ndarray[Any, Any], pose: np.ndarray[Any, Any]) -> None:
    """``pose`` is within the tolerance of one of the ``candidates`` (n, 4, 4)."""
    best = np.abs(candidates - pose).max(axis=(1, 2)).min()
    assert best < POSE_TOLERANCE_M, f"no state port snapshot puts the frame at {pose[:3, 3]}"


def test_it_outlives_clients_that_never_read_or_vanish(view: View, cell: RunningCell) -> None:
    joints = topics(cell)["joints"]
    # A client that stops reading its socket once one message waits (websockets' max_queue):
    # the server's queue for it fills while the others go on.
    stalled = subscribed(view, cell, "joints", "transforms", "executor", max_queue=1)
    try:
        with subscribed(view, cell, "joints") as reader:
            reader.next_message(joints, DEADLINE_S)
            # Behaviour, not a rate: the reader goes on being served (the view's rate beside
            # a stalled client is no benchmark figure yet).
            reader.messages_until(
                lambda found: sum(m.topic == joints for m in found) >= 20,
                DEADLINE_S,
                "20 joint states beside a stalled client",
            )
    finally:
        # Gone without a close frame: a reset, as when a laptop drops off the network.
        raw: socket.socket = stalled.connection.socket
        raw.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        raw.close()
        stalled.close()
    with socket.create_connection(view_address(view)):
        pass  # hung up before the WebSocket handshake
    with subscribed(view, cell, "joints") as again:
        assert again.next_message(joints, DEADLINE_S).json()["group_no"] == 0
    assert view.process.poll() is None


def test_a_client_that_never_reads_is_held_a_bounded_backlog(view: View, cell: RunningCell) -> None:
    """The server holds at most ``tools.view.MESSAGE_BACKLOG`` messages for a client that
    stopped reading and drops the oldest past that: once it reads again, ticks the server sent
    meanwhile are missing. A server that kept them all would show none, and grow without
    bound."""
    executor = topics(cell)["executor"]
    # A small receive buffer: the kernel holds little for it, the server's queue fills.
    stalled = subscribed(
        view, cell, "executor", "transforms", "joints", "tcp", max_queue=1, receive_buffer=4096
    )
    try:
        with moving(cell, seconds=8.0), subscribed(view, cell, "executor") as reader:
            sent: list[int] = []
            while len(sent) < STALLED_TICKS:
                sent.append(reader.next_message(executor, DEADLINE_S).json()["tick"])
        kept: list[int] = []
        while not kept or kept[-1] < sent[-1]:
            kept.append(stalled.next_message(executor, DEADLINE_S).json()["tick"])
    finally:
        stalled.close()
    assert set(sent) - set(kept), f"all {len(sent)} ticks kept for a client that did not read"
    assert view.process.poll() is None


def test_each_topic_is_sent_at_most_at_the_rate_asked(cell: RunningCell) -> None:
    """Ticks come at 250 Hz while the arm moves; the view sends at most one per period, each
    the newest that had arrived: of n sent, the n-1 after the first each arrived after the one
    before went out, so n-2 periods fit between the first's and the last's receive times."""
    capped = View(cell, "--rate", f"{CAPPED_HZ:g}")
    try:
        with moving(cell, seconds=3.0), subscribed(capped, cell, "executor") as client:
            received = client.messages_until(
                lambda found: len(found) >= 20, DEADLINE_S, "20 ticks while the arm moves"
            )
    finally:
        assert capped.stop() == 0, capped.lines
    ticks = [m for m in received if m.topic == topics(cell)["executor"]]
    span_s = (ticks[-1].log_time_ns - ticks[0].log_time_ns) / 1e9
    assert len(ticks) - 2 <= CAPPED_HZ * span_s, f"{len(ticks)} ticks in {span_s:.2f} s"
    numbers = [m.json()["tick"] for m in ticks]
    assert numbers == sorted(numbers) and numbers[-1] - numbers[0] > len(numbers), numbers


def view_address(view: View) -> tuple[str, int]:
    assert view.url is not None
    match = READY.search(view.url)
    assert match is not None
    return match.group("host"), int(match.group("port"))
