"""JointState as CDR bytes: the layout rmw_fastrtps writes (checked against rclpy's own
serialiser in a child process), its padding zeros."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from motocell.services.ros2.core.joint_state_cdr import JointStateCdr
from motocell.shared.ros2 import interfaces

ONE_JOINT = bytes.fromhex(
    "00010000"  # CDR_LE
    "01000000"  # stamp: 1 s
    "02000000"  # and 2 ns
    "01000000"
    "00"
    "000000"  # frame_id "" (its NUL), padding
    "01000000"
    "02000000"
    "6100"
    "0000"  # one name: "a" and its NUL, padding
    "01000000"
    "000000000000e03f"  # one position, 0.5 (at 32: aligned to 8 already)
    "01000000"
    "00000000"
    "000000000000d03f"  # one velocity, padding to 8, 0.25
    "00000000"
    "00000000"  # no effort, its (empty) doubles aligned to 8 all the same
)
"""What rclpy serialises for that message, but for its padding (rclpy leaves whatever the
buffer held there); its deserialiser read these bytes back as the same message."""

NAME_SETS = [
    ["a"],
    [f"joint_{index}" for index in range(15)],
    ["group_1/joint_1", "xy", "abc", "abcd"],
    [f"r{index}" for index in range(7)],
]


def values(count: int) -> tuple[list[float], list[float]]:
    return [0.1 * index - 3 for index in range(count)], [1e-3 * index for index in range(count)]


def test_one_joint_is_laid_out_as_cdr_lays_it_out() -> None:
    assert JointStateCdr(["a"]).encode((1, 2), [0.5], [0.25]) == ONE_JOINT


def test_only_the_stamp_and_the_arrays_change_between_messages() -> None:
    message = JointStateCdr(NAME_SETS[1])
    first = message.encode((10, 20), *values(15))
    second = message.encode((11, 21), [9.0] * 15, [8.0] * 15)
    assert len(first) == len(second) == 484  # rclpy's size for this message
    assert first[:4] == second[:4] and first[12:180] == second[12:180]


CHECK = """
import array, json, sys
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
for case in json.loads(sys.stdin.read()):
    message = JointState()
    message.name = case["names"]
    message.header.stamp.sec, message.header.stamp.nanosec = case["stamp"]
    message.position = array.array("d", case["positions"])
    message.velocity = array.array("d", case["velocities"])
    ours = bytes.fromhex(case["ours"])
    assert deserialize_message(ours, JointState) == message, case["names"]
    assert len(serialize_message(message)) == len(ours), case["names"]
print("same", flush=True)
"""


@pytest.mark.cell  # starts a Python that loads rclpy
@pytest.mark.skipif(
    interfaces.missing() == interfaces.INSTALL_EXTRA, reason=interfaces.INSTALL_EXTRA
)
def test_rclpy_reads_each_message_as_the_one_it_would_have_sent() -> None:
    cases = []
    for names in NAME_SETS:
        positions, velocities = values(len(names))
        stamp = (1_765_000_000, 999_999_999)
        ours = JointStateCdr(names).encode(stamp, positions, velocities)
        cases.append(
            {
                "names": names,
                "stamp": stamp,
                "positions": positions,
                "velocities": velocities,
                "ours": ours.hex(),
            }
        )
    checked = subprocess.run(
        [sys.executable, "-c", CHECK],
        input=json.dumps(cases),
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert checked.returncode == 0, checked.stderr
    assert checked.stdout.strip() == "same"


def test_arrays_that_do_not_fit_the_names_are_refused() -> None:
    with pytest.raises(ValueError, match="2 names, 1 positions"):
        JointStateCdr(["a", "b"]).encode((0, 0), [1.0], [1.0, 2.0])
