"""Forward kinematics against poses worked out independently: by hand from each arm's geometry,
and against the chain of the ROS-Industrial URDF each table imitates, composed from the URDF's
joint origins and axes (tests/frames.py), which shares no code or convention with the DH chain.

The flange frame of arm6 is the GP7 URDF's tool0 and that of arm7 the SIA10D URDF's link_t (it
has no tool0): no constant rotation between them, the frames are equal."""

from __future__ import annotations

import math

import numpy as np
import pytest

from motocell.shared.config import RobotModel, load_catalogue
from motocell.shared.motion.forward_kinematics import (
    Chain,
    FloatArray,
    pose,
    quaternion,
    tool_pose,
    tool_transform,
)
from tests.frames import UrdfJoint, axis_rotation, rotation_matrix, urdf_pose

MODELS = load_catalogue()
ARM6 = Chain(MODELS["arm6"])
ARM7 = Chain(MODELS["arm7"])

METRES = 1e-9
RADIANS = 1e-9
URDF_RADIANS = 1e-6
"""The GP7 URDF writes tool0's rpy as (3.1415926, -1.570796, 0): 3.3e-7 rad off a half and a
quarter turn."""
HALF = math.pi / 2
ROOT_HALF = math.sqrt(0.5)

# ros-industrial/motoman, motoman_gp7_support/urdf/gp7_macro.xacro: joint_1_s ... joint_6_t, then
# the fixed joint_6_t-tool0; every link frame is parallel to base_link at zero.
GP7 = [
    UrdfJoint((0.0, 0.0, 0.330), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    UrdfJoint((0.040, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    UrdfJoint((0.0, 0.0, 0.445), (0.0, 0.0, 0.0), (0.0, -1.0, 0.0)),
    UrdfJoint((0.440, 0.0, 0.040), (0.0, 0.0, 0.0), (-1.0, 0.0, 0.0)),
    UrdfJoint((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, -1.0, 0.0)),
    UrdfJoint((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (-1.0, 0.0, 0.0)),
    UrdfJoint((0.080, 0.0, 0.0), (3.1415926, -1.570796, 0.0)),
]
GP7_LIMITS = [
    (-2.9670, 2.9670),
    (-1.1344, 2.5307),
    (-1.2217, 3.3161),
    (-3.3161, 3.3161),
    (-2.3561, 2.3561),
    (-6.2944, 6.2944),
]
# ros-industrial/motoman, motoman_sia10d_support/urdf/sia10d_macro.xacro: joint_s, l, e, u, r, b,
# t; the chain ends at link_t.
SIA10D = [
    UrdfJoint((0.0, 0.0, 0.36), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    UrdfJoint((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    UrdfJoint((0.0, 0.0, 0.36), (0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    UrdfJoint((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, -1.0, 0.0)),
    UrdfJoint((0.0, 0.0, 0.360), (0.0, 0.0, 0.0), (0.0, 0.0, -1.0)),
    UrdfJoint((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, -1.0, 0.0)),
    UrdfJoint((0.0, 0.0, 0.155), (0.0, 0.0, 0.0), (0.0, 0.0, -1.0)),
]
SIA10D_LIMITS = [
    (-3.1415, 3.1415),
    (-1.9198, 1.9198),
    (-2.9670, 2.9670),
    (-2.3561, 2.3561),
    (-3.1415, 3.1415),
    (-1.9198, 1.9198),
    (-3.1415, 3.1415),
]


def rotation_z(angle: float) -> FloatArray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


# arm6 (GP7): base 0.330 to L, L 0.040 in front of S, upper arm 0.445, forearm 0.040 above U
# and 0.440 long to the wrist centre, wrist centre to flange 0.080. At home the upper arm is
# upright, the forearm points forward (+x); the flange's z points forward, its x up.
ARM6_HOME = np.array(
    [[0.0, 0.0, 1.0, 0.560], [0.0, -1.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.815], [0.0, 0.0, 0.0, 1.0]]
)
# arm7 (SIA10D): upright at home, 0.360 base to L, L to U, U to B, then 0.155 to the flange.
# The flange is the base frame lifted by 1.235.
ARM7_HOME = np.array(
    [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 1.235], [0.0, 0.0, 0.0, 1.0]]
)


def test_arm6_home_is_a_gp7_at_rest() -> None:
    """All-zero joints: the flange 0.560 m in front of the base, 0.815 m above it."""
    np.testing.assert_allclose(ARM6.flange(np.zeros(6)), ARM6_HOME, atol=METRES)


def test_arm7_home_is_upright() -> None:
    np.testing.assert_allclose(ARM7.flange(np.zeros(7)), ARM7_HOME, atol=METRES)


@pytest.mark.parametrize(
    ("joints", "flange_position"),
    [
        # S a quarter turn (about +z): the arm faces +y.
        ([HALF, 0, 0, 0, 0, 0], [0.0, 0.560, 0.815]),
        # L forward a quarter turn about the shoulder (0.040, 0, 0.330) (L turns about +y): the
        # upper arm lies forward, the forearm hangs down: (0.040 + 0.485, 0, 0.330 - 0.520).
        ([0, HALF, 0, 0, 0, 0], [0.525, 0.0, -0.190]),
        # U a quarter turn about the elbow (0.040, 0, 0.775) (U turns about -y) raises the
        # forearm upright; the 0.040 it sits above U now points back: (0.040 - 0.040, 0,
        # 0.775 + 0.520).
        ([0, 0, HALF, 0, 0, 0], [0.0, 0.0, 1.295]),
        # U -70 degrees, its lower limit, lowers the forearm: the flange, 0.520 out and 0.040
        # up from the elbow at home, turns 70 degrees down about it.
        (
            [0, 0, -math.radians(70), 0, 0, 0],
            [
                0.040 + 0.520 * math.cos(math.radians(70)) + 0.040 * math.sin(math.radians(70)),
                0.0,
                0.775 - 0.520 * math.sin(math.radians(70)) + 0.040 * math.cos(math.radians(70)),
            ],
        ),
        # B a quarter turn about the wrist centre (0.480, 0, 0.815) (B turns about -y) tips
        # the flange up: 0.080 above it.
        ([0, 0, 0, 0, HALF, 0], [0.480, 0.0, 0.895]),
        # R (about -x) first turns the B axis from -y to +z, so B then swings the flange to +y.
        ([0, 0, 0, HALF, HALF, 0], [0.480, 0.080, 0.815]),
        # T turns about the flange's own axis: the position stays.
        ([0, 0, 0, 0, 0, 1.0], [0.560, 0.0, 0.815]),
    ],
)
def test_arm6_single_joint_moves_by_hand(joints: list[float], flange_position: list[float]) -> None:
    position, _ = pose(ARM6.flange(np.array(joints)))
    np.testing.assert_allclose(position, flange_position, atol=METRES)


def test_arm6_t_turns_the_flange_about_its_minus_z() -> None:
    """T turns about the GP7's -x at home, which is the flange's -z: at T = 90 degrees the
    flange's z still points forward and its x turns from up to +y."""
    flange = ARM6.flange(np.array([0, 0, 0, 0, 0, HALF]))
    np.testing.assert_allclose(flange[:3, 2], [1.0, 0.0, 0.0], atol=RADIANS)
    np.testing.assert_allclose(flange[:3, 0], [0.0, 1.0, 0.0], atol=RADIANS)


@pytest.mark.parametrize(("chain", "urdf", "model"), [(ARM6, GP7, "arm6"), (ARM7, SIA10D, "arm7")])
def test_agrees_with_the_urdf_chain(chain: Chain, urdf: list[UrdfJoint], model: str) -> None:
    """Random joint vectors inside the joint ranges: the flange is the URDF's last frame,
    position and orientation."""
    limits = np.array(MODELS[model].joint_limits)
    rng = np.random.default_rng(16)
    vectors = rng.uniform(limits[:, 0], limits[:, 1], size=(500, len(limits)))
    flanges = chain.flange(vectors)
    for joints, flange in zip(vectors, flanges, strict=True):
        expected = urdf_pose(urdf, joints)
        np.testing.assert_allclose(flange[:3, 3], expected[:3, 3], atol=METRES)
        np.testing.assert_allclose(flange[:3, :3], expected[:3, :3], atol=URDF_RADIANS)


@pytest.mark.parametrize(
    ("model", "urdf_limits", "differing"),
    [("arm6", GP7_LIMITS, {5}), ("arm7", SIA10D_LIMITS, set())],
)
def test_joint_limits_are_the_urdf_ones_per_direction(
    model: str, urdf_limits: list[tuple[float, float]], differing: set[int]
) -> None:
    """With the URDF's joint directions, each signed limit is the URDF's (to its 4 decimals),
    except the GP7's T: the datasheet's +-360 degrees, where the URDF writes +-6.2944."""
    limits = MODELS[model].joint_limits
    for axis, (ours, urdf) in enumerate(zip(limits, urdf_limits, strict=True)):
        if axis not in differing:
            assert ours == pytest.approx(urdf, abs=2e-4)
    for axis in differing:
        assert limits[axis] == pytest.approx([-2 * math.pi, 2 * math.pi], abs=1e-4)


def test_arm7_l_and_u_turn_as_on_an_sia10d() -> None:
    """L turns about +y, U about -y: L a quarter turn lays the upper arm forward (elbow at
    (0.360, 0, 0.360)), and U a quarter turn then raises the forearm upright from there."""
    np.testing.assert_allclose(
        pose(ARM7.flange(np.array([0, HALF, 0, 0, 0, 0, 0]))).position,
        [0.875, 0, 0.360],
        atol=METRES,
    )
    np.testing.assert_allclose(
        pose(ARM7.flange(np.array([0, HALF, 0, HALF, 0, 0, 0]))).position,
        [0.360, 0, 0.875],
        atol=METRES,
    )


def test_arm7_e_is_an_elbow_roll_between_l_and_u() -> None:
    """L a quarter turn and U a quarter turn back: the upper arm lies forward (elbow at
    (0.360, 0, 0.360)) and the forearm hangs down. E then turns the forearm about the upper arm,
    so the flange swings sideways around it; an E axis at the wrist (Motoman's pulse order)
    would leave it still."""
    bent = np.array([0, HALF, 0, -HALF, 0, 0, 0])
    rolled = np.array([0, HALF, HALF, -HALF, 0, 0, 0])
    np.testing.assert_allclose(pose(ARM7.flange(bent)).position, [0.360, 0, -0.155], atol=METRES)
    np.testing.assert_allclose(
        pose(ARM7.flange(rolled)).position, [0.360, 0.515, 0.360], atol=METRES
    )


def test_arm7_e_keeps_the_elbow_and_the_forearm_length() -> None:
    """Whatever E, U's frame (the elbow) stays put and the flange stays 0.515 m from it."""
    elbow_frames = []
    for e in np.linspace(-2.5, 2.5, 7):
        joints = np.array([0.3, 0.8, e, 1.1, 0.0, 0.0, 0.0])
        links = ARM7.link_transforms(joints)
        to_elbow = links[0] @ links[1] @ links[2]  # frames S, L, E: the origin of U's
        elbow_frames.append(to_elbow[:3, 3])
        distance = np.linalg.norm(ARM7.flange(joints)[:3, 3] - to_elbow[:3, 3])
        assert distance == pytest.approx(0.515, abs=METRES)
    np.testing.assert_allclose(elbow_frames, [elbow_frames[0]] * 7, atol=1e-12)


def test_link_transforms_chain_to_the_flange() -> None:
    """The frame tree's transforms, multiplied along the arm, give the flange."""
    joints = np.array([0.2, -0.4, 0.9, 1.3, -0.7, 2.0])
    links = ARM6.link_transforms(joints)
    assert links.shape == (6, 4, 4)
    np.testing.assert_allclose(np.linalg.multi_dot(list(links)), ARM6.flange(joints), atol=1e-12)


def test_first_link_is_the_s_rotation_and_base_height() -> None:
    """The first link's frame: S about the base's z, 0.330 up and 0.040 out along the turned x."""
    link = ARM6.link_transforms(np.array([HALF, 0, 0, 0, 0, 0]))[0]
    np.testing.assert_allclose(link[:3, 3], [0.0, 0.040, 0.330], atol=METRES)


def test_batches_match_single_calls() -> None:
    """Feedback and commanded positions go through one call."""
    both = np.array([[0.1, 0.2, 0.3, 0.4, 0.5, 0.6], [-0.6, 0.5, -0.4, 0.3, -0.2, 0.1]])
    batch = pose(ARM6.flange(both))
    for row, joints in enumerate(both):
        single = pose(ARM6.flange(joints))
        np.testing.assert_allclose(batch.position[row], single.position, atol=1e-15)
        np.testing.assert_allclose(batch.orientation[row], single.orientation, atol=1e-15)


def test_linear_axis_moves_along_its_z() -> None:
    """The track's carriage moves along the base frame's z by the joint value in metres."""
    track = Chain(MODELS["track1"])
    np.testing.assert_allclose(track.flange(np.array([1.25]))[:3, 3], [0.0, 0.0, 1.25])


def test_positioner_tilt_then_rotate() -> None:
    """positioner2: tilt about the base's z, then the table about the tilted frame's z, which
    the table's alpha of 90 degrees lays along -y at zero tilt."""
    positioner = Chain(MODELS["positioner2"])
    table = positioner.flange(np.array([0.0, 0.0]))
    np.testing.assert_allclose(table[:3, 2], [0.0, -1.0, 0.0], atol=RADIANS)
    tilted = positioner.flange(np.array([HALF, 0.0]))
    np.testing.assert_allclose(tilted[:3, 2], [1.0, 0.0, 0.0], atol=RADIANS)


def test_fewer_links_than_axes_leave_the_extra_axes_out() -> None:
    model = RobotModel(
        kind="robot",
        axis_types=["rotary", "rotary"],
        pulses_per_unit=[1.0, 1.0],
        max_speed=[1.0, 1.0],
        max_accel=[1.0, 1.0],
        initial_position=[0.0, 0.0],
        joint_limits=[[-1.0, 1.0], [-1.0, 1.0]],
        dh=[[0.0, 0.0, 1.0, 0.0]],
    )
    flange = Chain(model).flange(np.array([HALF, 0.7]))
    np.testing.assert_allclose(flange[:3, 3], [0.0, 1.0, 0.0], atol=1e-12)


def test_tool_offset_is_along_the_flange_axes() -> None:
    """A tool 0.100 m out of the flange face at home: 0.100 further forward."""
    tcp = ARM6.tcp(np.zeros(6), tool_transform([0, 0, 0.100, 0, 0, 0]))
    np.testing.assert_allclose(tcp[:3, 3], [0.660, 0.0, 0.815], atol=METRES)
    # 0.050 along the flange's x, which points up at home.
    tcp = ARM6.tcp(np.zeros(6), tool_transform([0.050, 0, 0, 0, 0, 0]))
    np.testing.assert_allclose(tcp[:3, 3], [0.560, 0.0, 0.865], atol=METRES)


def test_tool_offset_turns_with_the_wrist() -> None:
    """B a quarter turn points the flange up: a 0.100 tool then reaches 0.180 above the wrist
    centre (0.480, 0, 0.815)."""
    tcp = ARM6.tcp(np.array([0, 0, 0, 0, HALF, 0]), tool_transform([0, 0, 0.100, 0, 0, 0]))
    np.testing.assert_allclose(tcp[:3, 3], [0.480, 0.0, 0.995], atol=METRES)


def test_tool_rotation_is_fixed_axis_roll_pitch_yaw() -> None:
    """rx = ry = 0, rz = 90: x -> y. rx = 90 then rz = 90 about the fixed axes, worked by hand:
    x -> y, y -> z, z -> x."""
    np.testing.assert_allclose(
        tool_transform([0, 0, 0, 0, 0, HALF])[:3, :3], rotation_z(HALF), atol=1e-12
    )
    expected = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    np.testing.assert_allclose(
        tool_transform([0, 0, 0, HALF, 0, HALF])[:3, :3], expected, atol=1e-12
    )
    # ry = 90 alone: z -> x.
    np.testing.assert_allclose(tool_transform([0, 0, 0, 0, HALF, 0])[:3, 2], [1, 0, 0], atol=1e-12)


def test_tool_pose_composes_tool_on_flange() -> None:
    """The one-call form: arm6 at home with a tool 0.100 out and turned 90 degrees about its z.
    Flange x up, z forward; the tool's x is the flange's y (-y of the base)."""
    tcp = tool_pose(MODELS["arm6"], [0, 0, 0.100, 0, 0, HALF], [0, 0, 0, 0, 0, 0])
    np.testing.assert_allclose(tcp.position, [0.660, 0.0, 0.815], atol=METRES)
    expected = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    np.testing.assert_allclose(rotation_matrix(tcp.orientation), expected, atol=RADIANS)


def test_home_quaternion() -> None:
    """arm6's flange at home is a half turn about (x + z)/sqrt(2): (sqrt(1/2), 0, sqrt(1/2), 0)
    up to the sign a half turn leaves free."""
    q = pose(ARM6.flange(np.zeros(6))).orientation
    assert abs(np.dot(q, [ROOT_HALF, 0, ROOT_HALF, 0])) == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize(
    ("axis", "angle", "expected"),
    [
        ((1, 0, 0), 0.0, (0, 0, 0, 1)),
        ((0, 0, 1), HALF, (0, 0, ROOT_HALF, ROOT_HALF)),
        ((1, 0, 0), math.pi, (1, 0, 0, 0)),
        ((0, 1, 0), math.pi, (0, 1, 0, 0)),
        ((0, 0, 1), math.pi, (0, 0, 1, 0)),
        ((ROOT_HALF, ROOT_HALF, 0), math.pi, (ROOT_HALF, ROOT_HALF, 0, 0)),
        ((0, ROOT_HALF, -ROOT_HALF), math.pi, (0, ROOT_HALF, -ROOT_HALF, 0)),
        ((0, 0, 1), -HALF, (0, 0, -ROOT_HALF, ROOT_HALF)),
    ],
)
def test_quaternion_of_known_rotations(
    axis: tuple[float, float, float], angle: float, expected: tuple[float, float, float, float]
) -> None:
    """(sin(angle/2) * axis, cos(angle/2)), including half turns, where w is 0 and the sign of
    the vector part must still be consistent."""
    q = quaternion(axis_rotation(np.array(axis, dtype=float), angle))
    assert abs(np.dot(q, expected)) == pytest.approx(1.0, abs=1e-12)


def test_quaternions_are_unit_with_w_not_negative() -> None:
    rng = np.random.default_rng(7)
    limits = np.array(MODELS["arm6"].joint_limits)
    joints = rng.uniform(limits[:, 0], limits[:, 1], size=(200, 6))
    q = pose(ARM6.flange(joints)).orientation
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-12)
    assert (q[:, 3] >= 0).all()


def test_matrix_quaternion_round_trip() -> None:
    """Random rotations (random axes and angles up to a half turn): the quaternion's matrix is
    the matrix, and a quaternion's matrix gives the quaternion back."""
    rng = np.random.default_rng(3)
    for _ in range(500):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        rotation = axis_rotation(axis, rng.uniform(-math.pi, math.pi))
        q = quaternion(rotation)
        np.testing.assert_allclose(rotation_matrix(q), rotation, atol=1e-12)
        np.testing.assert_allclose(quaternion(rotation_matrix(q)), q, atol=1e-12)


def test_quaternion_of_a_stack_keeps_its_shape() -> None:
    stack = np.broadcast_to(np.eye(4), (2, 3, 4, 4))
    np.testing.assert_allclose(quaternion(stack), np.broadcast_to([0, 0, 0, 1.0], (2, 3, 4)))
