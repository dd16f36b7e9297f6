"""The loaded-priority experiment's pure parts: its variants, their order, counting stall
episodes, the summary table."""

from __future__ import annotations

import argparse

import pytest

from motocell.shared.bus.schemas import Alarm, ControllerStatus
from motocell.shared.realtime import RT_PRIORITY, SERVICE_PRIORITY
from motocell.testing.statuses import ready_status
from motocell.tools.bench.loaded_priority import (
    ALL_KINDS,
    STALL_KINDS,
    VARIANTS,
    Run,
    episodes,
    parse_variants,
    rotated,
    spread,
    summary,
)


def test_variants_are_named_in_a_list() -> None:
    assert [v.name for v in parse_variants("today, rr,nice")] == ["today", "rr", "nice"]


@pytest.mark.parametrize("text", ["", "today,fast"])
def test_an_unknown_or_missing_variant_is_refused(text: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError, match="choose from today"):
        parse_variants(text)


def test_every_variant_stays_below_the_clock() -> None:
    for variant in VARIANTS.values():
        if variant.policy == "rr":
            assert variant.value < RT_PRIORITY


def test_the_rr_variant_is_what_the_services_ask_for() -> None:
    assert (VARIANTS["rr"].policy, VARIANTS["rr"].value) == ("rr", SERVICE_PRIORITY)
    assert VARIANTS["rr"].kinds == ALL_KINDS
    assert VARIANTS["rr-stall"].kinds == STALL_KINDS == {"controller", "interpolator", "gateway"}


def test_each_variant_takes_each_place_in_turn() -> None:
    variants = parse_variants("today,nice,rr")
    orders = [[v.name for v in rotated(variants, r)] for r in range(4)]
    assert orders == [
        ["today", "nice", "rr"],
        ["nice", "rr", "today"],
        ["rr", "today", "nice"],
        ["today", "nice", "rr"],
    ]


def status(*alarms: int, subcode: int = 0) -> ControllerStatus:
    return ready_status(
        seq=0,
        alarms=[Alarm(code) for code in alarms],
        motion_ready=not alarms and not subcode,
        not_ready_subcode=subcode,
        tools=[],
    )


def test_an_alarm_or_a_not_ready_episode_counts_once_however_many_statuses_repeat_it() -> None:
    statuses = [
        status(),
        status(4200, subcode=5001),
        status(4200, subcode=5001),
        status(),
        status(subcode=5012),
        status(subcode=5012),
        status(4200, subcode=5012),
        status(),
    ]
    assert episodes(statuses) == (2, 1)


def test_other_alarms_are_not_stalls() -> None:
    assert episodes([status(4100), status()]) == (0, 0)


def test_a_spread_is_the_median_and_the_range() -> None:
    assert spread([3.0, 1.0, 2.0]) == "2 [1-3]"
    assert spread([0.5]) == "0.5"


def run(variant: str, aborted: int) -> Run:
    return Run(
        variant=variant,
        repetition=0,
        trajectories=8,
        aborted=aborted,
        refusals=[],
        stall_alarms=aborted,
        incmove_episodes=0,
        missed_periods=1,
        lateness_p99_us=60.0,
        lateness_max_us=5000.0,
        reply_p50_ms=0.3,
        reply_p99_ms=9.0,
        status_gap_max_ms=150.0,
        hog_cpu_percent=80.0,
        loadavg=48.0,
        seconds=45.0,
        scheduling={},
    )


def test_the_summary_has_a_row_per_variant_run_in_the_order_asked() -> None:
    lines = summary(
        [run("rr", 0), run("today", 6), run("today", 0), run("today", 2)],
        parse_variants("today,nice,rr"),
    )
    assert lines[0].startswith("| variant | runs | trajectories | aborted | 4200 |")
    assert len(lines) == 4  # no row for nice: it did not run
    assert lines[2].startswith("| today | 3 | 24 | 2 [0-6] | 2 [0-6] |")
    assert lines[3].startswith("| rr | 1 | 8 | 0 | 0 |")
