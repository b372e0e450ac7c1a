"""The live view: its clock and timing table against hand-worked numbers, and `thesis-rbd view`
as a user meets it: a subprocess serving a page that headless Chromium draws, that advances,
whose buttons pause, step and reset the world, whose click on a body shows that body's state,
and that Ctrl-C stops cleanly."""

import logging
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import thesis_rbd as rbd
from tests.chromium import HeadlessChromium, canvas_rect, hide_notifications, require_chromium
from tests.viser_recording import recording
from thesis_rbd.viz.live import (
    FALLING_BEHIND_SECONDS,
    LiveView,
    PlaybackClock,
    _DroppedConnectionFilter,
    stage_timings,
)


def test_clock_follows_the_wall_clock_at_its_speed():
    clock = PlaybackClock(dt=0.01)
    assert clock.steps_due(0.0, 100.0) == 0  # not started: paused
    clock.start(simulated=2.0, wall=100.0)
    assert clock.steps_due(2.0, 100.1) == 10  # 0.1 s of wall at 1x: ten steps of 0.01 s
    assert clock.steps_due(2.05, 100.1) == 5
    clock.speed = 0.5
    clock.start(2.0, 100.0)
    assert clock.steps_due(2.0, 100.1) == 5
    clock.stop()
    assert clock.steps_due(2.0, 200.0) == 0


def test_clock_lets_go_of_time_it_cannot_catch_up():
    clock = PlaybackClock(dt=0.01)
    clock.start(0.0, 0.0)
    late_wall = 2 * FALLING_BEHIND_SECONDS
    assert clock.steps_due(0.0, late_wall) == 1 and clock.behind
    # the clock starts again from where the world is: nothing more is due at once
    assert clock.steps_due(0.0, late_wall) == 0 and clock.behind
    # keeping up for more than a second clears the flag
    assert clock.steps_due(1.5, late_wall + 1.5) == 0 and not clock.behind


def test_stage_timings_are_per_step_and_shares_of_the_staged_time():
    before = {"integrate": {"calls": 10, "seconds": 1.0}, "bounds": {"calls": 10, "seconds": 0.5}}
    after = {
        "integrate": {"calls": 30, "seconds": 1.3},
        "bounds": {"calls": 30, "seconds": 0.6},
        "sleep": {"calls": 0, "seconds": 0.0},
    }
    rows = stage_timings(before, after, steps=20)
    assert [row[0] for row in rows] == ["integrate", "bounds"]  # sleep did not run
    np.testing.assert_allclose([row[1] for row in rows], [15.0, 5.0])  # ms per step
    np.testing.assert_allclose([row[2] for row in rows], [0.75, 0.25])


def handshake_record(error: BaseException) -> logging.LogRecord:
    """The record websockets logs for a failed opening handshake that raised `error`."""
    try:
        raise error
    except BaseException:
        exc_info = sys.exc_info()
    return logging.LogRecord(
        "websockets.server", logging.ERROR, __file__, 0, "opening handshake failed", (), exc_info
    )


def test_only_connections_closed_before_a_request_are_left_unreported():
    keep = _DroppedConnectionFilter().filter
    closed = ValueError("did not receive a valid HTTP request")
    closed.__cause__ = EOFError("connection closed while reading HTTP request line")
    assert not keep(handshake_record(closed))
    assert keep(handshake_record(ValueError("invalid Sec-WebSocket-Key")))
    other = logging.LogRecord("websockets.server", logging.ERROR, "", 0, "boom", (), None)
    assert keep(other)


# ---------------------------------------------------------------------- joints
def test_view_draws_the_joints_on_their_bodies_and_frames_the_hinge():
    """The pendulum's view: the hinge's dot and axis on the ball (children of its node, in its
    frame) and on the world, and a camera aimed between the hinge and the ball (the ball alone
    would fill the view)."""
    view = LiveView(rbd.scenes.get("pendulum"), port=0, playing=False)
    try:
        record = recording(view.server.get_scene_serializer().as_html())
        points = {
            m["name"]: m["props"]["points"].reshape(-1, 3)
            for _, m in record["messages"]
            if m["type"] in ("PointCloudMessage", "LineSegmentsMessage") and "joint" in m["name"]
        }
        look_at = np.array(view.server.initial_camera.look_at)
    finally:
        view.close()
    assert set(points) == {
        "/bodies/0_ball/joint_anchors", "/bodies/0_ball/joint_axes",
        "/joint_anchors", "/joint_axes",
    }  # fmt: skip
    np.testing.assert_allclose(points["/bodies/0_ball/joint_anchors"], [[-1.0, 0.0, 0.0]])
    np.testing.assert_allclose(points["/joint_anchors"], [[0.0, 0.0, 0.0]])
    for node, anchor in (("/bodies/0_ball/joint_axes", -1.0), ("/joint_axes", 0.0)):
        segment = points[node]
        np.testing.assert_allclose(segment[:, [0, 2]], [[anchor, 0.0], [anchor, 0.0]])
        assert segment[0, 1] < 0.0 < segment[1, 1]
    assert look_at[0] == pytest.approx(0.51, abs=0.01)


# ---------------------------------------------------------------------- the command
def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.fixture
def live_view():
    """`thesis-rbd view dzhanibekov` on a free port, as a subprocess: (process, url)."""
    require_chromium()
    script = Path(sys.executable).parent / "thesis-rbd"
    command = [str(script)] if script.exists() else [sys.executable, "-m", "thesis_rbd.cli"]
    process = subprocess.Popen(
        [*command, "view", "dzhanibekov", "--port", str(free_port())],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    url = None
    deadline = time.monotonic() + 600  # a cold numba cache compiles first
    while url is None and time.monotonic() < deadline:
        line = process.stdout.readline()
        if not line:
            break
        match = re.search(r"thesis-rbd view: dzhanibekov at (http://\S+)", line)
        url = match.group(1) if match else None
    if url is None:
        process.kill()
        pytest.fail(f"the view never said where it serves: {process.stderr.read()[-2000:]}")
    yield process, url
    if process.poll() is None:
        process.kill()
        process.wait()


def panel_state(browser):
    """(t, step) the page's status line shows."""
    text = browser.evaluate("document.body.innerText") or ""
    match = re.search(r"t = ([0-9.]+) s, step (\d+)", text)
    return (float(match.group(1)), int(match.group(2))) if match else (None, None)


def click_button(browser, label):
    assert browser.evaluate(
        "(() => { const b = [...document.querySelectorAll('button')]"
        f".find(b => b.textContent.trim() === '{label}'); if (b) b.click(); return !!b; }})()"
    ), f"no {label} button"


def wait_for_state(browser, condition, timeout=60.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        state = panel_state(browser)
        if state[0] is not None and condition(*state):
            return state
        time.sleep(0.2)
    raise AssertionError(f"the page never reached the state; it shows {panel_state(browser)}")


def reddish_share(shot, rect):
    """Share of the middle fifth of the canvas drawn in the first palette colour (reddish)."""
    middle = shot[
        int(rect["top"] + 0.4 * rect["height"]) : int(rect["top"] + 0.6 * rect["height"]),
        int(rect["left"] + 0.4 * rect["width"]) : int(rect["left"] + 0.6 * rect["width"]),
    ].astype(int)
    reddish = (middle[..., 0] - middle[..., 2] > 50) & (middle[..., 0] - middle[..., 1] > 30)
    return float(np.mean(reddish))


def test_view_draws_the_scene_advances_obeys_its_buttons_and_stops_on_ctrl_c(live_view):
    process, url = live_view
    dt = 1.0 / 240.0  # the dzhanibekov scene's step
    # a connection closed before it sends a request, as browsers close their spare ones: the
    # view says nothing of it (checked on its stderr at the end)
    host, port = re.search(r"//([^:/]+):(\d+)", url).groups()
    socket.create_connection((host, int(port)), timeout=10).close()
    with HeadlessChromium(width=1000, height=700) as browser:
        browser.open(url)
        rect = canvas_rect(browser)
        hide_notifications(browser)
        # it plays: time and steps advance
        t0, step0 = wait_for_state(browser, lambda t, step: step > 0)
        t1, _ = wait_for_state(browser, lambda t, step: step > step0 + 60)
        assert t1 > t0
        # the spinning box is drawn in the middle of the view, in the first palette colour
        # (on a loaded machine the page may show the state before the first frame with the
        # mesh is drawn: the shot is taken again until it is, for up to 30 s)
        deadline = time.monotonic() + 30.0
        while True:
            first = browser.screenshot()
            if reddish_share(first, rect) > 0.5 or time.monotonic() > deadline:
                break
            time.sleep(0.25)
        assert reddish_share(first, rect) > 0.5
        time.sleep(0.5)
        assert np.count_nonzero(np.any(browser.screenshot() != first, axis=2)) > 500  # it turns

        click_button(browser, "Pause")
        # the server answers by relabelling the button; then the panel settles
        browser.wait_for(
            "[...document.querySelectorAll('button')].some(b => b.textContent.trim() === 'Play')"
        )
        time.sleep(1.0)
        paused_t, paused_step = panel_state(browser)
        time.sleep(1.0)
        assert panel_state(browser) == (paused_t, paused_step)
        click_button(browser, "Step")
        t, step = wait_for_state(browser, lambda t, step: step != paused_step)
        assert step == paused_step + 1 and t == pytest.approx(paused_t + dt, abs=1.5e-3)
        click_button(browser, "Reset")
        assert wait_for_state(browser, lambda t, step: step == 0) == (0.0, 0)

        # a click on the body shows its state: at rest at its starting point, spinning
        x, y = rect["left"] + 0.5 * rect["width"], rect["top"] + 0.5 * rect["height"]
        for kind in ("mousePressed", "mouseReleased"):
            browser.call(
                "Input.dispatchMouseEvent", type=kind, x=x, y=y, button="left", clickCount=1
            )
        browser.wait_for("document.body.innerText.includes('angular velocity (rad/s)')", 30)
        text = browser.evaluate("document.body.innerText")
        assert "box (body 0)" in text
        position = re.search(r"position \(m\)\s*\(([^)]*)\)", text).group(1)
        np.testing.assert_allclose([float(v) for v in position.split(",")], 0.0, atol=1e-9)
        omega = re.search(r"angular velocity \(rad/s\)\s*\(([^)]*)\)", text).group(1)
        # the scene spins it at 2 pi rad/s about y, perturbed by 1e-3 about x and z
        np.testing.assert_allclose(
            [float(v) for v in omega.split(",")], [1e-3, 2 * np.pi, 1e-3], rtol=2e-3, atol=2e-4
        )

    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    assert "thesis-rbd view: stopped at t = " in out
    assert "Traceback" not in err
