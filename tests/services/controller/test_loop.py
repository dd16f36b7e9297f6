"""The controller's loop against a scripted bus and a fake clock: the order of its work in a
pass, what it waits for, the status it publishes when due, the replies it sends after it, how
it asks for liveliness tokens, and how it stops. Nothing sleeps."""

from __future__ import annotations

import threading
from dataclasses import dataclass

from motocell.services.controller.core.dispatch import Dispatcher, FaultKind, Verb
from motocell.services.controller.core.io_table import IoTable
from motocell.services.controller.core.model import (
    OT_IO_CONNECTED,
    OT_MOTION_CONNECTED,
    SERVO_ON_DELAY_S,
    Controller,
)
from motocell.services.controller.inbox import (
    BadPayload,
    CommandQuery,
    ConnectionCounts,
    FaultQuery,
    IncMoveError,
    ReplyTo,
    Stop,
    TokensAnswered,
    TokensChanged,
)
from motocell.services.controller.loop import ControllerLoop
from motocell.shared.bus.liveness import ASK_AGAIN_S, AT_REST_HEARTBEAT_S, QUERY_TIMEOUT_S
from motocell.shared.bus.schemas import CommandReply, CommandRequest
from motocell.shared.config import ControllerModel
from motocell.shared.protocol.constants import InvalidSubcode, NotReadySubcode, Result
from motocell.shared.service import StopFlag
from tests.services.controller.fake_bus import WAIT_S, FakeClock, FakeControllerBus

REQUIRED = ["@motocell/c/alive/executor/0", "@motocell/c/alive/gateway/0"]
FIRST_SEQ = 1000
FIRST = FIRST_SEQ + 1
"""The first status's number."""


@dataclass
class Harness:
    clock: FakeClock
    bus: FakeControllerBus
    stop: StopFlag
    loop: ControllerLoop

    @property
    def model(self) -> Controller:
        return self.loop.dispatcher.model


def harness(*, whole: bool = True, blocking: bool = False) -> Harness:
    """A loop over a one-group controller; ``whole``: every other service's token present."""
    clock = FakeClock()
    bus = FakeControllerBus(clock, blocking=blocking)
    if whole:
        bus.tokens = set(REQUIRED)
    model = Controller(groups=1)
    io = IoTable(ControllerModel.YRC1000, model.outputs, model.set_output)
    dispatcher = Dispatcher[ReplyTo](model, io, REQUIRED, FIRST_SEQ)
    stop = StopFlag()
    return Harness(clock, bus, stop, ControllerLoop(dispatcher, bus, stop, clock))


def command(h: Harness, verb: Verb, name: str) -> CommandQuery:
    """``verb`` with an empty request, its reply logged as ``reply <name>``."""
    return CommandQuery(verb, CommandRequest(), h.bus.reply_to(name))


# -- a pass ---------------------------------------------------------------------------------


def test_a_pass_asks_waits_hands_over_publishes_then_replies() -> None:
    h = harness()
    reset = h.bus.reply_to("reset")
    h.bus.arrive(CommandQuery(Verb.RESET_ALARM, CommandRequest(), reset), Stop())
    h.loop.serve()
    assert h.bus.log == ["ask", "wait 0", f"publish {FIRST}", "reply reset"]
    assert reset.replies == [CommandReply(Result.SUCCESS, status_seq=FIRST)]


def test_every_arrival_of_a_wait_is_handled_in_that_pass() -> None:
    h = harness()
    h.bus.arrive(command(h, Verb.RESET_ALARM, "a"), command(h, Verb.STOP_SERVOS, "b"), Stop())
    h.loop.serve()
    assert h.bus.log == ["ask", "wait 0", f"publish {FIRST}", "reply a", "reply b"]


def test_an_unchanged_status_is_published_again_at_the_heartbeat_it_announced() -> None:
    h = harness()
    h.bus.idle()
    h.bus.idle()
    h.bus.arrive(Stop())
    h.loop.serve()
    assert h.bus.waits == [0.0, AT_REST_HEARTBEAT_S, AT_REST_HEARTBEAT_S]
    assert [status.seq for status in h.bus.published] == [FIRST, FIRST + 1]


def test_a_changed_status_is_published_in_the_pass_that_changed_it() -> None:
    h = harness()
    estop = FaultQuery(FaultKind.ESTOP, CommandRequest(value=1), h.bus.reply_to("estop"))
    h.bus.idle()
    h.bus.arrive(estop, Stop())
    h.loop.serve()
    assert [status.estop for status in h.bus.published] == [False, True]
    assert h.bus.log[-2:] == [f"publish {FIRST + 1}", "reply estop"]


def test_a_command_that_waits_for_the_servo_is_answered_when_its_time_comes() -> None:
    h = harness()
    servo = h.bus.reply_to("servo")
    h.bus.arrive(CommandQuery(Verb.START_SERVOS, CommandRequest(), servo))
    h.bus.idle()
    h.bus.arrive(Stop())
    h.loop.serve()
    assert h.bus.waits[1] == SERVO_ON_DELAY_S  # woken by the servo's power-up
    assert h.bus.log.count("reply servo") == 1
    assert h.bus.log.index("reply servo") > h.bus.log.index("wait 0.05")
    [reply] = servo.replies
    assert (reply.result, reply.status_seq) == (Result.SUCCESS, h.bus.published[-1].seq)
    assert h.bus.published[-1].servo_on


# -- what arrives ---------------------------------------------------------------------------


def test_a_bad_query_payload_is_answered_invalid_and_the_loop_goes_on() -> None:
    h = harness()
    bad = h.bus.reply_to("bad")
    h.bus.arrive(BadPayload("cmd/select_tool", "truncated", bad))
    h.bus.arrive(command(h, Verb.RESET_ALARM, "next"), Stop())
    h.loop.serve()
    assert bad.replies == [
        CommandReply(Result.INVALID, InvalidSubcode.DATA, detail="truncated", status_seq=FIRST)
    ]
    assert "reply next" in h.bus.log


def test_a_bad_notice_gets_no_reply_and_changes_nothing() -> None:
    h, untouched = harness(), harness()
    h.bus.arrive(BadPayload("connections", "truncated", None), Stop())
    untouched.bus.arrive(Stop())
    h.loop.serve()
    untouched.loop.serve()
    assert h.bus.log == untouched.bus.log
    assert h.bus.published == untouched.bus.published


def test_connection_counts_set_the_connected_outputs() -> None:
    h = harness()
    h.bus.arrive(ConnectionCounts(CommandRequest(args=[1, -1, 1])), Stop())
    h.loop.serve()
    assert (h.model.outputs[OT_MOTION_CONNECTED], h.model.outputs[OT_IO_CONNECTED]) == (1, 1)


def test_an_incmove_error_is_in_the_next_status() -> None:
    h = harness()
    h.bus.arrive(IncMoveError(CommandReply(Result.FAILURE, detail="increment batch gap")), Stop())
    h.loop.serve()
    assert h.bus.published[-1].incmove_error


def test_a_fault_is_applied_and_acknowledged() -> None:
    h = harness()
    hold = h.bus.reply_to("hold")
    h.bus.arrive(FaultQuery(FaultKind.HOLD, CommandRequest(value=1), hold), Stop())
    h.loop.serve()
    assert h.bus.published[-1].hold
    assert [reply.result for reply in hold.replies] == [Result.SUCCESS]


# -- liveliness tokens ----------------------------------------------------------------------


def test_the_tokens_present_at_start_are_in_the_first_status() -> None:
    h = harness(whole=False)
    h.bus.tokens = {REQUIRED[0]}
    h.bus.arrive(Stop())
    h.loop.serve()
    first = h.bus.published[0]
    assert first.missing_services == ["gateway/0"]
    assert first.not_ready_subcode == NotReadySubcode.SERVO_OFF


def test_a_change_of_tokens_is_read_when_it_arrives() -> None:
    h = harness(whole=False)
    h.bus.idle()
    h.bus.arrive(TokensChanged(), tokens=REQUIRED)
    h.bus.arrive(Stop())
    h.loop.serve()
    missing = [status.missing_services for status in h.bus.published]
    assert missing == [["executor/0", "gateway/0"], []]


def test_a_whole_cell_is_asked_for_its_tokens_once() -> None:
    h = harness()
    h.bus.arrive(TokensAnswered())
    for _ in range(3):
        h.bus.idle()
    h.bus.arrive(Stop())
    h.loop.serve()
    assert h.bus.asked_at == [0.0]
    assert h.clock.now == 3 * AT_REST_HEARTBEAT_S


def test_while_a_service_is_missing_the_tokens_are_asked_again_after_the_answer() -> None:
    h = harness(whole=False)
    h.bus.tokens = {REQUIRED[0]}
    h.bus.arrive(TokensAnswered())
    h.bus.idle()
    h.bus.arrive(Stop())
    h.loop.serve()
    assert h.bus.asked_at == [0.0, ASK_AGAIN_S]


def test_a_question_never_answered_is_asked_again_after_its_time_out() -> None:
    h = harness(whole=False)
    for _ in range(3):  # at 0 s, and at the heartbeats 1 s and 2 s
        h.bus.idle()
    h.bus.arrive(Stop())
    h.loop.serve()
    assert h.bus.asked_at == [0.0, QUERY_TIMEOUT_S + ASK_AGAIN_S]


# -- stopping -------------------------------------------------------------------------------


def test_stop_ends_the_loop_after_its_pass() -> None:
    h = harness()
    h.bus.arrive(Stop(), command(h, Verb.RESET_ALARM, "last"))
    h.loop.serve()
    assert h.bus.log == ["ask", "wait 0", f"publish {FIRST}", "reply last"]


def test_raising_the_stop_flag_wakes_the_waiting_loop() -> None:
    h = harness(blocking=True)

    def stop_once_waiting() -> None:
        assert h.bus.waiting.wait(WAIT_S)
        h.stop.set()

    stopper = threading.Thread(target=stop_once_waiting)
    stopper.start()
    h.loop.run()
    stopper.join()
    assert h.bus.waited == [Stop()]
    assert "stop waiting" in h.bus.log
