"""``sensor_msgs/msg/JointState`` as the bytes a ROS 2 publisher sends (CDR, little-endian,
as rmw_fastrtps serialises it), for one topic's fixed names and an empty ``effort``.

rclpy's ``publish`` of a message object converts it to C and serialises it anew each period,
names included; a JointState of a topic only ever changes its stamp and its two arrays, so the
face packs those into a layout computed once and publishes the bytes (rclpy's ``publish``
takes serialised bytes as they are). CDR's rules, as the encoder follows them: each primitive
is aligned to its own size, counted from the end of the 4-byte encapsulation header; a string
is its length (with the NUL) as uint32, its bytes and a NUL; a sequence is its count as uint32,
then its elements aligned to their size, even when it has none. Padding is written as zeros.
The e2e tests' real subscribers read every message the face sends through this.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

ENCAPSULATION = b"\x00\x01\x00\x00"
"""CDR_LE: plain CDR, little-endian, no options."""
_UINT32 = struct.Struct("<I")


class _Writer:
    """The fixed bytes between the stamp and the positions, and where CDR's alignment puts
    what follows them."""

    def __init__(self, offset: int) -> None:
        self.offset = offset
        self.data = bytearray()

    def padding(self, size: int) -> int:
        count = -self.offset % size
        self.offset += count
        return count

    def uint32(self, value: int) -> None:
        self.data += b"\x00" * self.padding(4) + _UINT32.pack(value)
        self.offset += 4

    def string(self, text: str) -> None:
        encoded = text.encode() + b"\x00"
        self.uint32(len(encoded))
        self.data += encoded
        self.offset += len(encoded)


class JointStateCdr:
    """One topic's JointState: ``encode`` fills in the stamp, positions and velocities."""

    def __init__(self, names: Sequence[str]) -> None:
        self.joints = len(names)
        # Header: stamp (int32 sec, uint32 nanosec, 8 bytes), then an empty frame_id.
        fixed = _Writer(offset=8)
        fixed.string("")
        fixed.uint32(len(names))
        for name in names:
            fixed.string(name)
        fixed.uint32(self.joints)  # position's count
        joints, doubles = self.joints, 8 * self.joints
        before_positions = fixed.padding(8)
        fixed.offset += doubles
        before_velocities = fixed.padding(4)
        fixed.offset += 4
        velocities_pad = fixed.padding(8)
        fixed.offset += doubles
        before_effort = fixed.padding(4)
        fixed.offset += 4
        after_effort = fixed.padding(8)  # an empty double sequence is aligned all the same
        self._fixed = bytes(fixed.data)
        self._layout = struct.Struct(
            f"<4siI{len(self._fixed)}s{before_positions}x{joints}d"
            f"{before_velocities}xI{velocities_pad}x{joints}d{before_effort}xI{after_effort}x"
        )

    def encode(
        self, stamp: tuple[int, int], positions: Sequence[float], velocities: Sequence[float]
    ) -> bytes:
        """``stamp``: (seconds, nanoseconds); one position and one velocity per name."""
        if len(positions) != self.joints or len(velocities) != self.joints:
            raise ValueError(
                f"{self.joints} names, {len(positions)} positions, {len(velocities)} velocities"
            )
        sec, nanosec = stamp
        return self._layout.pack(
            ENCAPSULATION, sec, nanosec, self._fixed, *positions, self.joints, *velocities, 0
        )
