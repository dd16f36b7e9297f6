"""``motocell plot``: a recording (``motocell record``) as one PNG of how the motion went.

Per group: joint positions, commanded (dashed) against feedback (solid); the following error
(commanded - feedback, the servo's lag, docs/servo.md); joint velocities, commanded (dashed)
against feedback (solid); all from ``state``. Then every group's executor queue depth and the
executor's tick lateness, from ``executor/tick``, whose lines break where the executor's clock
rested (``plotting.GAP_PERIODS``). Time is seconds since the cell's first recorded sample, on
every panel, so the panels line up.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``motocell plot`` (``tools.cli`` names the command)."""
    parser.description = __doc__
    parser.add_argument("file", metavar="FILE", help="an MCAP recording")
    parser.add_argument("-o", "--out", metavar="OUT.png", help="default: FILE with .png")
    parser.add_argument("--cell", metavar="NAME", help="needed when FILE holds several cells")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    # matplotlib and mcap are in the tools extra, and matplotlib is slow to import: imported by
    # this command only, not by every `motocell`.
    from motocell.tools.plotting import plot_recording  # noqa: PLC0415
    from motocell.tools.recording import Recording  # noqa: PLC0415

    out = args.out or str(Path(args.file).with_suffix(".png"))
    recording = Recording(args.file)
    try:
        plot_recording(recording, out, args.cell)
    except (OSError, ValueError) as exc:
        cut = f" ({CUT})" if recording.cut else ""
        print(f"motocell plot: {exc}{cut}", file=sys.stderr)
        return 1
    if recording.cut:
        print(f"motocell plot: {args.file}: {CUT}; plotted what it holds", file=sys.stderr)
    print(f"wrote {out}")
    return 0


CUT = "cut short, its recorder did not close it (killed, or a full disk)"
