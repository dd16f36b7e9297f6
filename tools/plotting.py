"""Drawing a recording: the figure ``motocell plot`` saves (its help describes the panels).

matplotlib is in the ``tools`` extra, and slow to import: only ``motocell plot`` (and tests)
import this module.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from motocell.shared.bus import catalog
from motocell.tools.recording import Recording

WIDTH_IN = 12.0
ROW_HEIGHT_IN = 2.5
DPI = 100
JOINT_STYLE: dict[str, Literal["--", "-"]] = {"commanded": "--", "feedback": "-"}
PANELS_PER_GROUP = 3
"""Positions, following error, velocities."""
GAP_PERIODS = 3
"""The tick panels' lines go on across at most this many periods of the executor's clock from
one recorded tick to the next (tick numbers count its periods): across a tick or two the
recording lacks (lost on a loaded machine), a line stands for what the ticks between were,
and at the 4 ms default period those 12 ms are narrower than a pixel of a plot a few seconds
long. A longer step is a span the clock did not tick through (it rested: docs/timing.md, the
clock at rest) and is left a gap, as is a tick sent again (its resting tick, once a second)."""


@dataclass
class CellSeries:
    """The samples of one cell that the plot needs, in log-time order."""

    first_ns: int
    state_ns: list[int] = field(default_factory=list)
    states: list[dict[str, Any]] = field(default_factory=list)
    tick_ns: list[int] = field(default_factory=list)
    ticks: list[dict[str, Any]] = field(default_factory=list)


def collect(recording: Recording) -> dict[str, CellSeries]:
    """``state`` and ``executor/tick`` of every cell in the recording, a cut one too (what
    it holds); ValueError with one line for a file that is not an MCAP file."""
    cells: dict[str, CellSeries] = {}
    for key, log_ns, payload in recording.messages():
        name = catalog.cell_of(key)
        series = cells.setdefault(name, CellSeries(first_ns=log_ns))
        suffix = catalog.suffix_of(key)
        if suffix == "state":
            series.state_ns.append(log_ns)
            series.states.append(payload)
        elif suffix == "executor/tick":
            series.tick_ns.append(log_ns)
            series.ticks.append(payload)
    return cells


def choose_cell(cells: dict[str, CellSeries], cell: str | None, path: str | Path) -> str:
    with_state = sorted(name for name, series in cells.items() if series.states)
    if cell is not None:
        if cell not in with_state:
            raise ValueError(f"{path}: no state samples of cell {cell!r} (has: {with_state})")
        return cell
    if not with_state:
        raise ValueError(f"{path}: no state samples in the recording")
    if len(with_state) > 1:
        raise ValueError(f"{path}: the recording holds cells {with_state}; choose one with --cell")
    return with_state[0]


def plot_recording(recording: Recording, out: str | Path, cell: str | None = None) -> Figure:
    """Plot one cell of a recording into the PNG ``out``; return the figure that was saved.

    Lines carry a ``gid`` (``group<g>/joint<j>/commanded``, ``.../feedback``,
    ``.../following_error``, ``.../velocity``, ``.../velocity/commanded``, ``group<g>/depth``,
    ``lateness``) so callers can find each series; the tick panels' lines hold a NaN (x and y)
    where they break (``tick_gaps``).
    """
    path = recording.path
    cells = collect(recording)
    name = choose_cell(cells, cell, path)
    series = cells[name]
    groups = len(series.states[0]["groups"])
    rows = PANELS_PER_GROUP * groups + 2
    # A bare Figure on the Agg canvas: no pyplot, so no global figure registry and no GUI.
    figure = Figure(figsize=(WIDTH_IN, ROW_HEIGHT_IN * rows), dpi=DPI, layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.subplots(rows, 1, sharex=True, squeeze=False)[:, 0]
    state_s = (np.array(series.state_ns, dtype=np.int64) - series.first_ns) / 1e9
    tick_s = (np.array(series.tick_ns, dtype=np.int64) - series.first_ns) / 1e9
    for g in range(groups):
        first = PANELS_PER_GROUP * g
        _plot_group(axes[first : first + PANELS_PER_GROUP], g, state_s, series.states)
    gaps = tick_gaps([tick["tick"] for tick in series.ticks])
    _plot_depth(axes[-2], tick_s, series.ticks, groups, gaps)
    _plot_lateness(axes[-1], tick_s, series.ticks, gaps)
    for ax in axes:
        # Shared x (the panels line up) but every panel keeps its own time labels, so any one
        # of them can be read alone.
        ax.tick_params(labelbottom=True)
        ax.set_xlabel("time since first sample (s)")
        ax.grid(True, alpha=0.3)
    figure.suptitle(f"{Path(path).name}: cell {name}")
    figure.savefig(out, dpi=DPI, format="png")
    return figure


def _plot_group(
    panels: Any,
    g: int,
    t: np.ndarray[Any, np.dtype[np.float64]],
    states: list[dict[str, Any]],
) -> None:
    """Positions, commanded (dashed) vs feedback (solid); the following error (commanded -
    feedback); velocities, commanded (dashed, when recorded) vs feedback."""
    positions_ax, error_ax, velocities_ax = panels
    group_no = states[0]["groups"][g]["group_no"]
    feedback = _series(states, g, "positions")
    commanded = _series(states, g, "command_positions")
    velocities = {"feedback": _series(states, g, "velocities")}
    # A recording whose states carry no commanded velocities (an older file) plots the
    # feedback's alone.
    if all(s["groups"][g].get("command_velocities") for s in states):
        velocities["commanded"] = _series(states, g, "command_velocities")
    joints = feedback.shape[1]
    for j in range(joints):
        colour = f"C{j % 10}"
        for kind, values in (("commanded", commanded), ("feedback", feedback)):
            positions_ax.plot(
                t,
                values[:, j],
                color=colour,
                linestyle=JOINT_STYLE[kind],
                linewidth=1.2,
                gid=f"group{g}/joint{j}/{kind}",
            )
        error_ax.plot(
            t,
            (commanded[:, j] - feedback[:, j]) * 1e3,
            color=colour,
            linewidth=1.2,
            gid=f"group{g}/joint{j}/following_error",
        )
        for kind, values in velocities.items():
            velocities_ax.plot(
                t,
                values[:, j],
                color=colour,
                linestyle=JOINT_STYLE[kind],
                linewidth=1.2,
                gid=f"group{g}/joint{j}/velocity" + ("/commanded" if kind == "commanded" else ""),
            )
    positions_ax.set_title(
        f"group {group_no}: joint positions, commanded (dashed) vs feedback (solid)"
    )
    positions_ax.set_ylabel("position (rad; m if linear)")
    error_ax.set_title(f"group {group_no}: following error (commanded - feedback)")
    error_ax.set_ylabel("error (mrad; mm if linear)")
    shown = (
        ", commanded (dashed) vs feedback (solid)" if "commanded" in velocities else " (feedback)"
    )
    velocities_ax.set_title(f"group {group_no}: joint velocities{shown}")
    velocities_ax.set_ylabel("velocity (rad/s; m/s if linear)")
    # One legend entry per joint colour plus the two line styles, instead of 2 x joints entries;
    # outside the axes, so the plotting area shows only data.
    handles = [Line2D([], [], color=f"C{j % 10}", label=f"joint {j + 1}") for j in range(joints)]
    styles = [
        Line2D([], [], color="black", linestyle=style, label=kind)
        for kind, style in JOINT_STYLE.items()
    ]
    positions_ax.legend(handles=handles + styles, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    error_ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    drawn = [style for style in styles if style.get_label() in velocities]
    velocities_ax.legend(handles=handles + drawn, loc="upper left", bbox_to_anchor=(1.01, 1.0))


def _series(states: list[dict[str, Any]], g: int, field: str) -> np.ndarray[Any, Any]:
    return np.array([s["groups"][g][field] for s in states], dtype=np.float64)


def tick_gaps(ticks: list[int]) -> np.ndarray[Any, np.dtype[np.intp]]:
    """Where the tick panels' lines break: the indices ``i`` of the ticks after which the next
    is the same tick again or more than ``GAP_PERIODS`` periods on."""
    steps = np.diff(np.asarray(ticks, dtype=np.int64))
    return np.flatnonzero((steps < 1) | (steps > GAP_PERIODS))


def broken_at(
    gaps: np.ndarray[Any, np.dtype[np.intp]], values: np.ndarray[Any, Any]
) -> np.ndarray[Any, np.dtype[np.float64]]:
    """``values`` with a NaN after each of ``gaps``: matplotlib lifts the pen at a NaN."""
    return np.insert(values.astype(np.float64), gaps + 1, np.nan)


def _plot_depth(
    ax: Axes,
    t: np.ndarray[Any, np.dtype[np.float64]],
    ticks: list[dict[str, Any]],
    groups: int,
    gaps: np.ndarray[Any, np.dtype[np.intp]],
) -> None:
    for g in range(groups):
        depth = np.array([tick["groups"][g]["depth"] for tick in ticks], dtype=np.int64)
        ax.plot(
            broken_at(gaps, t),
            broken_at(gaps, depth),
            drawstyle="steps-post",
            linewidth=1.2,
            label=f"group {g}",
            gid=f"group{g}/depth",
        )
    ax.set_title("executor queue depth per group (entries waiting in the ring)")
    ax.set_ylabel("depth (entries)")
    if ticks:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
    else:
        _no_data(ax, "executor/tick")


def _plot_lateness(
    ax: Axes,
    t: np.ndarray[Any, np.dtype[np.float64]],
    ticks: list[dict[str, Any]],
    gaps: np.ndarray[Any, np.dtype[np.intp]],
) -> None:
    lateness_us = np.array([tick["lateness_ns"] for tick in ticks], dtype=np.float64) / 1e3
    ax.plot(
        broken_at(gaps, t),
        broken_at(gaps, lateness_us),
        color="C3",
        linewidth=0.8,
        gid="lateness",
    )
    ax.set_title("executor tick lateness (start of the tick after its deadline)")
    ax.set_ylabel("lateness (µs)")
    if not ticks:
        _no_data(ax, "executor/tick")


def _no_data(ax: Axes, key: str) -> None:
    ax.text(0.5, 0.5, f"no {key} samples", transform=ax.transAxes, ha="center", va="center")
