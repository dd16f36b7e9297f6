"""The motion port's other requests, on a fake cell: MOTO_MOTION_CTRL commands (motoros1 §2.3),
SELECT_TOOL, PING and DH parameters, types it closes on, replies to replies."""

from __future__ import annotations

import msgspec
import pytest

from motocell.services.gateway.core.motion import (
    SLOTS_WAIT_S,
    START_TRAJ_MODE_TIMEOUT_S,
    STOP_WAIT_S,
)
from motocell.shared.bus.schemas import CommandReply, CommandRequest, QueueState
from motocell.shared.protocol.constants import (
    TOOL_NUMBERS,
    Command,
    CommType,
    InvalidSubcode,
    MsgType,
    NotReadySubcode,
    ReplyType,
    Result,
)
from motocell.shared.protocol.errors import PeerProtocolError
from motocell.shared.protocol.messages import (
    DhLink,
    Empty,
    GetDhParametersReply,
    JointFeedback,
    Message,
    MotoMotionCtrl,
    ReadIOBitReply,
    UnknownMessage,
)
from motocell.shared.protocol.replies import (
    get_dh_parameters,
    motion_ctrl,
    ping,
    read_io_bit,
    read_mregister,
    select_tool,
    state_message,
    traj_point,
)
from tests.services.gateway.core.fake_cell import (
    NOW,
    FakeCell,
    exchange,
    gateway,
    queue,
    reply_of,
    slot,
    status,
    two_groups,
    verdict_of,
)

ZEROS = (0.0,) * 6
ZERO_LINK = DhLink(0.0, 0.0, 0.0, 0.0)
SUCCESS = (int(Result.SUCCESS), 0)
FAILURE = (int(Result.FAILURE), 0)
SERVO_OFF = int(NotReadySubcode.SERVO_OFF)


def command(which: Command, group: int = 0) -> Message:
    return motion_ctrl(which, group)


def with_points_outstanding(cell: FakeCell) -> None:
    cell.state.groups[0].published = 2


# -- CHECK_MOTION_READY, CHECK_QUEUE_CNT -------------------------------------------------
def test_check_motion_ready_when_ready() -> None:
    handler, _ = gateway()
    reply = exchange(handler, command(Command.CHECK_MOTION_READY)).reply
    assert verdict_of(reply) == (int(Result.TRUE), 0)
    assert reply_of(reply).command == Command.CHECK_MOTION_READY


def test_check_motion_ready_when_not_ready_gives_the_reason() -> None:
    handler, cell = gateway()
    cell.state.on_status(status(ready=False, subcode=SERVO_OFF), NOW)
    reply = exchange(handler, command(Command.CHECK_MOTION_READY)).reply
    assert verdict_of(reply) == (int(Result.FALSE), SERVO_OFF)


def test_check_motion_ready_waits_for_every_interpolator() -> None:
    handler, cell = gateway(two_groups())
    cell.state.on_status(status(missing=["interpolator/1"]), NOW)
    reply = exchange(handler, command(Command.CHECK_MOTION_READY)).reply
    assert verdict_of(reply) == (int(Result.FALSE), int(NotReadySubcode.INC_MOVE_ERROR))


def test_check_queue_cnt_counts_the_entries_in_the_groups_ring_without_asking() -> None:
    handler, cell = gateway(two_groups())
    cell.state.on_queue(1, queue(depth=17), NOW)
    reply = exchange(handler, command(Command.CHECK_QUEUE_CNT, group=1)).reply
    assert verdict_of(reply) == (int(Result.SUCCESS), 17)
    assert reply_of(reply).group_no == 1
    assert cell.calls == []


def test_check_queue_cnt_does_not_count_pending_points() -> None:
    handler, cell = gateway()
    with_points_outstanding(cell)
    reply = exchange(handler, command(Command.CHECK_QUEUE_CNT)).reply
    assert verdict_of(reply) == (int(Result.SUCCESS), 0)


@pytest.mark.parametrize("group", [-1, 2, 4])
def test_check_queue_cnt_of_a_group_the_cell_lacks_fails_with_minus_1(group: int) -> None:
    handler, _ = gateway(two_groups())
    reply = exchange(handler, command(Command.CHECK_QUEUE_CNT, group=group)).reply
    assert verdict_of(reply) == (int(Result.FAILURE), -1)


def test_check_queue_cnt_without_a_known_ring_fails_with_minus_1() -> None:
    handler, cell = gateway()
    cell.state.on_status(status(ready=False, missing=["executor/0"]), NOW)
    reply = exchange(handler, command(Command.CHECK_QUEUE_CNT)).reply
    assert verdict_of(reply) == (int(Result.FAILURE), -1)


# -- STOP_MOTION ---------------------------------------------------------------------------
def test_stop_motion_clears_the_queues_and_ends_the_trajectory() -> None:
    handler, cell = gateway()
    exchange(handler, traj_point(0, 0, 0.0, ZEROS, ZEROS))
    cell.effects["executor/stop"] = cell.take_all
    assert verdict_of(exchange(handler, command(Command.STOP_MOTION)).reply) == SUCCESS
    assert cell.verbs("executor") == ["stop"]
    assert cell.verbs("controller") == []
    after = exchange(handler, traj_point(0, 1, 0.1, ZEROS, ZEROS)).reply
    assert verdict_of(after) == (int(Result.INVALID), int(InvalidSubcode.SEQUENCE))


def test_stop_motion_waits_for_the_pending_points_to_be_dropped() -> None:
    handler, cell = gateway()
    with_points_outstanding(cell)
    cell.while_waiting.append(lambda: cell.state.on_slot(0, slot(taken=2)))
    assert verdict_of(exchange(handler, command(Command.STOP_MOTION)).reply) == SUCCESS
    assert cell.waits == [STOP_WAIT_S]


def test_stop_motion_fails_when_points_stay_pending() -> None:
    handler, cell = gateway()
    with_points_outstanding(cell)
    assert verdict_of(exchange(handler, command(Command.STOP_MOTION)).reply) == FAILURE


def test_stop_motion_fails_when_the_executor_does_not_answer() -> None:
    handler, cell = gateway()
    cell.replies["executor/stop"] = None
    assert verdict_of(exchange(handler, command(Command.STOP_MOTION)).reply) == FAILURE


# -- servos and alarms ---------------------------------------------------------------------
@pytest.mark.parametrize(
    ("which", "verb"),
    [(Command.START_SERVOS, "start_servos"), (Command.RESET_ALARM, "reset_alarm")],
)
def test_servo_and_alarm_commands_pass_on_the_controllers_answer(which: Command, verb: str) -> None:
    handler, cell = gateway()
    cell.replies[f"controller/{verb}"] = CommandReply(int(Result.NOT_READY), SERVO_OFF)
    reply = exchange(handler, command(which)).reply
    assert verdict_of(reply) == (int(Result.NOT_READY), SERVO_OFF)
    [call] = cell.calls
    assert (call.verb, call.timeout) == (verb, START_TRAJ_MODE_TIMEOUT_S)


def test_stop_servos_stops_motion_first() -> None:
    handler, cell = gateway()
    assert verdict_of(exchange(handler, command(Command.STOP_SERVOS)).reply) == SUCCESS
    assert [(c.service, c.verb) for c in cell.calls] == [
        ("executor", "stop"),
        ("controller", "stop_servos"),
    ]


def test_a_silent_controller_is_a_failure() -> None:
    handler, cell = gateway()
    cell.replies["controller/start_servos"] = None
    assert verdict_of(exchange(handler, command(Command.START_SERVOS)).reply) == FAILURE


# -- START_TRAJ_MODE -----------------------------------------------------------------------
def test_start_traj_mode_succeeds_once_the_cell_is_ready() -> None:
    handler, cell = gateway()
    assert verdict_of(exchange(handler, command(Command.START_TRAJ_MODE)).reply) == SUCCESS
    [call] = cell.calls
    assert (call.verb, call.timeout) == ("start_traj_mode", START_TRAJ_MODE_TIMEOUT_S)


def test_start_traj_mode_waits_for_an_interpolator_to_report() -> None:
    handler, cell = gateway(two_groups())
    cell.state.on_status(status(missing=["interpolator/1"]), NOW)
    cell.while_waiting.append(lambda: cell.state.on_slot(1, slot(instance=99)))
    assert verdict_of(exchange(handler, command(Command.START_TRAJ_MODE)).reply) == SUCCESS
    assert cell.waits == [SLOTS_WAIT_S]


def test_start_traj_mode_is_not_ready_while_an_interpolator_stays_silent() -> None:
    handler, cell = gateway(two_groups())
    cell.state.on_status(status(missing=["interpolator/1"]), NOW)
    reply = exchange(handler, command(Command.START_TRAJ_MODE)).reply
    assert verdict_of(reply) == (int(Result.NOT_READY), int(NotReadySubcode.INC_MOVE_ERROR))


def test_start_traj_mode_passes_on_the_controllers_not_ready() -> None:
    handler, cell = gateway()
    cell.replies["controller/start_traj_mode"] = CommandReply(int(Result.NOT_READY), SERVO_OFF)
    reply = exchange(handler, command(Command.START_TRAJ_MODE)).reply
    assert verdict_of(reply) == (int(Result.NOT_READY), SERVO_OFF)
    assert cell.waits == []


def test_start_traj_mode_without_a_controller_answer_is_not_ready_with_the_reason() -> None:
    handler, cell = gateway()
    cell.replies["controller/start_traj_mode"] = None
    cell.state.on_status(status(ready=False, subcode=int(NotReadySubcode.NOT_REMOTE)), NOW)
    reply = exchange(handler, command(Command.START_TRAJ_MODE)).reply
    assert verdict_of(reply) == (int(Result.NOT_READY), int(NotReadySubcode.NOT_REMOTE))


# -- STOP_TRAJ_MODE and DISCONNECT ---------------------------------------------------------
def test_stop_traj_mode_stops_motion_and_releases_the_job() -> None:
    handler, cell = gateway(two_groups())
    assert verdict_of(exchange(handler, command(Command.STOP_TRAJ_MODE)).reply) == SUCCESS
    assert [(c.service, c.verb) for c in cell.calls] == [
        ("executor", "stop"),
        ("controller", "stop_traj_mode"),
    ]


@pytest.mark.parametrize("queued", [queue(depth=3), None])
def test_stop_traj_mode_refuses_while_a_ring_is_not_known_empty(queued: QueueState | None) -> None:
    handler, cell = gateway(two_groups())
    cell.state.groups[1].queue = queued
    assert verdict_of(exchange(handler, command(Command.STOP_TRAJ_MODE)).reply) == FAILURE
    assert cell.verbs("controller") == []
    assert "stop" not in cell.verbs("executor")


def test_stop_traj_mode_refuses_while_a_point_is_pending() -> None:
    handler, cell = gateway()
    with_points_outstanding(cell)
    assert verdict_of(exchange(handler, command(Command.STOP_TRAJ_MODE)).reply) == FAILURE
    assert cell.verbs("controller") == []


def test_stop_traj_mode_fails_when_the_controller_refuses() -> None:
    handler, cell = gateway()
    cell.replies["controller/stop_traj_mode"] = CommandReply(int(Result.FAILURE))
    assert verdict_of(exchange(handler, command(Command.STOP_TRAJ_MODE)).reply) == FAILURE


def test_disconnect_closes_without_a_reply() -> None:
    handler, cell = gateway()
    response = exchange(handler, command(Command.DISCONNECT))
    assert response.close
    assert response.reply is None
    assert cell.verbs("controller") == ["stop_traj_mode"]


def test_disconnect_that_cannot_stop_replies_failure_and_keeps_the_connection() -> None:
    handler, cell = gateway()
    cell.state.on_queue(0, queue(depth=4), NOW)
    response = exchange(handler, command(Command.DISCONNECT))
    assert not response.close
    assert verdict_of(response.reply) == FAILURE


def test_an_unknown_command_is_invalid_3006() -> None:
    handler, cell = gateway()
    request = msgspec.structs.replace(
        motion_ctrl(Command.STOP_MOTION),
        body=MotoMotionCtrl(0, 0, 200199, (0.0,) * 10),
    )
    reply = exchange(handler, request).reply
    assert verdict_of(reply) == (int(Result.INVALID), int(InvalidSubcode.COMMAND))
    assert cell.calls == []


# -- SELECT_TOOL ---------------------------------------------------------------------------
@pytest.mark.parametrize("tool", [TOOL_NUMBERS[0], 5, TOOL_NUMBERS[-1]])
def test_select_tool_asks_the_controller(tool: int) -> None:
    handler, cell = gateway(two_groups())
    reply = exchange(handler, select_tool(1, tool, sequence=9)).reply
    assert verdict_of(reply) == SUCCESS
    assert (reply_of(reply).group_no, reply_of(reply).sequence) == (1, 9)
    [call] = cell.calls
    assert (call.verb, call.request) == ("select_tool", CommandRequest(group=1, value=tool))


@pytest.mark.parametrize("tool", [TOOL_NUMBERS[0] - 1, TOOL_NUMBERS[-1] + 1, 1000])
def test_select_tool_refuses_a_tool_the_controller_does_not_have(tool: int) -> None:
    handler, cell = gateway()
    reply = exchange(handler, select_tool(0, tool)).reply
    assert verdict_of(reply) == (int(Result.INVALID), int(InvalidSubcode.DATA_TOOLNO))
    assert cell.calls == []


@pytest.mark.parametrize("group", [-1, 1, 4])
def test_select_tool_refuses_a_group_the_cell_does_not_have(group: int) -> None:
    handler, cell = gateway()
    reply = exchange(handler, select_tool(group, 1)).reply
    assert verdict_of(reply) == (int(Result.INVALID), int(InvalidSubcode.GROUPNO))
    assert cell.calls == []


def test_select_tool_fails_when_the_controller_is_silent() -> None:
    handler, cell = gateway()
    cell.replies["controller/select_tool"] = None
    assert verdict_of(exchange(handler, select_tool(0, 1)).reply) == FAILURE


# -- other types ---------------------------------------------------------------------------
def test_ping_is_answered() -> None:
    handler, _ = gateway()
    reply = exchange(handler, ping()).reply
    assert reply is not None
    assert (reply.msg_type, reply.comm_type, reply.reply_type) == (
        MsgType.PING,
        CommType.SERVICE_REPLY,
        ReplyType.SUCCESS,
    )
    assert reply.body == Empty()


def test_dh_parameters_for_the_groups_the_cell_has_and_zeros_beyond() -> None:
    cell = two_groups()
    handler, _ = gateway(cell)
    reply = exchange(handler, get_dh_parameters()).reply
    assert reply is not None
    body = reply.body
    assert isinstance(body, GetDhParametersReply)
    assert len(body.groups) == 4
    model = cell.groups[0].model
    assert list(body.groups[0][: len(model.dh)]) == [DhLink(*values) for values in model.dh]
    assert body.groups[0][len(model.dh) :] == (ZERO_LINK,) * (8 - len(model.dh))
    assert body.groups[2] == body.groups[3] == (ZERO_LINK,) * 8


def test_an_unknown_type_is_invalid_3003() -> None:
    handler, _ = gateway()
    reply = exchange(handler, UnknownMessage(99, 2, 0, b"")).reply
    assert verdict_of(reply) == (int(Result.INVALID), int(InvalidSubcode.MSGTYPE))


def test_a_type_without_a_handler_closes_the_connection() -> None:
    handler, _ = gateway()
    feedback = JointFeedback(0, 6, 0.0, (0.0,) * 10, (0.0,) * 10, (0.0,) * 10)
    response = exchange(handler, state_message(MsgType.JOINT_FEEDBACK, feedback))
    assert response.close
    assert response.reply is None


def test_m_registers_are_not_served_on_the_motion_port() -> None:
    handler, cell = gateway()
    reply = exchange(handler, read_mregister(5)).reply
    assert verdict_of(reply) == (int(Result.INVALID), int(InvalidSubcode.MSGTYPE))
    assert cell.calls == []


@pytest.mark.parametrize("m_register", [MsgType.MOTO_READ_MREGISTER, MsgType.MOTO_WRITE_MREGISTER])
def test_m_registers_of_any_length_are_unknown_on_the_motion_port(m_register: MsgType) -> None:
    handler, _ = gateway()
    error = PeerProtocolError("short", InvalidSubcode.MSGSIZE, msg_type=m_register)
    reply = reply_of(handler.error_reply(error))
    assert (reply.group_no, reply.sequence, reply.command) == (-1, -1, m_register)
    assert (reply.result, reply.subcode) == (Result.INVALID, InvalidSubcode.MSGTYPE)


def test_io_bits_are_served_on_the_motion_port_too() -> None:
    handler, cell = gateway()
    cell.replies["controller/read_bit"] = CommandReply(0, value=1)
    reply = exchange(handler, read_io_bit(27010)).reply
    assert reply is not None
    assert reply.body == ReadIOBitReply(1, 0)


def test_a_request_that_is_a_reply_is_processed_but_not_answered() -> None:
    handler, cell = gateway()
    request = msgspec.structs.replace(
        traj_point(0, 0, 0.0, ZEROS, ZEROS), comm_type=int(CommType.SERVICE_REPLY)
    )
    response = exchange(handler, request)
    assert response.reply is None
    assert not response.close
    assert len(cell.sent) == 1


def test_an_unreadable_frame_gets_the_invalid_reply() -> None:
    handler, _ = gateway()
    error = PeerProtocolError("short", InvalidSubcode.MSGSIZE, msg_type=14)
    reply = handler.error_reply(error)
    assert verdict_of(reply) == (int(Result.INVALID), int(InvalidSubcode.MSGSIZE))
    assert reply_of(reply).command == 14
