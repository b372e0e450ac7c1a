"""Make the screenshots of the README and the guide: the live view and the playback page.

    python docs/make_screenshots.py [FOLDER]

from the root of a source checkout, with headless Chromium installed (``apt-get install
chromium``). Writes ``live_view.png`` and ``playback.png`` into FOLDER (``docs/`` by default):

- ``thesis-rbd view dominoes`` in a subprocess, opened in the browser, paused while the row
  falls, with a domino clicked so that the panel shows its state;
- the playback page of ``thesis-rbd run tori_demo --html`` (contacts recorded), paused while
  the tori cut through each other.
"""

from __future__ import annotations

import itertools
import re
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPOSITORY))

from tests.chromium import (  # noqa: E402  (needs the checkout on the path first)
    HeadlessChromium,
    canvas_rect,
    file_url,
    find_chromium,
    hide_notifications,
)

WIDTH, HEIGHT = 1200, 720


def _save(picture, path: Path) -> None:
    from PIL import Image

    Image.fromarray(picture).save(path, optimize=True)
    print(f"wrote {path}")


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _click_button(browser, label: str) -> None:
    browser.evaluate(
        "[...document.querySelectorAll('button')]"
        f".find(b => b.textContent.trim() === '{label}').click()"
    )


def live_view(path: Path) -> None:
    """The dominoes in the live view, paused mid-fall, a domino's state in the panel."""
    command = [sys.executable, "-m", "thesis_rbd.cli", "view", "dominoes", "--paused"]
    process = subprocess.Popen(
        [*command, "--port", str(_free_port())], stdout=subprocess.PIPE, text=True
    )
    try:
        url = None
        while url is None:
            line = process.stdout.readline()
            if not line:
                raise RuntimeError("thesis-rbd view stopped before serving")
            match = re.search(r" at (http://\S+)", line)
            url = match.group(1) if match else None
        with HeadlessChromium(WIDTH, HEIGHT) as browser:
            browser.open(url)
            rect = canvas_rect(browser)
            hide_notifications(browser)
            _click_button(browser, "Play")
            browser.wait_for("/t = (0[.]9|[1-9][.])/.test(document.body.innerText)", 300)
            _click_button(browser, "Pause")
            # click along the row of dominoes until a moving body answers (not the floor)
            for row, column in itertools.product((0.47, 0.5, 0.44, 0.53), (0.5, 0.45, 0.55, 0.4)):
                x = rect["left"] + column * rect["width"]
                y = rect["top"] + row * rect["height"]
                for kind in ("mousePressed", "mouseReleased"):
                    browser.call(
                        "Input.dispatchMouseEvent", type=kind, x=x, y=y, button="left", clickCount=1
                    )
                time.sleep(1.0)
                if "angular velocity" in (browser.evaluate("document.body.innerText") or ""):
                    break
            time.sleep(1.0)
            _save(browser.screenshot(), path)
    finally:
        process.terminate()
        process.wait(timeout=30)


def playback(path: Path) -> None:
    """The tori demo's playback page, paused mid-cut with its contacts drawn."""
    with tempfile.TemporaryDirectory() as folder:
        page = Path(folder) / "tori.html"
        subprocess.run(
            [sys.executable, "-m", "thesis_rbd.cli", "run", "tori_demo", "--html", str(page)],
            check=True,
        )
        with HeadlessChromium(WIDTH, HEIGHT) as browser:
            browser.open(file_url(page))
            canvas_rect(browser)
            hide_notifications(browser)
            browser.wait_for("parseFloat(document.querySelector('input').value) >= 2.9", 120)
            for kind in ("keyDown", "keyUp"):
                browser.call("Input.dispatchKeyEvent", type=kind, key=" ", code="Space")
            time.sleep(1.5)
            _save(browser.screenshot(), path)


def main(argv: list[str]) -> int:
    if find_chromium() is None:
        print("needs headless Chromium: apt-get install chromium", file=sys.stderr)
        return 1
    folder = Path(argv[0]) if argv else REPOSITORY / "docs"
    folder.mkdir(parents=True, exist_ok=True)
    live_view(folder / "live_view.png")
    playback(folder / "playback.png")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
