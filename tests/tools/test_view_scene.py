"""The 3D scene: frames that compose to the kinematics' poses, placed by the cell file, and
geometry as long as the DH table's links."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from motocell.shared.config import Cell, load_cell
from motocell.shared.motion.forward_kinematics import Chain, tool_transform
from motocell.tools.view_scene import LINK_COLOUR, CellScene, Transform, flange_frame
from tests.frames import in_root


def in_cell(transforms: list[Transform], frame: str, cell: str) -> np.ndarray[Any, Any]:
    """``frame``'s pose in the cell's frame, composed up the tree."""
    steps = [(t.parent, t.child, t.translation, t.rotation) for t in transforms]
    return in_root(steps, cell)[frame]


@pytest.fixture
def dual() -> Cell:
    return load_cell("dual-arm-positioner")


def test_every_flange_is_where_the_kinematics_put_it_in_its_place(dual: Cell) -> None:
    rng = np.random.default_rng(7)
    joints = {g.index: rng.uniform(-1, 1, g.axes).tolist() for g in dual.groups}
    transforms = CellScene(dual).transforms(joints)
    for group in dual.groups:
        placement = tool_transform([*group.base.xyz, *group.base.rpy])
        expected = placement @ Chain(group.model).flange(joints[group.index])
        found = in_cell(transforms, flange_frame(dual.name, group.name), dual.name)
        np.testing.assert_allclose(found, expected, atol=1e-12)


def test_the_sample_cell_stands_its_groups_apart(dual: Cell) -> None:
    transforms = CellScene(dual).transforms({g.index: [0.0] * g.axes for g in dual.groups})
    bases = [in_cell(transforms, f"dual/{g.name}/base", "dual")[:3, 3] for g in dual.groups]
    gaps = [np.linalg.norm(a - b) for i, a in enumerate(bases) for b in bases[i + 1 :]]
    assert min(gaps) > 1.0


def test_a_group_with_no_joints_given_is_left_out(dual: Cell) -> None:
    transforms = CellScene(dual).transforms({0: [0.0] * 6, 7: [0.0] * 6})
    assert {t.child.split("/")[1] for t in transforms} == {"R1"}


def test_a_group_with_other_axes_than_its_cell_file_says_is_left_out(dual: Cell) -> None:
    """The state of a cell that is not the one the ``--config`` file describes."""
    transforms = CellScene(dual).transforms({0: [0.0] * 6, 1: [0.0] * 2})
    assert {t.child.split("/")[1] for t in transforms} == {"R1"}


def test_the_links_are_drawn_as_long_as_the_table_says() -> None:
    cell = load_cell()
    shapes = CellScene(cell).shapes()
    model = cell.groups[0].model
    links = [s for frame in shapes.values() for s in frame if s.colour == LINK_COLOUR]
    drawn = sum(s.size[2] for s in links)
    assert drawn == pytest.approx(sum(abs(d) + abs(a) for _theta, d, a, _alpha in model.dh))


def test_a_track_gets_its_rail_and_a_positioner_its_table() -> None:
    four = load_cell("four-group")
    shapes = CellScene(four).shapes()
    (rail,) = [s for s in shapes["four/B1/base"] if s.kind == "cube"]
    lower, upper = four.groups[2].joint_limits[0]
    assert rail.size[2] == pytest.approx(upper - lower)
    (table,) = shapes["four/S1/flange"]
    assert table.kind == "cylinder" and table.size[0] == pytest.approx(0.7)
