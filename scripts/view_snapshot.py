"""A picture of what ``motocell view`` shows, for the README, from a real run; Foxglove itself
needs a desktop.

Starts the dual-arm-positioner sample cell (``testing.running_cell``), runs ``motocell record``
on it (which writes the same channels ``motocell view`` serves), moves both arms and the
positioner with MOTO_JOINT_TRAJ_PT_FULL_EX as motoman_driver does, stops the recording, then
draws the last ``/dual/transforms`` message with the ``/dual/scene`` geometry, decoded from the
file with the schemas in it, using matplotlib: a rendering of the view's data, not a
screenshot of Foxglove.

    .venv/bin/python scripts/view_snapshot.py docs/images/view-dual.png
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from mcap.reader import make_reader

from motocell.shared.protocol.constants import Command
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing.client import smooth_move, stream_ex
from motocell.testing.running_cell import running_cell
from tests.foxglove_ws import protobuf_class
from tests.frames import foxglove_steps, in_root, pose_matrix, rotation, vector

GOALS = {
    0: (0.6, 0.5, 0.3, 0.0, -0.6, 0.0),
    1: (-0.5, 0.6, 0.3, -0.9, 0.0, 0.7, 0.0),
    2: (0.6, 1.2),
}


def record_a_move(out: Path) -> None:
    with running_cell("dual-arm-positioner") as cell:
        env = {**os.environ, RUNTIME_DIR_ENV: str(cell.runtime_dir)}
        command = [sys.executable, "-m", "motocell.tools.cli", "record", str(out)]
        recorder = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, text=True)
        try:
            assert recorder.stdout is not None
            for line in recorder.stdout:
                if "(json, State)" in line:
                    break
            with cell.motion() as motion, cell.state() as state:
                motion.command(Command.START_TRAJ_MODE)
                still = state.wait_still()
                moves = {
                    group: smooth_move(
                        still.groups[group].positions[: len(goal)], goal, duration=2.0, points=11
                    )
                    for group, goal in GOALS.items()
                }
                stream_ex(motion, moves)
                time.sleep(0.5)
                state.wait_still(10.0)
        finally:
            recorder.send_signal(signal.SIGINT)
            recorder.wait(timeout=20)


def last_scene(path: Path, cell: str) -> tuple[Any, Any]:
    """The last transforms and scene messages of ``cell`` in the recording, decoded."""
    found: dict[str, Any] = {}
    with path.open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages():
            if channel.topic in (f"/{cell}/transforms", f"/{cell}/scene") and schema:
                decoded = protobuf_class(schema.name, schema.data).FromString(message.data)
                found[channel.topic] = decoded
    return found[f"/{cell}/transforms"], found[f"/{cell}/scene"]


def cylinder(ax: Any, pose: np.ndarray[Any, Any], primitive: Any, colour: Any) -> None:
    """A cylinder about its own z, ``size`` its bounding box, drawn as a surface."""
    radius, length = primitive.size.x / 2, primitive.size.z
    theta, height = np.meshgrid(np.linspace(0, 2 * np.pi, 24), np.array([-0.5, 0.5]) * length)
    local = np.stack([radius * np.cos(theta), radius * np.sin(theta), height, np.ones_like(height)])
    world = pose @ pose_matrix(
        vector(primitive.pose.position), rotation(primitive.pose.orientation)
    )
    points = np.tensordot(world, local, axes=1)
    ax.plot_surface(points[0], points[1], points[2], color=colour, shade=True, linewidth=0)


def cube(ax: Any, pose: np.ndarray[Any, Any], primitive: Any, colour: Any) -> None:
    half = np.array([primitive.size.x, primitive.size.y, primitive.size.z]) / 2
    world = pose @ pose_matrix(
        vector(primitive.pose.position), rotation(primitive.pose.orientation)
    )
    for axis in range(3):
        for sign in (-1, 1):
            u, v = [a for a in range(3) if a != axis]
            grid_u, grid_v = np.meshgrid([-1, 1], [-1, 1])
            corners = np.zeros((4, 2, 2))
            corners[axis] = sign * half[axis]
            corners[u], corners[v] = grid_u * half[u], grid_v * half[v]
            corners[3] = 1
            points = np.tensordot(world, corners, axes=1)
            ax.plot_surface(points[0], points[1], points[2], color=colour, linewidth=0)


def render(transforms: Any, scene: Any, cell: str, out: Path) -> None:
    poses = in_root(foxglove_steps(transforms), cell)
    figure = Figure(figsize=(8, 6.5), dpi=110, layout="tight")
    FigureCanvasAgg(figure)
    ax = figure.add_subplot(projection="3d")
    for entity in scene.entities:
        pose = poses[entity.frame_id]
        for primitive in entity.cylinders:
            colour = (primitive.color.r, primitive.color.g, primitive.color.b)
            cylinder(ax, pose, primitive, colour)
        for primitive in entity.cubes:
            cube(ax, pose, primitive, (primitive.color.r, primitive.color.g, primitive.color.b))
    for frame, pose in poses.items():
        if frame.endswith(("/base", "/flange", "/tcp")) or frame == cell:
            for axis, colour in zip(range(3), ("r", "g", "b"), strict=True):
                tip = pose[:3, 3] + 0.12 * pose[:3, axis]
                ax.plot(*zip(pose[:3, 3], tip, strict=True), color=colour, linewidth=1.5)
    ax.set(xlim=(-0.6, 1.8), ylim=(-1.2, 1.2), zlim=(0, 1.5), xlabel="x (m)", ylabel="y (m)")
    ax.set_box_aspect((2.4, 2.4, 1.5))
    ax.view_init(elev=22, azim=-128)
    ax.set_title(
        f"cell {cell}: /{cell}/transforms + /{cell}/scene as `motocell view` serves them\n"
        "(a matplotlib rendering of a real run's recorded view data, not a Foxglove screenshot)",
        fontsize=9,
    )
    figure.savefig(out)


def main() -> None:
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "view.png")
    with tempfile.TemporaryDirectory() as directory:
        recording = Path(directory) / "dual.mcap"
        record_a_move(recording)
        transforms, scene = last_scene(recording, "dual")
    out.parent.mkdir(parents=True, exist_ok=True)
    render(transforms, scene, "dual", out)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
