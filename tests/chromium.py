"""Headless Chromium driven through the DevTools protocol: open a page, wait, take screenshots.

For the browser tests of the playback page and the live view: WebGL runs in software
(SwiftShader), so the screenshots hold what three.js drew. Tests skip with a message where
no Chromium is installed (``apt-get install chromium``).
"""

from __future__ import annotations

import base64
import io
import itertools
import json
import re
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def find_chromium() -> str | None:
    return next((path for name in CHROMIUM_NAMES if (path := shutil.which(name))), None)


def require_chromium() -> str:
    browser = find_chromium()
    if browser is None:
        pytest.skip("headless Chromium not found: apt-get install chromium to run this check")
    return browser


class HeadlessChromium:
    """One headless Chromium with one page, driven over the DevTools websocket.

    Parameters
    ----------
    width, height : int
        Window size in CSS pixels (the screenshots' size).
    """

    def __init__(self, width: int = 800, height: int = 600):
        from websockets.sync.client import connect

        self._profile = tempfile.TemporaryDirectory(prefix="thesis-rbd-chromium-")
        self.process = subprocess.Popen(
            [
                require_chromium(),
                "--headless",
                "--no-sandbox",
                "--enable-unsafe-swiftshader",
                "--use-angle=swiftshader",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--no-first-run",
                "--hide-scrollbars",
                "--remote-debugging-port=0",
                f"--user-data-dir={self._profile.name}",
                f"--window-size={width},{height}",
                "about:blank",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        browser_url = self._devtools_url()
        port = re.search(r":(\d+)/", browser_url).group(1)
        target = self._page_target(port)
        self._socket = connect(target, max_size=None, open_timeout=30)
        self._ids = itertools.count(1)
        self.call("Page.enable")
        self.call("Runtime.enable")
        # the window size includes the (hidden) browser chrome: fix the page's own size
        self.call(
            "Emulation.setDeviceMetricsOverride",
            width=width,
            height=height,
            deviceScaleFactor=1,
            mobile=False,
        )

    def _devtools_url(self, timeout: float = 60.0) -> str:
        deadline = time.monotonic() + timeout
        lines = []
        while time.monotonic() < deadline:
            line = self.process.stderr.readline()
            if not line and self.process.poll() is not None:
                break
            lines.append(line)
            match = re.search(r"DevTools listening on (ws://\S+)", line)
            if match:
                return match.group(1)
        self.close()
        raise RuntimeError("Chromium did not start its DevTools server:\n" + "".join(lines[-20:]))

    @staticmethod
    def _page_target(port: str) -> str:
        from urllib.request import urlopen

        with urlopen(f"http://127.0.0.1:{port}/json/list", timeout=30) as response:
            targets = json.load(response)
        return next(t["webSocketDebuggerUrl"] for t in targets if t["type"] == "page")

    def call(self, method: str, **params) -> dict:
        """Send one DevTools command and return its result (events in between are dropped)."""
        message_id = next(self._ids)
        self._socket.send(json.dumps({"id": message_id, "method": method, "params": params}))
        while True:
            reply = json.loads(self._socket.recv(timeout=120))
            if reply.get("id") == message_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})

    def open(self, url: str) -> None:
        self.call("Page.navigate", url=url)

    def evaluate(self, expression: str):
        """The value of a JavaScript expression in the page."""
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True)
        return result.get("result", {}).get("value")

    def wait_for(self, expression: str, timeout: float = 60.0) -> None:
        """Poll until a JavaScript expression is truthy in the page."""
        deadline = time.monotonic() + timeout
        while not self.evaluate(expression):
            if time.monotonic() > deadline:
                raise TimeoutError(f"page never satisfied: {expression}")
            time.sleep(0.25)

    def screenshot(self) -> np.ndarray:
        """(height, width, 3) uint8 RGB of the page as drawn now."""
        from PIL import Image

        data = self.call("Page.captureScreenshot", format="png")["data"]
        with Image.open(io.BytesIO(base64.b64decode(data))) as image:
            return np.asarray(image.convert("RGB"))

    def close(self) -> None:
        socket = getattr(self, "_socket", None)
        if socket is not None:
            socket.close()
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.process.stderr.close()
        # Chromium's helper processes can still be writing into the profile for a moment
        # after the browser itself exits: retry, then leave what remains to the system
        for _ in range(50):
            try:
                self._profile.cleanup()
                return
            except OSError:
                time.sleep(0.1)
        shutil.rmtree(self._profile.name, ignore_errors=True)

    def __enter__(self) -> HeadlessChromium:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()


_LARGEST_CANVAS = (
    "[...document.querySelectorAll('canvas')].reduce((a, c) =>"
    " (!a || c.width * c.height > a.width * a.height ? c : a), null)"
)


def canvas_rect(browser: HeadlessChromium, timeout: float = 90.0) -> dict:
    """Wait until the page's canvas spans the window's width; return its CSS box (left, top,
    width, height).

    viser draws the scene on the page's largest canvas, as wide as the window once laid out.
    """
    browser.wait_for(
        f"(() => {{ const c = {_LARGEST_CANVAS};"
        " return !!c && c.getBoundingClientRect().width === window.innerWidth; })()",
        timeout,
    )
    return browser.evaluate(
        f"(() => {{ const r = ({_LARGEST_CANVAS}).getBoundingClientRect();"
        " return {left: r.left, top: r.top, width: r.width, height: r.height}; })()"
    )


def hide_notifications(browser: HeadlessChromium) -> None:
    """Hide viser's notices (e.g. "software WebGL") so that they cover no part of the view."""
    browser.evaluate(
        "(() => { const s = document.createElement('style');"
        " s.textContent = '.mantine-Notifications-root { display: none !important; }';"
        " document.head.appendChild(s); return true; })()"
    )


def file_url(path: Path) -> str:
    return Path(path).resolve().as_uri()
