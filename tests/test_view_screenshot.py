"""scripts/view_screenshot.py's own parts: the panels it waits for, the URL it opens the app at,
the loopback server it serves the app and the layout from, and its one line for a folder that
is no built app. The screenshot itself needs a built Lichtblick and Chromium, which the machines
the suite runs on do not have."""

from __future__ import annotations

import copy
import importlib.util
import sys
import urllib.request
from pathlib import Path
from types import ModuleType
from urllib.parse import parse_qs, urlsplit

import pytest

from motocell.shared.config import load_cell
from motocell.tools.view_layout import layout

SCRIPT = Path(__file__).parent.parent / "scripts" / "view_screenshot.py"


@pytest.fixture(scope="module")
def script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("view_screenshot", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_panels_shown_are_the_split_tree_and_the_active_tab(script: ModuleType) -> None:
    made = layout([load_cell("dual-arm-positioner")])
    lights = [f"Indicator!dual{name}" for name in ("motionready", "servoon", "estop", "hold")]
    assert script.shown_panels(made) == [
        "3D!scene",
        *lights,
        "Tab!cells",
        "Plot!dualR1pos",
        "Plot!dualR1vel",
    ]
    controller = copy.deepcopy(made)
    controller["configById"]["Tab!cells"]["activeTabIdx"] = 3
    assert script.shown_panels(controller)[-4:] == [
        "Tab!cells",
        "RawMessages!dualstatus",
        "Plot!duallate",
        "Plot!dualdepth",
    ]


def test_each_cell_s_motion_ready_light_is_read_for_its_yes(script: ModuleType) -> None:
    made = layout([load_cell(), load_cell("dual-arm-positioner")])
    assert script.motion_ready_labels(made) == {
        "Indicator!cell1motionready": "motion-ready: YES",
        "Indicator!dualmotionready": "motion-ready: YES",
    }


def test_the_app_is_told_to_connect_to_the_view_and_import_the_layout(script: ModuleType) -> None:
    url = urlsplit(script.app_url(8080, "ws://127.0.0.1:8765"))
    # What Lichtblick 1.28.1 reads of its URL: a data source, its address, a layout to fetch.
    assert parse_qs(url.query) == {
        "ds": ["foxglove-websocket"],
        "ds.url": ["ws://127.0.0.1:8765"],
        "layoutUrl": [f"http://127.0.0.1:8080{script.LAYOUT_PATH}"],
    }
    assert (url.hostname, url.port, url.path) == ("127.0.0.1", 8080, "/")


def test_the_server_gives_the_app_and_the_layout_beside_it(
    script: ModuleType, tmp_path: Path
) -> None:
    app = tmp_path / "app"
    app.mkdir()
    (app / "index.html").write_text("<html>the app</html>")
    layout_file = tmp_path / "written.json"
    layout_file.write_text('{"layout": "the view\'s"}')
    with script.serving(app, layout_file) as port:
        base = f"http://127.0.0.1:{port}"
        with urllib.request.urlopen(f"{base}/index.html") as page:
            assert page.read() == b"<html>the app</html>"
        with urllib.request.urlopen(f"{base}{script.LAYOUT_PATH}") as served:
            assert served.read() == b'{"layout": "the view\'s"}'


def test_a_folder_that_is_no_built_app_is_one_line(
    script: ModuleType,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.setattr(sys, "argv", ["view_screenshot.py", str(tmp_path), "out.png"])
    with pytest.raises(SystemExit) as exited:
        script.main()
    assert exited.value.code == 2
    assert capsys.readouterr().err == (
        f"view_screenshot: {tmp_path} holds no index.html: not a built web app\n"
    )
