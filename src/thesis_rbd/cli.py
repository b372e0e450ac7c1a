"""The ``thesis-rbd`` command line: run scenes, list the built-ins, replay saved runs.

    thesis-rbd run [SCENE] [--seconds S] [--dt DT] [--integrator NAME] [--record-every K]
                   [--contacts | --no-contacts]
                   [--out run.npz] [--html play.html] [--gif play.gif] [--quiet | -v]
    thesis-rbd scenes
    thesis-rbd play RUN.npz [--html play.html] [--gif play.gif]

SCENE is a scene file (TOML) or the name of a built-in scene (``thesis-rbd scenes``); without
one, the default built-in runs. Every input is checked before the run starts: a fault exits
with status 1 and one message on stderr, no traceback, and no output file. Outputs are written
together at the end, each atomically, so a run leaves all of them or none.

The validation campaign is not a command of the installed package: it lives beside the
sources in a checkout and runs there as ``python -m validation``.
"""

from __future__ import annotations

import contextlib
import math
import sys
from pathlib import Path
from time import perf_counter
from typing import Annotated

import typer

from thesis_rbd import scenes as builtin_scenes
from thesis_rbd._atomic import atomic_path, check_writable_folder
from thesis_rbd.dynamics.integrators import INTEGRATORS
from thesis_rbd.scene import Scene, load_scene
from thesis_rbd.trajectory import Trajectory, simulate

__all__ = ["app", "resolve_scene"]

app = typer.Typer(
    name="thesis-rbd",
    help="Rigid-body simulation after the JAOC thesis: run scenes and play them back.",
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)

PROGRESS_AFTER_SECONDS = 1.0
_HTML_HELP = "Write an offline playback page (.html)."
_GIF_HELP = "Write an animated GIF (needs matplotlib)."
_FPS_HELP = "GIF frames per simulated second."
_QUIET_HELP = "Print nothing but errors."


class InputError(Exception):
    """A fault in the user's input, reported as one line and exit status 1."""


def resolve_scene(argument: str) -> Scene:
    """Load ``argument`` as a scene file if it is one, else as a built-in scene's name."""
    path = Path(argument)
    if path.is_file() or path.suffix == ".toml" or "/" in argument or "\\" in argument:
        return load_scene(path)
    if argument in builtin_scenes.names():
        return builtin_scenes.get(argument)
    raise InputError(
        f"no scene file or built-in scene named {argument!r}; "
        f"built-ins: {', '.join(builtin_scenes.names())}"
    )


def _fail(message: str) -> typer.Exit:
    typer.echo(f"thesis-rbd: error: {message}", err=True)
    return typer.Exit(code=1)


@contextlib.contextmanager
def _reported_errors():
    """Turn input faults (bad scene, bad option, unwritable path) into one line and exit 1."""
    try:
        yield
    except (InputError, ValueError, OSError) as exc:
        raise _fail(str(exc)) from None


class _ProgressBar:
    """A rich progress bar on stderr that appears only once a run has lasted a second.

    Called as ``progress(steps_done, steps_total)`` by :func:`simulate`; stays silent when
    stderr is not a terminal or the run is quick.
    """

    def __init__(self, label: str, enabled: bool):
        self.label, self.enabled = label, enabled
        self.start = perf_counter()
        self.bar = None
        self.task = None

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        if self.bar is None:
            if perf_counter() - self.start < PROGRESS_AFTER_SECONDS:
                return
            from rich.console import Console
            from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

            console = Console(stderr=True)
            if not console.is_terminal:
                self.enabled = False
                return
            self.bar = Progress(
                TextColumn("{task.description}"),
                BarColumn(),
                TextColumn("{task.completed}/{task.total} steps"),
                TimeRemainingColumn(),
                console=console,
                transient=True,
            )
            self.bar.start()
            self.task = self.bar.add_task(self.label, total=total)
        self.bar.update(self.task, completed=done)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.stop()


def _check_outputs(out: Path | None, html: Path | None, gif: Path | None) -> list[Path]:
    outputs = [path for path in (out, html, gif) if path is not None]
    for path in outputs:
        check_writable_folder(path)
    resolved = [path.resolve() for path in outputs]
    if len(set(resolved)) != len(resolved):
        raise InputError("--out, --html and --gif must name different files")
    if gif is not None:
        from thesis_rbd.viz.gif import require_matplotlib

        require_matplotlib()
    return outputs


def _write_outputs(
    trajectory: Trajectory,
    out: Path | None,
    html: Path | None,
    gif: Path | None,
    fps: float,
    title: str,
) -> None:
    """Write every requested output; all of them appear at the end, or none does."""
    from thesis_rbd.viz.gif import write_gif
    from thesis_rbd.viz.html import write_html

    with contextlib.ExitStack() as staged:
        if out is not None:
            trajectory.save(staged.enter_context(atomic_path(out)))
        if html is not None:
            write_html(trajectory, staged.enter_context(atomic_path(html)), title=title)
        if gif is not None:
            write_gif(trajectory, staged.enter_context(atomic_path(gif)), fps=fps, title=title)


def _describe_scene(scene: Scene) -> str:
    lines = [f"scene {scene.name} ({scene.source})"]
    lines += [f"  {line}" for line in scene.description.strip().splitlines()]
    settings = ", ".join(f"{key} = {value}" for key, value in scene.world.items()) or "defaults"
    lines.append(f"  [world] {settings}")
    for index, body in enumerate(scene.bodies):
        amount = (
            "static"
            if body.static
            else f"mass {body.mass:g} kg"
            if body.mass is not None
            else f"density {body.density if body.density is not None else 1.0:g} kg/m^3"
        )
        forces = f", {len(body.forces)} applied force(s)" if body.forces else ""
        lines.append(
            f"  body[{index}] {body.name}: {body.shape['type']} ({len(body.mesh.faces)} faces), "
            f"{amount}{forces}"
        )
    return "\n".join(lines)


def _summary(trajectory: Trajectory, wall_seconds: float) -> str:
    meta = trajectory.metadata
    n = trajectory.body_count
    lines = [
        f"{meta.get('scene', 'run')}: {n} {'body' if n == 1 else 'bodies'}, "
        f"{trajectory.times[-1] - trajectory.times[0]:g} s simulated in {meta['steps']} steps "
        f"of {meta['dt']:.6g} s ({meta['integrator']}), {wall_seconds:.3f} s wall",
        f"  {'stage':<14}{'calls':>8}{'seconds':>11}{'share':>8}",
    ]
    profile = {stage: entry for stage, entry in meta["profile"].items() if entry["calls"]}
    staged = sum(entry["seconds"] for entry in profile.values())
    other = max(wall_seconds - staged, 0.0)
    for stage, entry in profile.items():
        share = entry["seconds"] / wall_seconds if wall_seconds > 0 else 0.0
        lines.append(f"  {stage:<14}{entry['calls']:>8}{entry['seconds']:>11.4f}{share:>8.1%}")
    share = other / wall_seconds if wall_seconds > 0 else 0.0
    lines.append(f"  {'(other)':<14}{'':>8}{other:>11.4f}{share:>8.1%}")
    return "\n".join(lines)


@app.command()
def run(
    scene: Annotated[
        str,
        typer.Argument(help="Scene file (.toml) or built-in scene name (see `thesis-rbd scenes`)."),
    ] = builtin_scenes.DEFAULT,
    seconds: Annotated[
        float | None,
        typer.Option("--seconds", "-s", help="Simulated time (s); the scene's own by default."),
    ] = None,
    dt: Annotated[
        float | None, typer.Option("--dt", help="Time step (s); the scene's own by default.")
    ] = None,
    integrator: Annotated[
        str | None,
        typer.Option(
            "--integrator",
            help=f"One of {', '.join(sorted(INTEGRATORS))}; the scene's own by default.",
        ),
    ] = None,
    record_every: Annotated[
        int, typer.Option("--record-every", help="Record a frame every K steps.", min=1)
    ] = 1,
    contacts: Annotated[
        bool | None,
        typer.Option(
            "--contacts/--no-contacts",
            help="Record each frame's contact points (saved in --out, drawn by --html and "
            "--gif); the scene's own choice by default.",
        ),
    ] = None,
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="Write the trajectory (.npz).")
    ] = None,
    html: Annotated[Path | None, typer.Option("--html", help=_HTML_HELP)] = None,
    gif: Annotated[Path | None, typer.Option("--gif", help=_GIF_HELP)] = None,
    fps: Annotated[float, typer.Option("--fps", help=_FPS_HELP)] = 20.0,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help=_QUIET_HELP)] = False,
    verbose: Annotated[
        bool, typer.Option("--verbose", "-v", help="Describe the scene and its stages first.")
    ] = False,
) -> None:
    """Run a scene and report where the time went; optionally save and play it back."""
    with _reported_errors():
        if seconds is not None and not (math.isfinite(seconds) and seconds > 0):
            raise InputError(f"--seconds must be a positive number, got {seconds}")
        if dt is not None and not (math.isfinite(dt) and dt > 0):
            raise InputError(f"--dt must be a positive number, got {dt}")
        if integrator is not None and integrator not in INTEGRATORS:
            raise InputError(
                f"--integrator must be one of {', '.join(sorted(INTEGRATORS))}, got {integrator!r}"
            )
        if not (math.isfinite(fps) and fps > 0):
            raise InputError(f"--fps must be a positive number, got {fps}")
        loaded = resolve_scene(scene)
        overrides = {
            key: value
            for key, value in (("dt", dt), ("integrator", integrator))
            if value is not None
        }
        if overrides:
            loaded = loaded.with_world(**overrides)
        _check_outputs(out, html, gif)
        world = loaded.build()
        if verbose and not quiet:
            typer.echo(_describe_scene(loaded))
            typer.echo(f"  stages: {' -> '.join(world.stages) or '(none: nothing moves)'}")

        duration = loaded.seconds if seconds is None else seconds
        progress = _ProgressBar(loaded.name, enabled=not quiet)
        start = perf_counter()
        try:
            trajectory = simulate(
                world,
                duration,
                record_every=record_every,
                progress=progress,
                record_contacts=loaded.record_contacts if contacts is None else contacts,
            )
        finally:
            progress.close()
        wall = perf_counter() - start
        trajectory.metadata.update(scene=loaded.name, summary=loaded.summary)
        _write_outputs(trajectory, out, html, gif, fps, loaded.name)

    if not quiet:
        typer.echo(_summary(trajectory, wall))
        written = [str(path) for path in (out, html, gif) if path is not None]
        if written:
            recorded = (
                f", {len(trajectory.contact_points)} contacts" if trajectory.has_contacts else ""
            )
            typer.echo(f"wrote {', '.join(written)} ({len(trajectory)} frames{recorded})")


@app.command()
def scenes() -> None:
    """List the built-in scenes, one line each."""
    with _reported_errors():
        listing = [(name, builtin_scenes.get(name).summary) for name in builtin_scenes.names()]
    width = max(len(name) for name, _ in listing)
    for name, summary in listing:
        marker = " (default)" if name == builtin_scenes.DEFAULT else ""
        typer.echo(f"{name:<{width}}  {summary}{marker}")


@app.command()
def play(
    trajectory_file: Annotated[
        Path, typer.Argument(help="A trajectory saved by `thesis-rbd run --out`.")
    ],
    html: Annotated[Path | None, typer.Option("--html", help=_HTML_HELP)] = None,
    gif: Annotated[Path | None, typer.Option("--gif", help=_GIF_HELP)] = None,
    fps: Annotated[float, typer.Option("--fps", help=_FPS_HELP)] = 20.0,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help=_QUIET_HELP)] = False,
) -> None:
    """Turn a saved trajectory into a playback page and/or a GIF."""
    with _reported_errors():
        if html is None and gif is None:
            raise InputError("nothing to write: give --html and/or --gif")
        if not (math.isfinite(fps) and fps > 0):
            raise InputError(f"--fps must be a positive number, got {fps}")
        _check_outputs(None, html, gif)
        trajectory = Trajectory.load(trajectory_file)
        title = trajectory.metadata.get("scene", trajectory_file.stem)
        _write_outputs(trajectory, None, html, gif, fps, title)
    if not quiet:
        typer.echo(f"wrote {', '.join(str(p) for p in (html, gif) if p is not None)}")


def main() -> None:  # pragma: no cover - the console script calls app directly
    app(prog_name="thesis-rbd")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
