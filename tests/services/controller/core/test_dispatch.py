"""Dispatcher: decoded commands, faults and notices against the controller model; replies wait
for their status. Queries are plain strings here; time is passed in, nothing sleeps."""

from __future__ import annotations

import math

import pytest

from motocell.services.controller.core.dispatch import Dispatcher, FaultKind, Verb
from motocell.services.controller.core.io_table import IoTable
from motocell.services.controller.core.model import (
    OT_IO_CONNECTED,
    OT_MOTION_CONNECTED,
    OT_ROS_DONE,
    OT_ROS_READY,
    OT_STATE_CONNECTED,
    SERVO_ON_DELAY_S,
    START_TIMEOUT_S,
    Controller,
)
from motocell.shared.bus.liveness import (
    ASK_AGAIN_S,
    AT_REST_HEARTBEAT_S,
    HEARTBEAT_S,
    QUERY_TIMEOUT_S,
)
from motocell.shared.bus.schemas import Alarm, CommandReply, CommandRequest, encode
from motocell.shared.config import ControllerModel
from motocell.shared.protocol.constants import InvalidSubcode, IoResult, NotReadySubcode, Result

REQUIRED = ["@motocell/c/alive/executor/0", "@motocell/c/alive/gateway/0"]
FIRST_SEQ = 1000
WRITABLE_BIT = 10010
"""A general output every model lets a client write."""


def dispatcher(groups: int = 1) -> Dispatcher[str]:
    model = Controller(groups)
    io = IoTable(ControllerModel.YRC1000, model.outputs, model.set_output)
    return Dispatcher(model, io, REQUIRED, FIRST_SEQ)


def replies(d: Dispatcher[str]) -> dict[str, CommandReply]:
    return dict(d.take_replies())


def answer(d: Dispatcher[str], verb: Verb, request: CommandRequest | None = None) -> CommandReply:
    """One command at t = 0 that is answered at once."""
    d.command(verb, request or CommandRequest(), "q", 0.0)
    return replies(d)["q"]


def result(reply: CommandReply) -> tuple[int, int]:
    return reply.result, reply.subcode


def whole(d: Dispatcher[str]) -> None:
    """Every other service present, and asked for once: no question for tokens is due."""
    d.services_present(REQUIRED)
    d.tokens_asked(0.0)


def ready(d: Dispatcher[str]) -> None:
    """Motion-ready by START_TRAJ_MODE from servo off: 0.10 s of simulated time."""
    d.command(Verb.START_TRAJ_MODE, CommandRequest(), "ready", 0.0)
    for now in (0.05, 0.10):
        d.advance(now)
    assert result(replies(d)["ready"]) == (Result.SUCCESS, 0)


# -- servo power --------------------------------------------------------------------------


def test_start_servos_answers_once_the_servo_is_on() -> None:
    d = dispatcher()
    d.command(Verb.START_SERVOS, CommandRequest(), "q", 0.0)
    assert replies(d) == {}
    d.advance(SERVO_ON_DELAY_S)
    assert result(replies(d)["q"]) == (Result.SUCCESS, 0)
    assert d.model.servo_on


def test_start_servos_under_estop_fails_at_once() -> None:
    d = dispatcher()
    d.model.set_estop(True)
    assert result(answer(d, Verb.START_SERVOS)) == (Result.FAILURE, 0)


def test_start_servos_that_never_completes_fails_at_the_deadline() -> None:
    d = dispatcher()
    d.command(Verb.START_SERVOS, CommandRequest(), "q", 0.0)
    d.model.set_servo(False, 0.01)  # a servo-off fault cancels the power-up
    d.advance(START_TIMEOUT_S - 0.01)
    assert replies(d) == {}
    d.advance(START_TIMEOUT_S)
    assert result(replies(d)["q"]) == (Result.FAILURE, 0)


def test_start_servos_leaves_energy_saving() -> None:
    d = dispatcher()
    d.model.eco = True
    d.command(Verb.START_SERVOS, CommandRequest(), "q", 0.0)
    assert not d.model.eco


def test_stop_servos_turns_the_servo_off() -> None:
    d = dispatcher()
    ready(d)
    assert result(answer(d, Verb.STOP_SERVOS)) == (Result.SUCCESS, 0)
    assert not d.model.servo_on
    assert not d.model.motion_ready()


def test_reset_alarm_clears_alarms_and_errors() -> None:
    d = dispatcher()
    d.model.raise_alarm(4107)
    d.model.set_error(3)
    assert result(answer(d, Verb.RESET_ALARM)) == (Result.SUCCESS, 0)
    assert (d.model.alarms, d.model.error) == ([], 0)


# -- trajectory mode ----------------------------------------------------------------------


def test_start_traj_mode_answers_when_motion_ready() -> None:
    d = dispatcher()
    d.command(Verb.START_TRAJ_MODE, CommandRequest(), "q", 0.0)
    d.advance(0.05)
    assert replies(d) == {}
    d.advance(0.10)
    assert result(replies(d)["q"]) == (Result.SUCCESS, 0)


def test_start_traj_mode_decided_at_once_is_answered_at_once() -> None:
    d = dispatcher()
    d.model.set_estop(True)
    assert result(answer(d, Verb.START_TRAJ_MODE)) == (Result.NOT_READY, NotReadySubcode.ESTOP)


def test_start_traj_mode_times_out_with_the_reason() -> None:
    d = dispatcher()
    d.command(Verb.START_TRAJ_MODE, CommandRequest(), "q", 0.0)
    d.model.set_hold(True)
    d.advance(START_TIMEOUT_S)
    assert result(replies(d)["q"]) == (Result.NOT_READY, NotReadySubcode.HOLD)


def test_stop_traj_mode_releases_the_job() -> None:
    d = dispatcher()
    ready(d)
    assert result(answer(d, Verb.STOP_TRAJ_MODE)) == (Result.SUCCESS, 0)
    assert d.model.outputs[OT_ROS_DONE] == 1
    d.advance(0.2)
    assert not d.model.operating


def test_an_earlier_waiting_reply_is_answered_when_a_later_command_is_handled() -> None:
    d = dispatcher()
    d.command(Verb.START_SERVOS, CommandRequest(), "first", 0.0)
    d.model.advance(SERVO_ON_DELAY_S)
    d.command(Verb.START_SERVOS, CommandRequest(), "second", SERVO_ON_DELAY_S)
    assert set(replies(d)) == {"first", "second"}


# -- positions, tools, I/O ----------------------------------------------------------------


def test_select_tool_sets_the_groups_tool() -> None:
    d = dispatcher(groups=2)
    assert result(answer(d, Verb.SELECT_TOOL, CommandRequest(group=1, value=7))) == (0, 0)
    assert d.model.tools == [0, 7]


@pytest.mark.parametrize("group", [-1, 2])
def test_select_tool_for_a_group_the_cell_lacks_is_invalid(group: int) -> None:
    reply = answer(dispatcher(groups=2), Verb.SELECT_TOOL, CommandRequest(group=group, value=1))
    assert result(reply) == (Result.INVALID, InvalidSubcode.GROUPNO)


@pytest.mark.parametrize("tool", [-1, 64])
def test_select_tool_beyond_the_tool_files_is_invalid(tool: int) -> None:
    reply = answer(dispatcher(), Verb.SELECT_TOOL, CommandRequest(value=tool))
    assert result(reply) == (Result.INVALID, InvalidSubcode.DATA_TOOLNO)


def test_write_then_read_a_bit() -> None:
    d = dispatcher()
    write = answer(d, Verb.WRITE_BIT, CommandRequest(value=WRITABLE_BIT, args=[1]))
    assert write.result == IoResult.OK
    read = answer(d, Verb.READ_BIT, CommandRequest(value=WRITABLE_BIT))
    assert (read.result, read.value) == (IoResult.OK, 1)


def test_a_write_without_a_value_is_refused_as_a_bad_value() -> None:
    reply = answer(dispatcher(), Verb.WRITE_BIT, CommandRequest(value=WRITABLE_BIT))
    assert reply.result == IoResult.WRITE_VALUE_INVALID


def test_a_read_of_an_unknown_address_reports_it() -> None:
    reply = answer(dispatcher(), Verb.READ_BIT, CommandRequest(value=9))
    assert reply.result == IoResult.READ_ADDRESS_INVALID


def test_write_then_read_a_register() -> None:
    d = dispatcher()
    assert answer(d, Verb.WRITE_REGISTER, CommandRequest(value=5, args=[1234])).result == 0
    assert answer(d, Verb.READ_REGISTER, CommandRequest(value=1_000_005)).value == 1234


def test_write_then_read_a_group() -> None:
    d = dispatcher()
    assert answer(d, Verb.WRITE_GROUP, CommandRequest(value=1001, args=[0xA5])).result == 0
    assert answer(d, Verb.READ_GROUP, CommandRequest(value=1001)).value == 0xA5


# -- faults -------------------------------------------------------------------------------


def inject(d: Dispatcher[str], kind: FaultKind, value: int = 1, *args: int) -> None:
    d.fault(kind, CommandRequest(value=value, args=list(args)), "f", 0.0)
    assert result(replies(d)["f"]) == (Result.SUCCESS, 0)


@pytest.mark.parametrize("kind", FaultKind)
def test_every_fault_is_acknowledged(kind: FaultKind) -> None:
    inject(dispatcher(), kind)


def test_estop_fault_stops_motion_and_clears_again() -> None:
    d = dispatcher()
    ready(d)
    inject(d, FaultKind.ESTOP)
    assert (d.model.estop, d.model.servo_on, d.model.motion_ready()) == (True, False, False)
    inject(d, FaultKind.ESTOP, 0)
    assert not d.model.estop


def test_hold_fault() -> None:
    d = dispatcher()
    inject(d, FaultKind.HOLD)
    assert d.model.hold


def test_alarm_fault_with_code_and_subcode() -> None:
    d = dispatcher()
    inject(d, FaultKind.ALARM, 1, 4107, 3)
    assert d.model.alarms == [Alarm(4107, 3)]


def test_alarm_fault_without_a_code_raises_9999() -> None:
    d = dispatcher()
    inject(d, FaultKind.ALARM)
    assert d.model.alarms == [Alarm(9999, 0)]


def test_alarm_fault_off_clears_the_alarms() -> None:
    d = dispatcher()
    inject(d, FaultKind.ALARM, 1, 4107)
    inject(d, FaultKind.ALARM, 0)
    assert d.model.alarms == []


@pytest.mark.parametrize(("value", "args", "error"), [(1, [42], 42), (1, [], 9999), (0, [42], 0)])
def test_error_fault(value: int, args: list[int], error: int) -> None:
    d = dispatcher()
    inject(d, FaultKind.ERROR, value, *args)
    assert d.model.error == error


def test_servo_fault_powers_up_after_the_delay() -> None:
    d = dispatcher()
    inject(d, FaultKind.SERVO)
    d.advance(SERVO_ON_DELAY_S)
    assert d.model.servo_on


@pytest.mark.parametrize(
    ("kind", "attribute"), [(FaultKind.PLAY, "play"), (FaultKind.REMOTE, "remote")]
)
def test_mode_faults_switch_the_mode(kind: FaultKind, attribute: str) -> None:
    d = dispatcher()
    inject(d, kind, 0)
    assert getattr(d.model, attribute) is False
    inject(d, kind, 1)
    assert getattr(d.model, attribute) is True


def test_pfl_fault_while_ready_latches() -> None:
    d = dispatcher()
    ready(d)
    inject(d, FaultKind.PFL)
    inject(d, FaultKind.PFL, 0)
    assert d.model.pfl_active
    assert d.model.not_ready_subcode() == NotReadySubcode.PFL_ACTIVE


def test_ot889_fault_drops_readiness() -> None:
    d = dispatcher()
    ready(d)
    inject(d, FaultKind.OT889, 0)
    assert d.model.outputs[OT_ROS_READY] == 0
    assert not d.model.motion_ready()


# -- notices ------------------------------------------------------------------------------


def test_missing_services_make_the_cell_not_ready() -> None:
    d = dispatcher()
    ready(d)
    d.services_present({REQUIRED[0]})
    assert d.model.missing_services == ["gateway/0"]
    assert d.model.not_ready_subcode() == NotReadySubcode.INC_MOVE_ERROR


def test_all_services_back_make_it_ready_again() -> None:
    d = dispatcher()
    ready(d)
    d.services_present(set())
    d.services_present({*REQUIRED, "@motocell/c/alive/broadcaster/0"})
    assert d.model.missing_services == []
    assert d.model.motion_ready()


def test_a_service_that_left_and_came_back_between_looks_is_an_incmove_error() -> None:
    """Its DELETE and PUT came together: the cell is whole again, but a not-ready status (or
    increments) may have been lost meanwhile; START_TRAJ_MODE ends it, as for any IncMove
    error."""
    d = dispatcher()
    whole(d)
    ready(d)
    d.services_present(REQUIRED, departed={REQUIRED[0]})
    assert d.model.missing_services == []
    assert not d.model.motion_ready()
    assert d.model.not_ready_subcode() == NotReadySubcode.INC_MOVE_ERROR
    assert d.model.begin_start_traj_mode(0.0) == (Result.SUCCESS, 0)


def test_a_service_that_left_and_came_back_while_starting_is_no_error() -> None:
    d = dispatcher()
    d.services_present(REQUIRED, departed={REQUIRED[0]})
    assert not d.model.incmove_error


def test_a_start_is_quiet_and_a_loss_after_it_is_a_warning(
    caplog: pytest.LogCaptureFixture,
) -> None:
    d = dispatcher()
    caplog.set_level("INFO")
    d.services_present({REQUIRED[0]})
    d.services_present({*REQUIRED, "@motocell/c/alive/broadcaster/0"})
    assert [r.levelname for r in caplog.records] == ["INFO", "INFO"]
    d.services_present({REQUIRED[0]})
    assert caplog.records[-1].levelname == "WARNING"
    assert "services missing: gateway/0" in caplog.records[-1].getMessage()


def test_the_tokens_are_asked_for_at_start() -> None:
    d = dispatcher()
    d.services_present(REQUIRED)
    assert d.next_token_question() == 0.0
    assert d.next_deadline() == 0.0


def test_a_whole_cell_is_not_asked_again() -> None:
    d = dispatcher()
    d.services_present(REQUIRED)
    d.tokens_asked(0.0)
    d.tokens_answered(0.01)
    assert d.next_token_question() == math.inf


def test_while_a_service_is_missing_the_tokens_are_asked_again() -> None:
    """As ``Asking`` says: a while after the last question ended, or after its time-out."""
    d = dispatcher()
    d.services_present({REQUIRED[0]})
    d.tokens_asked(0.0)
    assert d.next_token_question() == QUERY_TIMEOUT_S + ASK_AGAIN_S
    d.tokens_answered(0.2)
    assert d.next_token_question() == 0.2 + ASK_AGAIN_S
    d.status_due(0.2)
    assert d.next_deadline() == 0.2 + ASK_AGAIN_S


def test_a_service_lost_after_the_cell_was_whole_is_asked_for_again() -> None:
    d = dispatcher()
    d.services_present(REQUIRED)
    d.tokens_asked(0.0)
    d.tokens_answered(0.01)
    d.services_present({REQUIRED[0]})
    assert d.next_token_question() == 0.01 + ASK_AGAIN_S


def test_connection_counts_set_the_connected_outputs() -> None:
    d = dispatcher()
    d.connections(CommandRequest(args=[1, 0, 2]))
    outputs = d.model.outputs
    assert (outputs[OT_MOTION_CONNECTED], outputs[OT_STATE_CONNECTED]) == (1, 0)
    assert outputs[OT_IO_CONNECTED] == 1


def test_the_gateway_and_the_broadcaster_each_report_their_own_ports() -> None:
    d = dispatcher()
    d.connections(CommandRequest(args=[-1, 2, -1]))  # the broadcaster: the state port
    d.connections(CommandRequest(args=[1, -1, 0]))  # the gateway: motion and I/O
    outputs = d.model.outputs
    assert (outputs[OT_MOTION_CONNECTED], outputs[OT_STATE_CONNECTED]) == (1, 1)
    assert outputs[OT_IO_CONNECTED] == 0
    d.connections(CommandRequest(args=[-1, 0, -1]))
    assert (outputs[OT_MOTION_CONNECTED], outputs[OT_STATE_CONNECTED]) == (1, 0)


def test_short_connection_counts_mean_no_clients() -> None:
    d = dispatcher()
    d.connections(CommandRequest(args=[1]))
    assert (d.model.outputs[OT_STATE_CONNECTED], d.model.outputs[OT_IO_CONNECTED]) == (0, 0)


def test_incmove_error_notice_stops_motion() -> None:
    d = dispatcher()
    ready(d)
    d.incmove_error(CommandReply(Result.FAILURE, 0, detail="increment batch gap"))
    assert d.model.not_ready_subcode() == NotReadySubcode.INC_MOVE_ERROR
    assert d.model.alarms == []


SOFT_LIMIT = CommandReply(Result.FAILURE, 1, value=4416, detail="axis 0 past its range")


def soft_limit_hit() -> Dispatcher[str]:
    """A ready controller whose executor refused an increment at a range limit (group 1)."""
    d = dispatcher(groups=2)
    ready(d)
    d.incmove_error(SOFT_LIMIT)
    return d


def test_a_soft_limit_notice_raises_its_alarm_and_stops_motion() -> None:
    d = soft_limit_hit()
    status = d.model.status()
    assert status.alarms == [Alarm(4416, 1)]
    assert not status.motion_ready
    assert status.not_ready_subcode == NotReadySubcode.ALARM
    assert not status.incmove_error


def test_a_repeated_stall_notice_raises_one_alarm() -> None:
    d = dispatcher()
    ready(d)
    stall = CommandReply(Result.FAILURE, value=4200, detail="tick 3000 ms late")
    d.incmove_error(stall)
    d.incmove_error(stall)
    assert d.model.status().alarms == [Alarm(4200)]
    assert d.model.not_ready_subcode() == NotReadySubcode.ALARM


def test_reset_alarm_then_start_traj_mode_recovers_from_a_soft_limit() -> None:
    d = soft_limit_hit()
    assert result(answer(d, Verb.RESET_ALARM)) == (Result.SUCCESS, 0)
    assert d.model.alarms == []
    assert not d.model.motion_ready()
    ready(d)
    assert d.model.motion_ready()


def test_start_traj_mode_alone_recovers_from_a_soft_limit() -> None:
    d = soft_limit_hit()
    ready(d)
    assert d.model.alarms == []
    assert d.model.motion_ready()


def test_a_bad_query_payload_is_answered_invalid() -> None:
    d = dispatcher()
    d.bad_payload("cmd/select_tool", "q", "truncated")
    reply = replies(d)["q"]
    assert result(reply) == (Result.INVALID, InvalidSubcode.DATA)
    assert reply.detail == "truncated"


def test_a_bad_notice_gets_no_reply() -> None:
    d = dispatcher()
    d.bad_payload("connections", None, "truncated")
    assert replies(d) == {}


# -- status and replies -------------------------------------------------------------------


def test_the_first_status_is_always_due_and_numbered_after_first_seq() -> None:
    status = dispatcher().status_due(0.0)
    assert status is not None
    assert status.seq == FIRST_SEQ + 1


def test_an_unchanged_status_waits_for_the_heartbeat_it_announced() -> None:
    """Nothing can move: the slow heartbeat; the dispatcher's next deadline is the refresh."""
    d = dispatcher()
    whole(d)
    first = d.status_due(0.0)
    assert first is not None
    assert not first.motion_ready
    assert first.heartbeat_ms == AT_REST_HEARTBEAT_S * 1000
    assert d.next_deadline() == AT_REST_HEARTBEAT_S
    assert d.status_due(AT_REST_HEARTBEAT_S / 2) is None
    refreshed = d.status_due(AT_REST_HEARTBEAT_S)
    assert refreshed is not None
    assert refreshed.seq == FIRST_SEQ + 2


def test_a_motion_ready_status_announces_the_short_heartbeat() -> None:
    d = dispatcher()
    whole(d)
    ready(d)
    status = d.status_due(10.0)
    assert status is not None
    assert status.motion_ready
    assert status.heartbeat_ms == HEARTBEAT_S * 1000
    assert d.next_deadline() == 10.0 + HEARTBEAT_S


def test_a_changed_status_is_due_at_once() -> None:
    d = dispatcher()
    d.status_due(0.0)
    inject(d, FaultKind.ESTOP)
    status = d.status_due(0.001)
    assert status is not None
    assert status.estop


def test_replies_name_the_status_published_before_them() -> None:
    d = dispatcher()
    d.status_due(0.0)
    d.fault(FaultKind.ESTOP, CommandRequest(value=1), "f", 0.0)
    d.status_due(0.001)
    assert replies(d)["f"].status_seq == FIRST_SEQ + 2


def test_replies_are_taken_once() -> None:
    d = dispatcher()
    answer(d, Verb.RESET_ALARM)
    assert d.take_replies() == []


# -- any request --------------------------------------------------------------------------

ANY_REQUESTS = [
    CommandRequest(),
    CommandRequest(value=1),
    CommandRequest(group=-(2**63), value=-(2**63), args=[-(2**63)] * 3),
    CommandRequest(group=2**64 - 1, value=2**64 - 1, args=[2**64 - 1] * 3),
]
"""Requests that decode: empty, bare, and every field at the ends of what msgpack carries."""


@pytest.mark.parametrize("request_", ANY_REQUESTS)
def test_any_request_that_decodes_gets_one_reply_and_a_status_that_encodes(
    request_: CommandRequest,
) -> None:
    for handle in [*Verb, *FaultKind]:
        d = dispatcher()
        if isinstance(handle, Verb):
            d.command(handle, request_, handle, 0.0)
        else:
            d.fault(handle, request_, handle, 0.0)
        d.advance(START_TIMEOUT_S)
        status = d.status_due(START_TIMEOUT_S)
        assert status is not None
        encode(status)
        [(replied_to, reply)] = d.take_replies()
        assert replied_to == handle
        encode(reply)
