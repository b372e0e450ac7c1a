"""The live view: a scene simulated in this process and drawn in the browser by viser.

``thesis-rbd view SCENE`` builds the scene's world and serves a page (viser's web client) on
which the bodies move as the world steps, their joints drawn on them (``joint_nodes``): in real
time, at a chosen multiple of it, or as fast as it goes. The panel beside the view plays and
pauses, steps once, resets the scene, sets the speed, shows or hides the contacts (points with
a tick along the normal), shows the time each stage took per step over the last second, and
shows the state of the body last clicked (position, orientation, velocities).

The world lives in the thread that calls :meth:`LiveView.run`; the page's buttons are
answered on viser's threads, which only leave requests for that loop, so the world is never
touched from two threads at once.
"""

from __future__ import annotations

import collections
import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass
from time import perf_counter, sleep

import numpy as np

from thesis_rbd._numba.compile_log import CompileLog
from thesis_rbd.scene import Scene
from thesis_rbd.viz.joint_nodes import JointNodes, world_anchors
from thesis_rbd.viz.viser_scene import (
    BodyNodes,
    add_floor_grid,
    frame_camera,
    require_viser,
    scene_bounds,
)

__all__ = ["LiveView", "PlaybackClock", "stage_timings"]

FRAME_SECONDS = 1.0 / 60.0  # how often the bodies are redrawn
PANEL_SECONDS = 0.25  # how often the text of the panel is refreshed
TIMING_WINDOW_SECONDS = 1.0  # the stage timings cover the steps of the last second
SPEEDS = ("0.1x", "0.25x", "0.5x", "1x", "2x", "4x", "as fast as it goes")
FALLING_BEHIND_SECONDS = 0.25  # further behind the wall clock than this, the clock lets go
KEPT_UP_SECONDS = 1.0  # no longer "falling behind" once it has kept up this long


class _DroppedConnectionFilter(logging.Filter):
    """Drops websockets' report of a connection the client closed before it sent a request.

    Browsers open spare connections ahead of need and close them unused; websockets logs each
    as a failed handshake with a traceback, which on the user's terminal reads as a crash of
    the view. Any other handshake failure still gets through.
    """

    def filter(self, record: logging.LogRecord) -> bool:
        if record.getMessage() != "opening handshake failed" or not record.exc_info:
            return True
        error = record.exc_info[1]
        while error is not None:
            if isinstance(error, EOFError):
                return False
            error = error.__cause__
        return True


def _quiet_dropped_connections() -> None:
    """Install :class:`_DroppedConnectionFilter` on websockets' server logger, once."""
    logger = logging.getLogger("websockets.server")
    if not any(isinstance(f, _DroppedConnectionFilter) for f in logger.filters):
        logger.addFilter(_DroppedConnectionFilter())


class PlaybackClock:
    """How many steps are due: simulated time follows the wall clock times a speed.

    Parameters
    ----------
    dt : float
        The world's time step (s).

    Notes
    -----
    While playing at speed s, simulated time is due to reach t0 + s (w - w0), where t0 and w0
    are the simulated and wall times when play last started or the speed last changed. A
    world that cannot keep up drops the time it is behind instead of racing to catch up, so
    that it plays on smoothly at the speed it manages (:attr:`behind` says so until it has
    kept up for a second).
    """

    def __init__(self, dt: float):
        self.dt = float(dt)
        self.speed: float | None = 1.0  # None: as fast as it goes
        self._anchor: tuple[float, float] | None = None
        self.behind = False
        self._fell_behind = -np.inf

    def start(self, simulated: float, wall: float) -> None:
        """Play from simulated time ``simulated`` at wall time ``wall``."""
        self._anchor = (simulated, wall)
        self.behind = False

    def stop(self) -> None:
        self._anchor = None

    def steps_due(self, simulated: float, wall: float) -> int:
        """Steps to take now to keep up with the wall clock (0 when paused)."""
        if self._anchor is None or self.speed is None:
            return 0
        start_simulated, start_wall = self._anchor
        target = start_simulated + self.speed * (wall - start_wall)
        late = target - simulated
        if late > FALLING_BEHIND_SECONDS * self.speed:
            self.behind, self._fell_behind = True, wall
            self._anchor = (simulated, wall)
            return 1
        if late < self.dt and wall - self._fell_behind > KEPT_UP_SECONDS:
            self.behind = False
        return max(int(np.floor(late / self.dt + 1e-9)), 0)


def stage_timings(before: dict, after: dict, steps: int) -> list[tuple[str, float, float]]:
    """Per stage: milliseconds per step and share of the staged time between two profiles.

    Parameters
    ----------
    before, after : dict
        Copies of ``World.profile`` ({stage: {"calls", "seconds"}}) at two moments.
    steps : int
        Steps taken in between (> 0).

    Returns
    -------
    list of (stage, ms per step, share)
        Stages that ran in between, in pipeline order.
    """
    seconds = {
        stage: after[stage]["seconds"] - before.get(stage, {"seconds": 0.0})["seconds"]
        for stage in after
        if after[stage]["calls"] > before.get(stage, {"calls": 0})["calls"]
    }
    total = sum(seconds.values())
    return [
        (stage, 1e3 * spent / steps, spent / total if total > 0 else 0.0)
        for stage, spent in seconds.items()
    ]


@dataclass
class _Requests:
    """What the page asked for since the loop last looked (set on viser's threads)."""

    steps: int = 0
    reset: bool = False


class LiveView:
    """Serve a scene's simulation, live, on a viser page.

    Parameters
    ----------
    scene : Scene
        The scene to build and run; reset builds it again.
    host : str
        Interface to listen on ("127.0.0.1": this machine only; "0.0.0.0": all of them).
    port : int
        Port to listen on; viser takes the next free one if it is taken (0: any free port).
    playing : bool
        Start playing at once (else paused until the page says play).
    on_compile : callable(name or None), optional
        Told the name of a kernel when numba starts compiling one, and None once the world
        steps again without compiling (the command line shows a spinner in between).

    Raises
    ------
    ValueError
        If the scene has no bodies.

    Attributes
    ----------
    server : viser.ViserServer
    world : World
        Rebuilt from the scene on reset.
    steps : int
        Steps taken since the last reset.
    selected : int or None
        The body whose state the panel shows (the last one clicked).
    """

    def __init__(
        self,
        scene: Scene,
        host: str = "127.0.0.1",
        port: int = 8080,
        playing: bool = True,
        on_compile: Callable[[str | None], None] | None = None,
    ):
        viser = require_viser()
        if not scene.bodies:
            raise ValueError(f"scene {scene.name!r} has no bodies: there is nothing to view")
        self.scene = scene
        self._on_compile = on_compile
        self._compiling: str | None = None
        with CompileLog(on_start=self._compile_started) as log:
            self.world = scene.build()
        self._compile_finished(log)
        self.steps = 0
        self.selected: int | None = None
        self._lock = threading.Lock()
        self._requests = _Requests()
        self._stop = threading.Event()
        self._timings: collections.deque = collections.deque()
        self.clock = PlaybackClock(self.world.dt)
        _quiet_dropped_connections()
        self.server = viser.ViserServer(host=host, port=port, label=f"thesis-rbd: {scene.name}")
        self._build_panel(playing)
        self._build_scene_nodes()

    @property
    def url(self) -> str:
        """Where the page is served."""
        host = self.server.get_host()
        shown = "localhost" if host in ("0.0.0.0", "127.0.0.1", "::") else host
        return f"http://{shown}:{self.server.get_port()}"

    # ------------------------------------------------------------------ the page
    def _build_scene_nodes(self) -> None:
        world, bodies = self.world, self.world.bodies
        joints = world.joint_frames
        lower, upper = scene_bounds(
            bodies.drawn,
            bodies.center_of_mass_local,
            np.asarray(world.positions)[None],
            np.asarray(world.orientations)[None],
            points=world_anchors(joints),
        )
        size = float(np.linalg.norm(upper - lower))
        self.nodes = BodyNodes(
            self.server.scene,
            world.names,
            bodies.drawn,
            bodies.center_of_mass_local,
            bodies.static,
            size,
        )
        # the joints ride on the body nodes: a reset builds the same joints, so they stay
        self.joints = JointNodes(
            self.server.scene, [handle.name for handle in self.nodes.handles], joints, size
        )
        add_floor_grid(self.server.scene, lower, upper, size)
        frame_camera(self.server, lower, upper)
        for index, handle in enumerate(self.nodes.handles):
            handle.on_click(lambda _event, index=index: self._select(index))
        self._draw()

    def _build_panel(self, playing: bool) -> None:
        gui = self.server.gui
        self.status = gui.add_markdown("")
        self.play_button = gui.add_button("Pause" if playing else "Play")
        self.step_button = gui.add_button("Step")
        self.reset_button = gui.add_button("Reset")
        self.speed = gui.add_dropdown("Speed", SPEEDS, initial_value="1x")
        self.show_contacts = gui.add_checkbox("Contacts", True)
        self.timing = gui.add_markdown("Stage timings appear once the world steps.")
        self.body_state = gui.add_markdown("*Click a body to see its state.*")
        self.play_button.on_click(lambda _event: self._toggle_play())
        self.step_button.on_click(lambda _event: self._request(steps=1))
        self.reset_button.on_click(lambda _event: self._request(reset=True))
        self.speed.on_update(lambda _event: self._set_speed(self.speed.value))
        self.playing = playing
        if playing:
            self.clock.start(self.world.time, perf_counter())

    def _toggle_play(self) -> None:
        with self._lock:
            self._set_playing(not self.playing)

    def _set_playing(self, playing: bool) -> None:
        self.playing = playing
        if playing:
            self.clock.start(self.world.time, perf_counter())
        else:
            self.clock.stop()
        self.play_button.label = "Pause" if playing else "Play"

    def _request(self, steps: int = 0, reset: bool = False) -> None:
        with self._lock:
            if steps:
                self._set_playing(False)  # a single step is for looking at: it pauses
            self._requests.steps += steps
            self._requests.reset |= reset

    def _set_speed(self, label: str) -> None:
        with self._lock:
            self.clock.speed = None if label == SPEEDS[-1] else float(label.removesuffix("x"))
            if self.playing:
                self.clock.start(self.world.time, perf_counter())

    def _select(self, index: int) -> None:
        # read by the loop, which shows the body's state at its next panel refresh
        self.selected = index

    def _compile_started(self, kernel: str) -> None:
        self._compiling = kernel
        if hasattr(self, "status"):
            self._refresh_status()
        if self._on_compile is not None:
            self._on_compile(kernel)

    def _compile_finished(self, log: CompileLog) -> None:
        if self._compiling is not None and not log.compiling:
            self._compiling = None
            if self._on_compile is not None:
                self._on_compile(None)

    # ------------------------------------------------------------------ the loop
    def run(self) -> None:
        """Step and draw until :meth:`stop` is called (or Ctrl-C in the calling thread)."""
        last_frame = last_panel = perf_counter()
        self._timings.append((last_panel, self._profile_copy(), self.steps))
        self._refresh_panel(last_panel)
        with CompileLog(on_start=self._compile_started) as log:
            while not self._stop.is_set():
                stepped = self._take_requests()
                with self._lock:
                    due = self._steps_due()
                if due:
                    self._advance(due)
                    stepped = True
                if stepped:
                    self._compile_finished(log)
                now = perf_counter()
                if stepped and now - last_frame >= FRAME_SECONDS:
                    self._draw()
                    last_frame = now
                if now - last_panel >= PANEL_SECONDS:
                    self._refresh_panel(now)
                    last_panel = now
                if not due:
                    sleep(FRAME_SECONDS / 4)

    def _steps_due(self) -> int:
        if not self.playing:
            return 0
        if self.clock.speed is None:
            return self._steps_per_frame()
        return self.clock.steps_due(self.world.time, perf_counter())

    def _steps_per_frame(self) -> int:
        """As fast as it goes: the steps that fit in one frame at the recent cost per step."""
        (wall0, _, steps0), (wall1, _, steps1) = self._timings[0], self._timings[-1]
        if steps1 <= steps0 or wall1 <= wall0:
            return 1
        return max(1, int(FRAME_SECONDS * (steps1 - steps0) / (wall1 - wall0)))

    def _advance(self, steps: int) -> None:
        """Take up to ``steps`` steps, stopping after a frame's worth of wall time so that the
        page stays responsive (the clock asks for the rest next time)."""
        started = perf_counter()
        for _ in range(steps):
            self.world.step()
            self.steps += 1
            if perf_counter() - started > FRAME_SECONDS:
                break

    def _take_requests(self) -> bool:
        """Carry out a reset and single steps asked for; whether the world changed."""
        with self._lock:
            requests, self._requests = self._requests, _Requests()
            if requests.reset:
                self.world = self.scene.build()
                self.steps = 0
                if self.playing:
                    self.clock.start(self.world.time, perf_counter())
                self._timings.clear()
                self._timings.append((perf_counter(), self._profile_copy(), 0))
        if requests.steps:
            self.world.step(requests.steps)
            self.steps += requests.steps
        if requests.reset or requests.steps:
            self._draw()
            self._refresh_panel(perf_counter())
            return True
        return False

    def _profile_copy(self) -> dict:
        return {stage: dict(entry) for stage, entry in self.world.profile.items()}

    def _draw(self) -> None:
        world = self.world
        with self.server.atomic():
            self.nodes.set_poses(world.positions, world.orientations)
            if self.show_contacts.value:
                contacts = world.contacts
                self.nodes.set_contacts(contacts["points"], contacts["normals"])
            else:
                self.nodes.set_contacts(None, None)

    def _refresh_panel(self, now: float) -> None:
        self._timings.append((now, self._profile_copy(), self.steps))
        while len(self._timings) > 2 and now - self._timings[1][0] >= TIMING_WINDOW_SECONDS:
            self._timings.popleft()
        self._refresh_status()
        self._refresh_timing()
        self._refresh_body_state()

    def _refresh_status(self) -> None:
        world = self.world
        if self._compiling is not None:
            state = f"compiling kernels, first run only (`{self._compiling.rsplit('.', 1)[-1]}`)"
        elif not self.playing:
            state = "paused"
        elif self.clock.speed is None:
            state = "as fast as it goes"
        else:
            state = f"{self.clock.speed:g}x real time" + (
                " (falling behind)" if self.clock.behind else ""
            )
        self.status.content = (
            f"**{self.scene.name}**: t = {world.time:.3f} s, step {self.steps} "
            f"(dt = {world.dt:.4g} s, {world.integrator}), {state}"
        )

    def _refresh_timing(self) -> None:
        (wall0, before, steps0), (wall1, after, steps1) = self._timings[0], self._timings[-1]
        steps = steps1 - steps0
        if steps <= 0:
            return  # paused: the timings of the last steps taken stay on show
        per_second = steps / (wall1 - wall0) if wall1 > wall0 else 0.0
        lines = [
            f"Stage timings over the last {steps} steps ({per_second:.0f} steps/s):",
            "",
            "| stage | ms/step | share |",
            "| --- | ---: | ---: |",
        ]
        lines += [
            f"| {stage} | {ms:.3f} | {share:.0%} |"
            for stage, ms, share in stage_timings(before, after, steps)
        ]
        self.timing.content = "\n".join(lines)

    def _refresh_body_state(self) -> None:
        index = self.selected
        if index is None:
            return
        world = self.world
        name = world.names[index]
        if world.bodies.static[index] and not world.bodies.kinematic[index]:
            self.body_state.content = f"**{name}** (body {index}): static"
            return
        rows = [
            ("position (m)", world.position(index)),
            ("orientation (x, y, z, w)", world.orientation(index)),
            ("velocity (m/s)", world.linear_velocity(index)),
            ("angular velocity (rad/s)", world.angular_velocity(index)),
        ]
        asleep = (
            " (kinematic)"
            if world.bodies.kinematic[index]
            else " (asleep)"
            if world.sleeping[index]
            else ""
        )
        lines = [f"**{name}** (body {index}){asleep}", "", "| | |", "| --- | --- |"]
        lines += [f"| {label} | {_vector(value)} |" for label, value in rows]
        self.body_state.content = "\n".join(lines)

    def stop(self) -> None:
        """End :meth:`run` (safe from any thread and from a signal handler)."""
        self._stop.set()

    @property
    def stopping(self) -> bool:
        """Whether :meth:`stop` has been called."""
        return self._stop.is_set()

    def close(self) -> None:
        """Stop the server: the page says that its connection is lost."""
        self.server.stop()


def _vector(values: np.ndarray) -> str:
    return "(" + ", ".join(f"{value:.4g}" for value in np.asarray(values)) + ")"
