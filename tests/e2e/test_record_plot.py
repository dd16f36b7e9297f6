"""``motocell record`` against a real cell while it moves, then ``motocell plot`` of that file;
and ``motocell record`` of an open bus, where keys outside the catalogue travel too."""

from __future__ import annotations

import json
import os
import signal
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure
from matplotlib.image import imread
from matplotlib.lines import Line2D
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel
from mcap.records import Message as McapMessage
from mcap.stream_reader import StreamReader

from motocell.shared.bus.keys import CellKeys
from motocell.shared.bus.schemas import State
from motocell.shared.bus.session import open_session
from motocell.shared.motion.forward_kinematics import Chain, pose
from motocell.shared.motion.kinematics import AxisMap
from motocell.shared.ports import free_port
from motocell.shared.protocol.constants import Command, Result
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing.client import smooth_move, stream
from motocell.testing.processes import wait_until
from motocell.testing.running_cell import RunningCell, SampleLog, router_on_free_port
from motocell.tools.plotting import GAP_PERIODS, plot_recording
from motocell.tools.record import FLUSH_S
from motocell.tools.recording import Recording as RecordingFile

pytestmark = pytest.mark.cell

MOVE = (0.3, -0.2, 0.25, 0.4, -0.3, 0.5)
"""Joint 1 ends apart from every other joint, so its colour stays visible in the plot."""
UNKNOWN_PAYLOAD = b"\x93\x01\x02\x03"  # msgpack [1, 2, 3]
TOLERANCE_RAD = 1e-4


def record_command(out: Path, *extra: str) -> list[str]:
    # `motocell record`, with -W error so the recorder itself is warning-free too.
    return [sys.executable, "-W", "error", "-m", "motocell.tools.cli", "record", str(out), *extra]


@dataclass
class Recording:
    path: Path
    keys: CellKeys
    start: np.ndarray[Any, np.dtype[np.float64]]
    goal: np.ndarray[Any, np.dtype[np.float64]]
    stdout: list[str]
    returncode: int


class Lines:
    """Every line a subprocess prints, collected by a thread so the test can wait on them."""

    def __init__(self, process: subprocess.Popen[str]) -> None:
        assert process.stdout is not None
        self.lines: list[str] = []
        self._stdout = process.stdout
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _read(self) -> None:
        for line in self._stdout:
            self.lines.append(line.rstrip("\n"))

    def __contains__(self, line: str) -> bool:
        return line in list(self.lines)

    def started_with(self, prefix: str) -> bool:
        return any(line.startswith(prefix) for line in list(self.lines))


class Recorder:
    """``motocell record`` running as a process: its output lines, and a stop as by Ctrl-C.
    On leaving, a recorder that has not stopped is killed."""

    def __init__(self, command: list[str], env: dict[str, str] | None = None) -> None:
        self.process = subprocess.Popen(command, stdout=subprocess.PIPE, text=True, env=env)
        self.stdout = Lines(self.process)

    def __enter__(self) -> Recorder:
        return self

    def stop(self) -> int:
        self.process.send_signal(signal.SIGINT)
        return self.process.wait(timeout=10)

    def __exit__(self, *exc_info: object) -> None:
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()
        self.stdout.thread.join(timeout=5)
        assert self.process.stdout is not None
        self.process.stdout.close()


@pytest.fixture(scope="module")
def recording(cell: RunningCell, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Recording]:
    out = tmp_path_factory.mktemp("record") / "cell.mcap"
    keys = cell.keys
    axis_map = AxisMap(cell.cell.groups[0])
    # No endpoint, no credentials: the recorder finds the cell by name in the registry its
    # launcher wrote, as it would a cell started on this machine.
    env = {**os.environ, RUNTIME_DIR_ENV: str(cell.runtime_dir)}
    with Recorder(record_command(out, "--cell", cell.cell.name), env) as recorder:
        stdout = recorder.stdout
        # A state sample has reached the recorder, so its subscription is live before the
        # robot moves: the recording starts at rest.
        wait_until(
            lambda: f"+ {keys.state} (json, State)" in stdout, 15.0, "the first recorded state"
        )
        with cell.motion() as motion, cell.state() as state:
            reply = motion.command(Command.START_TRAJ_MODE)
            assert (reply.result, reply.subcode) == (Result.SUCCESS, 0)
            start = np.array(state.wait_still().groups[0].positions[: axis_map.axes])
            goal = start + np.array(MOVE)
            trajectory = smooth_move(tuple(start), tuple(goal), duration=1.0, points=11)
            result = stream(motion, trajectory)
            assert result.points == len(trajectory), result.last_reply
            goal_pulses = axis_map.ros_to_pulses(goal)
            state.wait_for(
                lambda f: (
                    f.status is not None
                    and f.status.in_motion == 0
                    and np.array_equal(
                        axis_map.ros_to_pulses(np.array(f.groups[0].positions[: axis_map.axes])),
                        goal_pulses,
                    )
                ),
                timeout=10.0,
            )
            # Ten more state cycles at the goal have gone out over Zenoh (the gateway relays
            # them after the recorder's router hop), so the recording ends at rest too.
            arrived = len(state.cycles)
            wait_until(lambda: len(state.cycles) >= arrived + 10, 5.0, "states at the goal")
        returncode = recorder.stop()
    yield Recording(out, keys, start, goal, stdout.lines, returncode)


def publish_unknown(endpoint: str, key: str, stdout: Lines) -> None:
    """Publish on a key the catalogue does not know until the recorder has a channel for it
    (a put can race the router learning of the recorder's subscription)."""
    session = open_session("client", [endpoint], wait=False)
    try:
        deadline = time.monotonic() + 60.0  # a bound for a hang, not a speed
        while f"+ {key} (msgpack, msgpack, not in the catalogue or not decodable)" not in stdout:
            assert time.monotonic() < deadline, "the recorder never recorded the unknown key"
            session.put(key, UNKNOWN_PAYLOAD)
            time.sleep(0.05)
    finally:
        session.close()


def test_recording_is_a_valid_mcap_of_the_motion(recording: Recording) -> None:
    assert recording.returncode == 0, recording.stdout
    (said,) = [line for line in recording.stdout if line.startswith(f"wrote {recording.path}: ")]

    with recording.path.open("rb") as file:
        reader = make_reader(file, validate_crcs=True)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        channels = {channel.topic: channel for channel in summary.channels.values()}
        keys = recording.keys
        for key in (keys.state, keys.executor_tick, keys.controller_status, keys.group_queue(0)):
            assert key in channels, sorted(channels)
            channel = channels[key]
            assert channel.message_encoding == "json"
            schema = summary.schemas[channel.schema_id]
            assert schema.encoding == "jsonschema"
            assert json.loads(schema.data)["type"] == "object"
        # A secured cell carries only the catalogue's keys: nobody may put anything else.
        on_keys = [c for c in channels.values() if c.topic.startswith("motocell/")]
        assert {channel.message_encoding for channel in on_keys} == {"json"}
        # Beside the keys, what `motocell view` serves, for Foxglove's panels.
        cell, group = keys.cell, "R1"
        view = {
            f"/{cell}/{group}/joints": ("json", "motocell.GroupState"),
            f"/{cell}/{group}/tcp": ("protobuf", "foxglove.PoseInFrame"),
            f"/{cell}/status": ("json", "motocell.ControllerStatus"),
            f"/{cell}/executor": ("json", "motocell.ExecutorTick"),
            f"/{cell}/transforms": ("protobuf", "foxglove.FrameTransforms"),
            f"/{cell}/scene": ("protobuf", "foxglove.SceneUpdate"),
        }
        for topic, (encoding, schema_name) in view.items():
            assert topic in channels, sorted(channels)
            channel = channels[topic]
            schema = summary.schemas[channel.schema_id]
            assert (channel.message_encoding, schema.name) == (encoding, schema_name)

        last_log_time: dict[int, int] = {}
        counts: dict[int, int] = {}
        for schema_, channel, message in reader.iter_messages(log_time_order=False):
            # File order is arrival order: per channel, log times never go back.
            assert message.log_time >= last_log_time.get(channel.id, 0), channel.topic
            assert message.publish_time == message.log_time
            last_log_time[channel.id] = message.log_time
            counts[channel.id] = counts.get(channel.id, 0) + 1
            assert schema_ is not None
            if channel.message_encoding != "json":
                continue
            payload = json.loads(message.data)
            assert set(payload) == set(json.loads(schema_.data)["properties"]), channel.topic
        assert counts == dict(summary.statistics.channel_message_counts)
    # The closing summary counts what the file holds: the keys' channels and the view's.
    total = sum(counts.values())
    assert said.startswith(f"wrote {recording.path}: {total} messages on {len(channels)} channels")

    states = [p for key, _, p in RecordingFile(recording.path).messages() if key == keys.state]
    feedback = np.array([s["groups"][0]["positions"] for s in states])
    np.testing.assert_allclose(feedback[0], recording.start, rtol=0, atol=TOLERANCE_RAD)
    np.testing.assert_allclose(feedback[-1] - feedback[0], MOVE, rtol=0, atol=TOLERANCE_RAD)
    moving = np.unique(feedback, axis=0)
    assert len(moving) >= 50, "100 Hz state over a 1 s move records about 100 distinct positions"


def test_the_recorded_state_carries_the_arm_poses(recording: Recording, cell: RunningCell) -> None:
    """Every recorded state holds the arm's flange and TCP (tool 0, all zero: the flange) at the
    feedback and at the commanded position, as the kinematics give them for its joints."""
    chain = Chain(cell.cell.groups[0].model)
    states = [
        p for key, _, p in RecordingFile(recording.path).messages() if key == recording.keys.state
    ]
    for state in states:
        group = state["groups"][0]
        assert group["tool"] == 0
        for joints, flange, tcp in (
            (group["positions"], group["flange"], group["tcp"]),
            (group["command_positions"], group["command_flange"], group["command_tcp"]),
        ):
            expected = pose(chain.flange(joints))
            for recorded in (flange, tcp):
                np.testing.assert_allclose(recorded["position"], expected.position, atol=1e-12)
                np.testing.assert_allclose(
                    recorded["orientation"], expected.orientation, atol=1e-12
                )
    first, last = states[0]["groups"][0]["tcp"], states[-1]["groups"][0]["tcp"]
    assert np.linalg.norm(np.subtract(last["position"], first["position"])) > 0.05


def lines_by_gid(figure: Figure) -> dict[str, Line2D]:
    return {
        str(line.get_gid()): line
        for ax in figure.axes
        for line in ax.get_lines()
        if line.get_gid() is not None
    }


def drawn(line: Line2D, breaks: int) -> tuple[np.ndarray[Any, Any], np.ndarray[Any, Any]]:
    """The points of ``line`` without the ``breaks`` NaNs that lift its pen (x and y both)."""
    x, y = np.asarray(line.get_xdata()), np.asarray(line.get_ydata())
    lifted = np.isnan(y)
    np.testing.assert_array_equal(np.isnan(x), lifted)
    assert lifted.sum() == breaks
    return x[~lifted], y[~lifted]


def test_plot_draws_the_recorded_series(recording: Recording, tmp_path: Path) -> None:
    png = tmp_path / "cell.png"
    figure = plot_recording(RecordingFile(recording.path), png)

    image = imread(png)
    width, height = np.round(figure.get_size_inches() * figure.dpi).astype(int)
    assert image.shape[:2] == (height, width) == (1250, 1200)  # 5 panels of 2.5 in, 100 dpi
    background = np.all(image[..., :3] > 0.98, axis=-1)
    assert background.mean() < 0.97, "the image is (nearly) blank"

    records = list(RecordingFile(recording.path).messages())
    t0 = records[0][1]
    keys = recording.keys
    states = [(t, p) for key, t, p in records if key == keys.state]
    ticks = [(t, p) for key, t, p in records if key == keys.executor_tick]
    state_s = np.array([(t - t0) / 1e9 for t, _ in states])
    tick_s = np.array([(t - t0) / 1e9 for t, _ in ticks])
    lines = lines_by_gid(figure)
    for kind, field in (("commanded", "command_positions"), ("feedback", "positions")):
        line = lines[f"group0/joint0/{kind}"]
        expected = [p["groups"][0][field][0] for _, p in states]
        np.testing.assert_allclose(np.asarray(line.get_xdata()), state_s, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(np.asarray(line.get_ydata()), expected)
    error = lines["group0/joint0/following_error"]
    expected = [
        (p["groups"][0]["command_positions"][0] - p["groups"][0]["positions"][0]) * 1e3
        for _, p in states
    ]
    np.testing.assert_allclose(np.asarray(error.get_ydata()), expected, rtol=0, atol=1e-12)
    assert max(np.abs(expected)) > 0, "the servo lags while moving"
    assert lines["group0/joint0/commanded"].get_linestyle() == "--"
    assert lines["group0/joint0/velocity/commanded"].get_linestyle() == "--"
    assert lines["group0/joint0/feedback"].get_linestyle() == "-"
    # The tick panels lift the pen after each tick that the next does not follow within
    # GAP_PERIODS (a rest, a resting tick sent again), and draw every tick.
    steps = np.diff([p["tick"] for _, p in ticks])
    breaks = int(np.count_nonzero((steps < 1) | (steps > GAP_PERIODS)))
    lateness = drawn(lines["lateness"], breaks)
    np.testing.assert_allclose(lateness[0], tick_s, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(lateness[1], [p["lateness_ns"] / 1e3 for _, p in ticks])
    depth = drawn(lines["group0/depth"], breaks)
    np.testing.assert_allclose(depth[0], tick_s, rtol=0, atol=1e-9)
    depths = [p["groups"][0]["depth"] for _, p in ticks]
    np.testing.assert_array_equal(depth[1], depths)
    assert max(depths) > 0, "streaming a trajectory fills the executor's queue"

    # Joint 1's colour is drawn inside the position panel (display y runs up, image rows down).
    feedback = lines["group0/joint0/feedback"]
    axes = feedback.axes
    assert axes is not None
    box = axes.get_window_extent()
    inside = image[
        int(height - box.y1) + 2 : int(height - box.y0) - 2, int(box.x0) + 2 : int(box.x1) - 2, :3
    ]
    colour = np.array(to_rgb(feedback.get_color()))
    matching = np.all(np.abs(inside - colour) < 0.02, axis=-1)
    assert matching.sum() > 50, "joint 1's line is not visible in the position panel"


KILLED_AFTER_S = (0.3, 0.8, 1.4, 3.0)
"""When each recorder is killed, counted in state periods published after its first state
reached it: within its first flush period, around the next ones, and well after."""


def test_a_recorder_killed_at_any_moment_keeps_all_but_the_last_flush_period(
    cell: RunningCell, tmp_path: Path
) -> None:
    """Killed outright (SIGKILL) from its first sample on, a recording holds its start, and
    loses no more than ``FLUSH_S`` and one period of margin before the kill. Measured in the
    states the cell published, as another observer saw them: not in wall-clock time, which a
    loaded machine stretches for the recorder and the cell alike."""
    keys = cell.keys
    period_s = cell.cell.state_period_ns / 1e9
    lost_at_most = round(2 * FLUSH_S / period_s)
    session = cell.session()
    published = SampleLog(session, keys.state, State)
    files = []
    try:
        # A state client connected: the broadcaster publishes a state every state period.
        with cell.state():
            wait_until(lambda: len(published) > 0, 30.0, "a published state")
            for after_s in KILLED_AFTER_S:
                out = tmp_path / f"killed-{after_s}.mcap"
                began, killed = _record_and_kill(cell, out, published, after_s / period_s)
                files.append(out)

                recording = RecordingFile(out)
                messages = list(recording.messages())
                assert recording.cut, after_s
                # Its first sample (whichever key brought it) went to the file at once.
                assert messages, f"killed {after_s} s in, the file holds nothing"
                seqs = [p["seq"] for key, _, p in messages if key == keys.state]
                if seqs:  # from its start: the states before it subscribed are not its own
                    assert seqs[0] <= began + round(FLUSH_S / period_s), (after_s, seqs, began)
                    assert seqs == list(range(seqs[0], seqs[-1] + 1)), f"a gap, {after_s} s in"
                # The states it held up to (none yet: those up to the one it began with).
                held = seqs[-1] if seqs else began - 1
                assert killed - held <= lost_at_most, (after_s, (killed - held) * period_s)
                # The mcap package's streaming reader reads it too, up to the cut.
                assert _streamed_states(out, keys.state) == len(seqs), after_s
    finally:
        published.subscriber.undeclare()
        session.close()

    plotted = subprocess.run(
        [sys.executable, "-m", "motocell.tools.cli", "plot", str(files[-1])],
        check=False,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert plotted.returncode == 0, plotted
    assert plotted.stderr == (
        f"motocell plot: {files[-1]}: cut short, its recorder did not close it (killed, or a "
        "full disk); plotted what it holds\n"
    )

    # Repaired, it opens in the indexed reader too, with every state it held.
    fixed = tmp_path / "fixed.mcap"
    repaired = subprocess.run(
        [*record_command(fixed), "--repair", str(files[-1])],
        check=False,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert repaired.returncode == 0, repaired
    with fixed.open("rb") as file:
        reader = make_reader(file, validate_crcs=True)
        states = [m for _, c, m in reader.iter_messages(topics=[keys.state])]
    assert len(states) == _streamed_states(files[-1], keys.state)


def _record_and_kill(
    cell: RunningCell, out: Path, published: SampleLog[State], periods: float
) -> tuple[int, int]:
    """Records ``cell`` into ``out`` and kills the recorder outright ``periods`` state periods
    after its first state: the sequence numbers published then, and at the kill."""
    env = {**os.environ, RUNTIME_DIR_ENV: str(cell.runtime_dir)}
    with Recorder(record_command(out, "--cell", cell.cell.name), env) as recorder:
        # Printed as its first state is written: the recording has begun.
        first = f"+ {cell.keys.state} (json, State)"
        wait_until(lambda: first in recorder.stdout, 30.0, "the first recorded state")
        began = _last_seq(published)
        kill_at = began + round(periods)
        wait_until(lambda: _last_seq(published) >= kill_at, 30.0, "states published")
        killed = _last_seq(published)
        recorder.process.kill()
        recorder.process.wait()
    return began, killed


def _last_seq(published: SampleLog[State]) -> int:
    return published.since(len(published) - 1)[0].seq


def _streamed_states(path: Path, key: str) -> int:
    """The states ``mcap``'s StreamReader reads before the cut, where it raises."""
    topics: dict[int, str] = {}
    count = 0
    with path.open("rb") as file:
        records = StreamReader(file).records
        with pytest.raises((McapError, struct.error)):  # the cut: no footer, maybe half a chunk
            for record in records:
                if isinstance(record, Channel):
                    topics[record.id] = record.topic
                elif isinstance(record, McapMessage) and topics.get(record.channel_id) == key:
                    count += 1
    return count


def test_record_without_a_router_fails_fast_and_clearly(tmp_path: Path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    out = tmp_path / "none.mcap"
    # Without waiting for a router (it would wait forever): the deadline is only a safety net.
    command = record_command(out, "--zenoh-connect", endpoint)
    result = subprocess.run(command, check=False, capture_output=True, text=True, timeout=15)
    assert result.returncode == 1, result
    assert result.stderr.startswith(f"motocell record: no Zenoh router answers at {endpoint}")
    assert result.stderr.count("\n") == 1, result.stderr
    assert not out.exists(), "a failed start leaves no empty recording behind"


def test_an_open_bus_is_recorded_whole_keys_outside_the_catalogue_too(tmp_path: Path) -> None:
    out = tmp_path / "open.mcap"
    unknown_key = "motocell/lab/observer/note"
    with ExitStack() as stack:
        endpoint = stack.enter_context(router_on_free_port())
        recorder = stack.enter_context(Recorder(record_command(out, "--zenoh-connect", endpoint)))
        started = recorder.stdout.started_with
        wait_until(lambda: started("recording "), 15.0, "the recorder to start")
        publish_unknown(endpoint, unknown_key, recorder.stdout)
        assert recorder.stop() == 0
    with out.open("rb") as file:
        reader = make_reader(file, validate_crcs=True)
        messages = list(reader.iter_messages())
    assert messages, "the unknown key was recorded"
    for schema, channel, message in messages:
        assert (channel.topic, channel.message_encoding) == (unknown_key, "msgpack")
        # No schema: MCAP's empty schema encoding, for a self-describing message encoding.
        assert schema is not None and (schema.encoding, schema.data) == ("", b"")
        assert message.data == UNKNOWN_PAYLOAD
