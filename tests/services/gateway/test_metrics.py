"""GatewayStats: counts and latency windows by message type, bounded whatever types arrive."""

from __future__ import annotations

from motocell.services.gateway.metrics import OTHER_TYPES, GatewayStats, bucket
from motocell.shared.bus.schemas import encode
from motocell.shared.protocol.constants import Command, InvalidSubcode, MsgType, Result
from motocell.shared.protocol.messages import Message
from motocell.shared.protocol.replies import motion_ctrl, motion_reply

REQUEST = motion_ctrl(Command.CHECK_MOTION_READY)


def reply(result: Result, group: int = 0) -> Message:
    return motion_reply(REQUEST, result, 0, group)


def test_every_known_type_has_its_own_bucket() -> None:
    assert all(bucket(t) == t for t in MsgType)


def test_every_other_type_shares_one_bucket() -> None:
    assert {bucket(t) for t in (0, -1, 3, 777, 2**31 - 1, -(2**31))} == {OTHER_TYPES}
    assert OTHER_TYPES not in set(MsgType)


def test_10000_unknown_types_keep_one_window_and_a_small_message() -> None:
    stats = GatewayStats(groups=2)
    invalid = motion_reply(REQUEST, Result.INVALID, InvalidSubcode.MSGTYPE)
    for msg_type in range(10_000, 20_000):
        stats.observe(msg_type, invalid, 1_000)
    stats.observe(MsgType.PING, None, 2_000)
    snapshot = stats.snapshot(1, 0)
    assert [(r.msg_type, r.count) for r in snapshot.requests] == [
        (OTHER_TYPES, 10_000),
        (MsgType.PING, 1),
    ]
    assert snapshot.invalid_total == 10_000
    assert len(stats._latency) == 2
    assert len(encode(snapshot)) < 200


def test_answers_are_counted_by_result_and_busy_by_group() -> None:
    stats = GatewayStats(groups=2)
    stats.observe(MsgType.JOINT_TRAJ_PT_FULL, reply(Result.BUSY, group=1), 1_000)
    stats.observe(MsgType.JOINT_TRAJ_PT_FULL, reply(Result.BUSY, group=7), 1_000)
    stats.observe(MsgType.JOINT_TRAJ_PT_FULL, reply(Result.NOT_READY), 1_000)
    stats.observe(MsgType.JOINT_TRAJ_PT_FULL, reply(Result.SUCCESS), 3_000)
    snapshot = stats.snapshot(1, 0)
    assert (snapshot.busy_total, snapshot.not_ready_total, snapshot.invalid_total) == (2, 1, 0)
    assert snapshot.busy_by_group == [0, 1]
    [requests] = snapshot.requests
    assert (requests.count, requests.reply.count, requests.reply.max_us) == (4, 4, 3.0)


def test_latencies_are_those_since_the_last_snapshot_counts_since_start() -> None:
    stats = GatewayStats(groups=1)
    stats.observe(MsgType.PING, None, 1_000)
    stats.snapshot(0, 0)
    [requests] = stats.snapshot(0, 0).requests
    assert (requests.count, requests.reply.count) == (1, 0)
