"""Figure 11's alternation, and the directions of figure 4's runs."""

from __future__ import annotations

from motocell.tools.bench.bench_headroom import ALONE, BESIDE, alternating
from motocell.tools.bench.bench_roundtrip import direction_index


def test_the_conditions_alternate_alone_first() -> None:
    assert alternating(3) == [ALONE, BESIDE, ALONE, BESIDE, ALONE, BESIDE]


def test_interleaved_conditions_go_the_same_way_in_each_round() -> None:
    # Figure 4 alone: + - +; two conditions: A+ B+ A- B- A+ B+.
    assert [direction_index(i, 1) % 2 for i in range(3)] == [0, 1, 0]
    assert [direction_index(i, 2) % 2 for i in range(6)] == [0, 0, 1, 1, 0, 0]
