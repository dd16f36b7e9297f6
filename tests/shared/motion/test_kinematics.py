"""AxisMap: ROS order/units <-> Motoman order/pulses (motoros1 §4.3)."""

from __future__ import annotations

import numpy as np
import pytest

from motocell.shared.config import Group, parse_cell
from motocell.shared.motion.kinematics import AxisMap


def group_of(model: str) -> Group:
    return parse_cell({"groups": [{"name": "G", "model": model}]}).groups[0]


ARM6 = AxisMap(group_of("arm6"))
ARM7 = AxisMap(group_of("arm7"))
TRACK = AxisMap(group_of("track1"))
POSITIONER = AxisMap(group_of("positioner2"))


def test_six_axis_orders_are_the_same() -> None:
    assert ARM6.axes == 6
    assert ARM6.ros_index_of_moto.tolist() == [0, 1, 2, 3, 4, 5]
    assert ARM6.moto_index_of_ros.tolist() == [0, 1, 2, 3, 4, 5]
    assert ARM6.pulses_per_unit_moto.tolist() == [58670, 58670, 58670, 32594, 32594, 21990]
    assert ARM6.max_speed_ros.tolist() == [6.54, 5.50, 7.15, 9.60, 9.60, 13.96]


def test_seven_axis_index_maps() -> None:
    # moto[0]=ros[0], moto[1]=ros[1], moto[2..5]=ros[3..6], moto[6]=ros[2].
    assert ARM7.axes == 7
    assert ARM7.ros_index_of_moto.tolist() == [0, 1, 3, 4, 5, 6, 2]
    assert ARM7.moto_index_of_ros.tolist() == [0, 1, 6, 2, 3, 4, 5]
    # ROS-order pulses per radian are [65536 x 4, 36408, 36408, 24576].
    assert ARM7.pulses_per_unit_moto.tolist() == [
        65536, 65536, 65536, 36408, 36408, 24576, 65536
    ]  # fmt: skip
    # Speed limits stay in ROS order (they are checked against ROS velocities).
    assert ARM7.max_speed_ros.tolist() == [2.96, 2.96, 2.96, 2.96, 3.49, 3.49, 6.28]


def test_seven_axis_ros_to_pulses_puts_e_last() -> None:
    # One distinct power-of-two-exact value per ROS joint S, L, E, U, R, B, T.
    ros = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]) / 8
    pulses = ARM7.ros_to_pulses(ros)
    assert pulses.dtype == np.int64
    # S, L, U, R, B, T, E
    assert pulses.tolist() == [8192, 16384, 32768, 22755, 27306, 21504, 24576]


def test_seven_axis_pulses_to_ros_puts_e_third() -> None:
    moto = [65536, 2 * 65536, 3 * 65536, 4 * 36408, 5 * 36408, 6 * 24576, 7 * 65536, 999]
    # The 8th slot is not an axis of this group and is ignored.
    assert ARM7.pulses_to_ros(moto).tolist() == [1.0, 2.0, 7.0, 3.0, 4.0, 5.0, 6.0]


@pytest.mark.parametrize("axis_map", [ARM6, ARM7, TRACK, POSITIONER])
def test_pulses_round_trip_exactly(axis_map: AxisMap) -> None:
    rng = np.random.default_rng(11)
    for _ in range(200):
        pulses = rng.integers(-3_000_000, 3_000_000, size=axis_map.axes)
        back = axis_map.ros_to_pulses(axis_map.pulses_to_ros(pulses))
        assert back.tolist() == pulses.tolist()


@pytest.mark.parametrize("axis_map", [ARM6, ARM7, TRACK, POSITIONER])
def test_positions_round_trip_within_half_a_pulse(axis_map: AxisMap) -> None:
    rng = np.random.default_rng(12)
    ros = rng.uniform(-3.2, 3.2, size=(500, axis_map.axes))
    pulses = axis_map.ros_to_pulses(ros)
    assert pulses.shape == (500, axis_map.axes)
    back = np.array([axis_map.pulses_to_ros(row) for row in pulses])
    ppu_ros = axis_map.pulses_per_unit_moto[axis_map.moto_index_of_ros]
    assert np.all(np.abs(back - ros) * ppu_ros <= 0.5 + 1e-9)


def test_two_dimensional_input_converts_row_by_row() -> None:
    ros = np.array([[0.0] * 7, [0.5] * 7, [-0.25] * 7])
    rows = ARM7.ros_to_pulses(ros)
    assert rows.tolist() == [ARM7.ros_to_pulses(r).tolist() for r in ros]


def test_rounding_is_to_nearest_not_truncation() -> None:
    # MotoROS truncates toward zero; AxisMap rounds to nearest (documented difference).
    scale = 65536.0  # ARM7 axis S: pulses = rad * 65536, exact for these values
    cases = {2.7: 3, 2.4: 2, -2.7: -3, -2.4: -2, 0.49: 0, -0.49: 0}
    for value, expected in cases.items():
        ros = np.zeros(7)
        ros[0] = value / scale
        assert ARM7.ros_to_pulses(ros)[0] == expected, value


def test_rounding_ties_go_to_even() -> None:
    scale = 65536.0  # exact halves are representable: rad = k.5 / 2**16
    for value, expected in {0.5: 0, 1.5: 2, 2.5: 2, -0.5: 0, -1.5: -2, -2.5: -2}.items():
        ros = np.zeros(7)
        ros[0] = value / scale
        assert ARM7.ros_to_pulses(ros)[0] == expected, value


def test_linear_axis_is_in_metres() -> None:
    assert TRACK.axes == 1
    assert TRACK.ros_to_pulses(np.array([0.0015])).tolist() == [1500]
    assert TRACK.ros_to_pulses(np.array([-1.2345674])).tolist() == [-1_234_567]
    assert TRACK.pulses_to_ros([2_500_000, 7, 7, 7, 7, 7, 7, 7]).tolist() == [2.5]


def test_pad_moto_fills_eight_slots() -> None:
    assert ARM6.pad_moto(np.array([1, -2, 3, -4, 5, -6], dtype=np.int64)) == [
        1, -2, 3, -4, 5, -6, 0, 0
    ]  # fmt: skip
    assert ARM7.pad_moto(np.arange(1, 8, dtype=np.int64)) == [1, 2, 3, 4, 5, 6, 7, 0]
    assert TRACK.pad_moto(np.array([42], dtype=np.int64)) == [42, 0, 0, 0, 0, 0, 0, 0]
    padded = ARM6.pad_moto(np.array([1, 2, 3, 4, 5, 6], dtype=np.int64))
    assert all(type(v) is int for v in padded)


def test_max_increments_are_the_speed_limit_in_pulses_per_period_plus_one() -> None:
    # arm6 S axis: 6.54 rad/s x 58670 pulses/rad x 4 ms = 1534.8, up to 1535, plus 1.
    assert ARM6.max_increments(0.004) == [1536, 1292, 1679, 1253, 1253, 1229, 0, 0]


def test_max_increments_of_a_seven_axis_arm_are_in_motoman_order() -> None:
    # The E axis (ROS index 2, 2.96 rad/s) is Motoman's seventh; T (6.28 rad/s) its sixth.
    assert ARM7.max_increments(0.004) == [777, 777, 777, 510, 510, 619, 777, 0]


def test_max_increments_scale_with_the_period() -> None:
    assert ARM6.max_increments(0.001)[0] == 385  # 383.7 up to 384, plus 1
    assert TRACK.max_increments(0.004) == [6001, 0, 0, 0, 0, 0, 0, 0]  # 1.5 m/s in µm


@pytest.mark.parametrize("model", ["arm6", "arm7", "positioner2", "track1"])
def test_ros_values_are_pulses_to_ros_exactly(model: str) -> None:
    """The state path's plain-Python conversion gives the very floats numpy does."""
    axis_map = AxisMap(parse_cell({"groups": [{"name": "G", "model": model}]}).groups[0])
    rng = np.random.default_rng(7)
    for _ in range(200):
        pulses = rng.integers(-500_000, 500_000, 8).tolist()
        moved = rng.uniform(-300, 300, 8).tolist()
        assert axis_map.ros_values(pulses) == axis_map.pulses_to_ros(pulses).tolist()
        assert axis_map.ros_values(moved, 250.0) == (axis_map.pulses_to_ros(moved) * 250.0).tolist()
