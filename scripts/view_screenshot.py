"""A screenshot of Lichtblick showing the dual-arm-positioner cell as ``motocell view`` serves
it, for the README, from a real run.

Given a built Lichtblick web app (the folder holding its ``index.html``; this script does not
build it), it starts the sample cell (``testing.running_cell``), runs ``motocell view --layout``
on it, serves the app and that layout on loopback, and opens the app in headless Chromium at
1280x800, driven over the DevTools protocol. The app's own URL parameters connect it
(``ds=foxglove-websocket&ds.url=ws://...``) and import the layout (``layoutUrl=``, which
Lichtblick fetches and installs as its layout import menu would). Once the panels are up, the
arms and the positioner move with MOTO_JOINT_TRAJ_PT_FULL_EX as motoman_driver moves them, and
once they rest, the page is saved as a PNG.

    PYTHONPATH=. .venv/bin/python scripts/view_screenshot.py LICHTBLICK/web/.webpack \\
        docs/images/view-lichtblick.png
"""

from __future__ import annotations

import argparse
import base64
import contextlib
import functools
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from collections.abc import Iterator
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import urlencode

from websockets.sync.client import ClientConnection, connect

from motocell.shared.protocol.constants import Command
from motocell.shared.registry import ENV as RUNTIME_DIR_ENV
from motocell.testing.client import smooth_move, stream_ex
from motocell.testing.running_cell import RunningCell, running_cell

CELL = "dual"
GOALS = {
    0: (0.6, 0.5, 0.3, 0.0, -0.6, 0.0),
    1: (-0.5, 0.6, 0.3, -0.9, 0.0, 0.7, 0.0),
    2: (0.6, 1.2),
}
WIDTH, HEIGHT = 1280, 800
"""The window the layout is drawn for (tools/view_layout.py)."""
LAYOUT_PATH = "/motocell-layout.json"
"""Where the served app finds the layout ``motocell view`` wrote."""
READY = re.compile(r"ws://[\d.]+:\d+")
CHROMIUM_ARGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    # WebGL (the 3D panel) on the CPU, as a machine without a GPU can draw it.
    "--enable-unsafe-swiftshader",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--remote-debugging-address=127.0.0.1",
    "--remote-debugging-port=0",
    f"--window-size={WIDTH},{HEIGHT}",
)
START_S = 60.0
"""How long the app may take to load, connect and draw on a loaded 2-core machine."""

DRAWN = """ids => ids.every(id => {
  const panel = document.querySelector(`[data-testid~="${id}"]`);
  return panel !== null && (!/^(3D|Plot)!/.test(id) || panel.querySelector("canvas") !== null);
})"""
"""True once every panel named is on the page, each 3D and plot panel with its canvas."""
READING = """labels => Object.entries(labels).every(([id, label]) =>
  document.querySelector(`[data-testid~="${id}"]`)?.innerText.includes(label))"""
"""True once each panel named shows its text: data has come through to it."""
NEXT_FRAMES = """new Promise(done =>
  requestAnimationFrame(() => requestAnimationFrame(() => done(true))))"""
"""Resolves after two frames: the page has drawn what it last received."""
CLOSE_SIDEBAR = "document.querySelector('[data-testid=sidebar-close-left]')?.click() ?? true"
"""A fresh Lichtblick opens its left sidebar, 320 px the layout is not drawn for."""


def shown_panels(layout: dict[str, Any]) -> list[str]:
    """The panels a layout puts on screen: its split tree's, and those of each Tab panel's
    active tab."""
    configs = layout["configById"]

    def leaves(node: Any) -> Iterator[str]:
        if isinstance(node, str):
            yield node
            tabs = configs.get(node, {}).get("tabs")
            if tabs:
                yield from leaves(tabs[configs[node].get("activeTabIdx", 0)]["layout"])
        elif node:
            yield from leaves(node["first"])
            yield from leaves(node["second"])

    return list(leaves(layout["layout"]))


def motion_ready_labels(layout: dict[str, Any]) -> dict[str, str]:
    """What each motion-ready light reads once its cell is ready (its rule's label)."""
    return {
        panel: config["rules"][0]["label"]
        for panel, config in layout["configById"].items()
        if panel.startswith("Indicator!") and config["path"].endswith(".motion_ready")
    }


def app_url(http_port: int, ws_url: str) -> str:
    """The app, told to connect to the view and to import the layout served beside it (the
    parameters Lichtblick's ``parseAppURLState`` reads)."""
    query = {
        "ds": "foxglove-websocket",
        "ds.url": ws_url,
        "layoutUrl": f"http://127.0.0.1:{http_port}{LAYOUT_PATH}",
    }
    return f"http://127.0.0.1:{http_port}/?{urlencode(query)}"


class AppHandler(SimpleHTTPRequestHandler):
    """The static app, and the layout at ``LAYOUT_PATH``."""

    def __init__(self, *args: Any, app: Path, layout: Path, **kwargs: Any) -> None:
        self.layout = layout
        super().__init__(*args, directory=str(app), **kwargs)

    def translate_path(self, path: str) -> str:
        if path.split("?", 1)[0] == LAYOUT_PATH:
            return str(self.layout)
        return super().translate_path(path)

    def log_message(self, format: str, *args: Any) -> None:
        """Quiet: a page load is hundreds of requests."""


@contextlib.contextmanager
def serving(app: Path, layout: Path) -> Iterator[int]:
    """Serves the app and the layout on a free loopback port; yields the port."""
    handler = functools.partial(AppHandler, app=app, layout=layout)
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, name="app-server")
    thread.start()
    try:
        yield server.server_address[1]
    finally:
        server.shutdown()
        thread.join()
        server.server_close()


@contextlib.contextmanager
def viewing(cell: RunningCell, layout: Path) -> Iterator[str]:
    """``motocell view`` of the cell on a free port, writing its layout; yields its URL."""
    env = {**os.environ, RUNTIME_DIR_ENV: str(cell.runtime_dir)}
    command = [sys.executable, "-m", "motocell.tools.cli", "view", "--port", "0"]
    view = subprocess.Popen(
        [*command, "--layout", str(layout)], env=env, stdout=subprocess.PIPE, text=True
    )
    try:
        assert view.stdout is not None
        url = next((m.group(0) for line in view.stdout if (m := READY.search(line))), None)
        if url is None:
            raise SystemExit(f"motocell view ended (status {view.wait()}) before serving")
        yield url
    finally:
        view.terminate()
        view.wait(timeout=20)


class Page:
    """One Chromium tab, driven over the DevTools protocol's WebSocket."""

    def __init__(self, socket: ClientConnection) -> None:
        self.socket = socket
        self.next_id = 0

    def call(self, method: str, **params: Any) -> dict[str, Any]:
        """Sends a command and returns its result, passing over the events sent meanwhile."""
        self.next_id += 1
        self.socket.send(json.dumps({"id": self.next_id, "method": method, "params": params}))
        while True:
            reply = json.loads(self.socket.recv(timeout=START_S))
            if reply.get("id") == self.next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']['message']}")
                result: dict[str, Any] = reply["result"]
                return result

    def evaluate(self, expression: str) -> Any:
        result = self.call(
            "Runtime.evaluate", expression=expression, returnByValue=True, awaitPromise=True
        )
        if "exceptionDetails" in result:
            thrown = result["exceptionDetails"]
            raise RuntimeError(f"the page threw: {thrown.get('exception', thrown)['description']}")
        return result["result"].get("value")

    def wait_until(self, function: str, argument: Any, what: str) -> None:
        """Until ``function`` of ``argument`` is true, looked at once a frame."""
        deadline = time.monotonic() + START_S
        while not self.evaluate(f"({function})({json.dumps(argument)})"):
            if time.monotonic() > deadline:
                raise SystemExit(f"view_screenshot: {what} within {START_S:.0f} s")
            self.evaluate(NEXT_FRAMES)


def devtools_port(profile: Path, browser: subprocess.Popen[bytes]) -> int:
    """The port Chromium chose, from the file it writes in its profile once it listens."""
    written = profile / "DevToolsActivePort"
    deadline = time.monotonic() + START_S
    while not written.exists() or not written.read_text().strip():
        if browser.poll() is not None:
            raise SystemExit(f"chromium ended (status {browser.returncode}) before listening")
        if time.monotonic() > deadline:
            raise SystemExit("chromium did not open its DevTools port")
        time.sleep(0.1)  # Chromium says nothing else when it is ready.
    return int(written.read_text().split()[0])


@contextlib.contextmanager
def chromium(executable: str, profile: Path) -> Iterator[Page]:
    """Headless Chromium with a fresh profile; yields its blank tab, sized to the layout."""
    command = [executable, *CHROMIUM_ARGS, f"--user-data-dir={profile}", "about:blank"]
    browser = subprocess.Popen(command, stderr=subprocess.DEVNULL)
    try:
        port = devtools_port(profile, browser)
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list") as answer:
            targets = json.load(answer)
        tab = next(t for t in targets if t["type"] == "page")
        with connect(tab["webSocketDebuggerUrl"], max_size=None) as socket:
            page = Page(socket)
            page.call(
                "Emulation.setDeviceMetricsOverride",
                width=WIDTH,
                height=HEIGHT,
                deviceScaleFactor=1,
                mobile=False,
            )
            yield page
    finally:
        browser.terminate()
        browser.wait(timeout=20)


def move(cell: RunningCell) -> None:
    """Both arms and the positioner out to ``GOALS``, over a sixth of the plots' 30 s so that
    the curves read; returns once they rest."""
    with cell.motion() as motion, cell.state() as state:
        motion.command(Command.START_TRAJ_MODE)
        still = state.wait_still()
        moves = {
            group: smooth_move(
                still.groups[group].positions[: len(goal)], goal, duration=5.0, points=21
            )
            for group, goal in GOALS.items()
        }
        stream_ex(motion, moves)
        state.wait_still()


def screenshot(app: Path, executable: str) -> bytes:
    with tempfile.TemporaryDirectory() as scratch, running_cell("dual-arm-positioner") as cell:
        layout = Path(scratch) / "motocell-layout.json"
        with (
            viewing(cell, layout) as ws_url,
            serving(app, layout) as http_port,
            chromium(executable, Path(scratch) / "profile") as page,
        ):
            page.call("Page.navigate", url=app_url(http_port, ws_url))
            shown = json.loads(layout.read_text())
            page.wait_until(DRAWN, shown_panels(shown), "the app did not draw the layout's panels")
            page.evaluate(CLOSE_SIDEBAR)
            move(cell)
            page.wait_until(READING, motion_ready_labels(shown), "no data reached the lights")
            page.evaluate(NEXT_FRAMES)
            shot = page.call("Page.captureScreenshot", format="png")
            # Off the view before it stops, so that it does not log a client cut off.
            page.call("Page.navigate", url="about:blank")
    return base64.b64decode(shot["data"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n", 1)[0])
    parser.add_argument(
        "app", type=Path, help="a built Lichtblick web app (its index.html's folder)"
    )
    parser.add_argument("out", type=Path, help="the PNG to write")
    parser.add_argument("--chromium", default="/usr/bin/chromium", help="the browser to drive")
    args = parser.parse_args()
    if not (args.app / "index.html").is_file():
        parser.exit(2, f"view_screenshot: {args.app} holds no index.html: not a built web app\n")
    png = screenshot(args.app, args.chromium)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_bytes(png)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
