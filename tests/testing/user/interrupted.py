"""A user's test that runs until Ctrl-C (tests/testing/test_installed_plugin.py copies it out
of the repository as test_interrupted.py): it writes its cell's name to the file $READY_FILE
names, then waits."""

import os
import time
from pathlib import Path

from motocell.testing import CellUnderTest


def test_waits_for_ctrl_c(motocell_cell: CellUnderTest) -> None:
    Path(os.environ["READY_FILE"]).write_text(motocell_cell.name)
    time.sleep(600)
