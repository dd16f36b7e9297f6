"""Where one service's start goes, in a fresh interpreter of its own (figure 13):

    python -m motocell.tools.bench.start_phases SERVICE ENDPOINT CONFIG CREDENTIALS

prints the CPU seconds (this process's, every thread) of each phase as JSON: the interpreter
until this module runs, the service's imports (``motocell.services.SERVICE.__main__``), loading
the cell file, and ``zenoh.open`` on the cell's router at ENDPOINT, as an observer with
CREDENTIALS (empty: an open bus). CONFIG empty: the default cell.
"""

from __future__ import annotations

import time

INTERPRETER = time.process_time()
"""Read first: what the interpreter and the packages above this module cost (``motocell``,
``motocell.tools``, ``motocell.tools.bench``: a few of the standard library's modules)."""

import importlib  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402


def main() -> None:
    service, endpoint, config, credentials = sys.argv[1:5]
    phases = {"the interpreter": INTERPRETER}
    mark = time.process_time()
    importlib.import_module(f"motocell.services.{service}.__main__")
    phases[f"import motocell.services.{service}"] = time.process_time() - mark

    from motocell.shared.bus.access import Identity  # noqa: PLC0415
    from motocell.shared.bus.catalog import Role  # noqa: PLC0415
    from motocell.shared.bus.credentials import load  # noqa: PLC0415
    from motocell.shared.bus.session import open_session  # noqa: PLC0415
    from motocell.shared.config import load_cell  # noqa: PLC0415

    mark = time.process_time()
    cell = load_cell(config or None)
    phases["load the cell file"] = time.process_time() - mark
    mark = time.process_time()
    observer = None
    if credentials:
        observer = load(Path(credentials), cell.name, Identity(Role.OBSERVER))
    session = open_session("client", [endpoint], credentials=observer)
    phases["zenoh.open"] = time.process_time() - mark
    session.close()
    print(json.dumps(phases))


if __name__ == "__main__":
    main()
