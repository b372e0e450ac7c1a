"""The ``thesis-rbd`` command line: run scenes, view them live, list the built-ins, replay saved
runs, compile the kernels ahead.

    thesis-rbd run [SCENE] [--seconds S] [--dt DT] [--integrator NAME] [--record-every K]
                   [--contacts | --no-contacts]
                   [--out run.npz] [--html play.html] [--gif play.gif] [--quiet | -v]
    thesis-rbd view [SCENE] [--port P] [--host H] [--paused]
    thesis-rbd scenes
    thesis-rbd play RUN.npz [--html play.html] [--gif play.gif]
    thesis-rbd warmup [--quiet]

SCENE is a scene file (TOML) or the name of a built-in scene (``thesis-rbd scenes``); without
one, the default built-in runs. Every input is checked before the run starts: a fault exits
with status 1 and one message on stderr, no traceback, and no output file. Outputs are written
together at the end, each atomically, so a run leaves all of them or none.

numba compiles the kernels on their first use, which takes minutes once and is cached for
every later run: while it compiles, the commands say so on stderr (a spinner on a terminal),
and ``run`` reports the time spent compiling apart from the time of the stages.

The validation campaign is not a command of the installed package: it lives beside the
sources in a checkout and runs there as ``python -m validation``.
"""

from __future__ import annotations

import atexit
import contextlib
import gc
import math
import signal
import sys
import warnings
from pathlib import Path
from time import perf_counter
from typing import Annotated

import typer

from thesis_rbd import scenes as builtin_scenes
from thesis_rbd._atomic import atomic_path, check_writable_folder
from thesis_rbd._numba.compile_helpers import CompileHelpers
from thesis_rbd._numba.compile_log import CompileLog
from thesis_rbd._numba.stage_ledger import StageLedger
from thesis_rbd._run_status import RunStatus
from thesis_rbd.dynamics.integrators import INTEGRATORS
from thesis_rbd.scene import Scene
from thesis_rbd.trajectory import MEMORY_LIMIT, Trajectory, planned_steps, simulate
from thesis_rbd.world.world import DEFAULT_DT

__all__ = ["app"]

app = typer.Typer(
    name="thesis-rbd",
    help="Rigid-body simulation after the JAOC thesis: run scenes, view them live, play them back.",
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)

_HTML_HELP = "Write an offline playback page (.html; drawn by viser)."
_GIF_HELP = "Write an animated GIF (needs matplotlib)."
_FPS_HELP = "GIF frames per simulated second."
_HELPERS_HELP = (
    "Processes that compile kernels beside a first run, each a share of the scene's kernels; "
    "one per spare core by default, 0 for none."
)
_QUIET_HELP = "Print nothing but errors."
WARMUP_SLOWEST = 10


class InputError(Exception):
    """A fault in the user's input, reported as one line and exit status 1."""


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
    except MemoryError as exc:
        raise _fail(f"not enough memory ({exc or 'allocation failed'})") from None
    except ArithmeticError as exc:  # a range the checks missed: still one line
        raise _fail(f"a number is out of range ({exc})") from None


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
    if html is not None:
        from thesis_rbd.viz.viser_scene import require_viser

        require_viser()
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
            "kinematic"
            if body.kinematic
            else "static"
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


def _planned_scenes(argument: str) -> list[str] | None:
    """The compile plans a run of ``argument`` shares among helpers: the built-in scene's own,
    or, for a scene file, every built-in scene's (its kernels are among theirs)."""
    return [argument] if argument in builtin_scenes.names() else None


def _summary(
    trajectory: Trajectory,
    wall_seconds: float,
    log: CompileLog,
    ledger: StageLedger,
    helpers: int = 0,
) -> str:
    """The run in a line, the time spent compiling kernels if any, and a line per stage.

    The stage table leaves out the frames during which kernels compiled (:class:`StageLedger`),
    so that a first run shows what the stages cost, not what compiling them cost.
    """
    meta = trajectory.metadata
    n = trajectory.body_count
    lines = [
        f"{meta.get('scene', 'run')}: {n} {'body' if n == 1 else 'bodies'}, "
        f"{trajectory.times[-1] - trajectory.times[0]:g} s simulated in {meta['steps']} steps "
        f"of {meta['dt']:.6g} s ({meta['integrator']}), {wall_seconds:.3f} s wall"
    ]
    profile = ledger.without_compiling(meta["profile"])
    staged_wall = wall_seconds
    if log.records or log.waits:
        staged_wall = max(wall_seconds - ledger.compiling_wall, 0.0)
        beside = (
            f", with {helpers} helper process{'es' if helpers > 1 else ''} compiling beside it"
            if helpers
            else ""
        )
        lines.append(
            f"  compiling kernels, first run only: {log.seconds:.3f} s for "
            f"{_kernels(log.kernel_count)}{beside} (numba caches them for later runs)"
        )
        if ledger.compiling_steps:
            steps = ledger.compiling_steps
            lines.append(
                f"  the stage times below leave out the {steps} step{'' if steps == 1 else 's'} "
                "during which kernels compiled"
            )
    lines.append(f"  {'stage':<14}{'calls':>8}{'seconds':>11}{'share':>8}")
    profile = {stage: entry for stage, entry in profile.items() if entry["calls"]}
    staged = sum(entry["seconds"] for entry in profile.values())
    other = max(staged_wall - staged, 0.0)
    for stage, entry in profile.items():
        share = entry["seconds"] / staged_wall if staged_wall > 0 else 0.0
        lines.append(f"  {stage:<14}{entry['calls']:>8}{entry['seconds']:>11.4f}{share:>8.1%}")
    share = other / staged_wall if staged_wall > 0 else 0.0
    lines.append(f"  {'(other)':<14}{'':>8}{other:>11.4f}{share:>8.1%}")
    return "\n".join(lines)


@app.command()
def run(
    scene: Annotated[
        str,
        typer.Argument(
            help="Scene file (.toml), URDF file (.urdf) or built-in scene name (see "
            "`thesis-rbd scenes`)."
        ),
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
    memory_limit: Annotated[
        float,
        typer.Option(
            "--memory-limit",
            help="GiB the recorded frames may take; a run that needs more is refused first.",
        ),
    ] = MEMORY_LIMIT / 2**30,
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
    compile_helpers: Annotated[
        int | None, typer.Option("--compile-helpers", help=_HELPERS_HELP, min=0)
    ] = None,
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
        loaded = builtin_scenes.resolve(scene)
        overrides = {
            key: value
            for key, value in (("dt", dt), ("integrator", integrator))
            if value is not None
        }
        if overrides:
            loaded = loaded.with_world(**overrides)
        if not (math.isfinite(memory_limit) and memory_limit > 0):
            raise InputError(f"--memory-limit must be a positive number, got {memory_limit}")
        # the run's steps and frames, checked before the world is built
        planned_steps(
            loaded.seconds if seconds is None else seconds,
            loaded.world.get("dt", DEFAULT_DT), record_every, len(loaded.bodies),
            memory_limit * 2**30,
        )  # fmt: skip
        _check_outputs(out, html, gif)
        status = RunStatus(loaded.name, enabled=not quiet)
        try:
            with (
                CompileLog(
                    on_start=status.compiling, on_end=lambda _record: status.compiling(None)
                ) as log,
                CompileHelpers(_planned_scenes(scene), compile_helpers) as helpers,
            ):
                start = perf_counter()
                world = loaded.build()
                if verbose and not quiet:
                    status.close()
                    typer.echo(_describe_scene(loaded))
                    typer.echo(f"  stages: {' -> '.join(world.stages) or '(none: nothing moves)'}")
                ledger = StageLedger(world, log)
                if log.records:  # compiled while building: set the build aside as well
                    ledger.compiling_wall += perf_counter() - start

                def progress(done: int, total: int) -> None:
                    ledger(done, total)
                    status(done, total)

                trajectory = simulate(
                    world,
                    loaded.seconds if seconds is None else seconds,
                    record_every=record_every,
                    progress=progress,
                    record_contacts=loaded.record_contacts if contacts is None else contacts,
                    memory_limit=memory_limit * 2**30,
                )
                wall = perf_counter() - start
        finally:
            status.close()
        trajectory.metadata.update(scene=loaded.name, summary=loaded.summary)
        _write_outputs(trajectory, out, html, gif, fps, loaded.name)

    if not quiet:
        typer.echo(_summary(trajectory, wall, log, ledger, helpers.started))
        written = [str(path) for path in (out, html, gif) if path is not None]
        if written:
            recorded = (
                f", {len(trajectory.contact_points)} contacts" if trajectory.has_contacts else ""
            )
            typer.echo(f"wrote {', '.join(written)} ({len(trajectory)} frames{recorded})")


@app.command()
def view(
    scene: Annotated[
        str,
        typer.Argument(
            help="Scene file (.toml), URDF file (.urdf) or built-in scene name (see "
            "`thesis-rbd scenes`)."
        ),
    ] = builtin_scenes.DEFAULT,
    port: Annotated[
        int,
        typer.Option(
            "--port", "-p", help="Port to serve on (the next free one if taken).", min=0, max=65535
        ),
    ] = 8080,
    host: Annotated[
        str,
        typer.Option(
            "--host", help="Interface to listen on: 127.0.0.1 (this machine) or 0.0.0.0 (all)."
        ),
    ] = "127.0.0.1",
    paused: Annotated[
        bool, typer.Option("--paused", help="Start paused (press Play on the page).")
    ] = False,
    compile_helpers: Annotated[
        int | None, typer.Option("--compile-helpers", help=_HELPERS_HELP, min=0)
    ] = None,
) -> None:
    """Simulate a scene live in the browser: play, pause, step, reset, speed, contacts, timings.

    Open the address it prints; click a body to see its state. Ctrl-C stops it.
    """
    with _reported_errors():
        from thesis_rbd.viz.viser_scene import require_viser

        require_viser()
        loaded = builtin_scenes.resolve(scene)
    from thesis_rbd.viz.live import LiveView

    status = RunStatus(loaded.name)
    live = None
    try:
        with (
            CompileLog(on_start=status.compiling, on_end=lambda _record: status.compiling(None)),
            CompileHelpers(_planned_scenes(scene), compile_helpers),
        ):
            with _reported_errors():
                live = LiveView(
                    loaded, host=host, port=port, playing=not paused, on_compile=status.compiling
                )
            typer.echo(f"thesis-rbd view: {loaded.name} at {live.url} (Ctrl-C stops it)")
            with _ctrl_c_stops(live):
                live.run()
    except KeyboardInterrupt:
        pass  # Ctrl-C is how the view is meant to end
    finally:
        status.close()
        if live is not None:
            live.close()
    if live is not None:
        typer.echo(
            f"thesis-rbd view: stopped at t = {live.world.time:.3f} s after {live.steps} steps"
        )


@contextlib.contextmanager
def _ctrl_c_stops(live):
    """While the view runs, Ctrl-C asks its loop to end after the current frame instead of
    raising KeyboardInterrupt wherever the main thread happens to be (inside the web server's
    calls an interrupt can leave a lock held, and stopping the server then waits forever); a
    second Ctrl-C interrupts at once."""

    def stop(signum, frame):
        if live.stopping:
            raise KeyboardInterrupt
        live.stop()

    previous = signal.signal(signal.SIGINT, stop)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@app.command()
def warmup(
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help=_QUIET_HELP)] = False,
    compile_helpers: Annotated[
        int | None, typer.Option("--compile-helpers", help=_HELPERS_HELP, min=0)
    ] = None,
) -> None:
    """Compile every kernel ahead: minutes once, then every run starts in a second or two.

    Runs each built-in scene for a simulated second and the collision queries once; numba keeps
    what it compiles in its cache. Reports each part's time and the slowest kernels.
    """
    from thesis_rbd._numba.warmup import WarmupTask, slowest_kernels, warm_up, warmup_tasks

    helpers = CompileHelpers(None, compile_helpers)
    tasks = warmup_tasks()
    if helpers.helpers:
        together = f"every scene's kernels, {helpers.helpers + 1} processes at once"
        tasks.insert(0, WarmupTask(together, helpers.start))
    status = RunStatus("warm-up", enabled=not quiet, unit="parts", after_seconds=0.0)
    done = 0

    def started(task) -> None:
        status(done, len(tasks), label=task.name)

    def finished(result) -> None:
        nonlocal done
        done += 1
        status(done, len(tasks))
        if not quiet and not status.terminal:
            typer.echo(f"  {result.name}: {result.seconds:.2f} s, {_compiled(result.compiles)}")

    start = perf_counter()
    try:
        results = warm_up(tasks, on_start=started, on_compile=status.compiling, on_end=finished)
    finally:
        helpers.stop()
        status.close()
    if quiet:
        return
    compiles = [record for result in results for record in result.compiles]
    if status.terminal:
        for result in results:
            typer.echo(f"  {result.name}: {result.seconds:.2f} s, {_compiled(result.compiles)}")
    typer.echo(
        f"warm-up: {perf_counter() - start:.1f} s, {_compiled(compiles)}"
        + (
            f" in {sum(r.compile_seconds for r in results):.1f} s"
            if compiles
            else " (all were cached already)"
        )
    )
    if compiles:
        typer.echo(f"  {'slowest kernels to compile (own time)':<64}{'seconds':>9}")
        for name, signatures, seconds in slowest_kernels(compiles)[:WARMUP_SLOWEST]:
            label = name.removeprefix("thesis_rbd.") + (
                f" ({signatures} signatures)" if signatures > 1 else ""
            )
            typer.echo(f"  {label:<64}{seconds:>9.2f}")


def _kernels(count: int) -> str:
    return f"{count} kernel{'' if count == 1 else 's'}"


def _compiled(records) -> str:
    return f"compiled {_kernels(len({record.name for record in records}))}"


@app.command()
def study(
    scene: Annotated[
        str, typer.Argument(help="Scene file (.toml), URDF file (.urdf) or built-in scene name.")
    ],
    vary: Annotated[
        list[str],
        typer.Option(
            "--vary",
            help="NAME=V1,V2,... : a world setting and its values (repeat for more settings; "
            "every combination runs). Fractions such as 1/240 are read as numbers.",
        ),
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out", "-o", help="Folder for results.csv, study.html and the records (resumes)."
        ),
    ],
    seconds: Annotated[
        float | None,
        typer.Option(
            "--seconds", "-s", help="Simulated time of each run; the scene's own by default."
        ),
    ] = None,
    seeds: Annotated[
        int, typer.Option("--seeds", help="Runs per variant (seeds 1.. perturb the initial poses).")
    ] = 1,
    perturbation: Annotated[
        float,
        typer.Option(
            "--perturbation",
            help="Fraction of each body's size (and radians) the seeds move it by.",
        ),
    ] = 1e-6,
    within: Annotated[
        str | None,
        typer.Option(
            "--within",
            help="Thresholds for the recommendation: position=1e-3,energy=1e-2 (scene units).",
        ),
    ] = None,
    reference: Annotated[
        str | None,
        typer.Option(
            "--reference",
            help="Settings of the reference run over the default (a quarter of the finest dt, "
            "contacts solved 100x tighter): integrator=rk4,dt=1/4000",
        ),
    ] = None,
    workers: Annotated[
        int | None,
        typer.Option(
            "--workers", "-j", help="Local worker processes; every core by default.", min=1
        ),
    ] = None,
    scheduler: Annotated[
        str | None,
        typer.Option("--scheduler", help="A Dask scheduler's address (tcp://HOST:PORT)."),
    ] = None,
    fresh: Annotated[
        bool, typer.Option("--fresh", help="Forget the runs already recorded in --out.")
    ] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help=_QUIET_HELP)] = False,
) -> None:
    """What accuracy costs in time on a scene: run every combination of some world settings
    against a reference run, and write the table, the plot and a recommendation."""
    from thesis_rbd.studies import StudyError
    from thesis_rbd.studies import study as run_study
    from thesis_rbd.studies.grid import parse_assignments, parse_vary

    with _reported_errors():
        try:
            grid = dict(parse_vary(spec) for spec in vary)
            if len(grid) != len(vary):
                raise InputError("a setting is given in two --vary options")
            status = RunStatus(Path(scene).stem, enabled=not quiet, unit="runs", after_seconds=0.0)
            try:
                table = run_study(
                    builtin_scenes.resolve(scene),
                    grid,
                    seconds=seconds,
                    reference=None
                    if reference is None
                    else parse_assignments(reference, "--reference"),
                    seeds=seeds,
                    scheduler=scheduler,
                    workers=workers,
                    perturbation=perturbation,
                    out=out,
                    fresh=fresh,
                    within=None if within is None else parse_assignments(within, "--within"),
                    progress=status,
                )
            finally:
                status.close()
        except (StudyError, ImportError) as exc:
            raise InputError(str(exc)) from None
        except KeyboardInterrupt:
            from thesis_rbd.studies.folder import recorded_runs

            done = recorded_runs(out)
            typer.echo(
                f"thesis-rbd: interrupted; {done} runs are recorded in {out}: the same command "
                "runs the rest",
                err=True,
            )
            raise typer.Exit(code=130) from None
    if quiet:
        return
    failed = sum(row["status"] != "ok" for row in table)
    typer.echo(
        f"{len(table)} runs ({failed} failed) of {len(table.variants())} variants: "
        f"{out / 'results.csv'}, {out / 'study.html'}"
    )
    if within is not None:
        typer.echo(table.recommend(parse_assignments(within, "--within")).sentence)


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


def main(argv: list[str] | None = None) -> None:
    """The ``thesis-rbd`` console script: :data:`app` with the garbage collector kept off the
    objects that live as long as the process.

    numba, LLVM and SciPy leave a great many long-lived objects behind when imported, and
    every cached kernel loaded adds more. Python's cyclic collector walks all of them at each
    full collection and once more at exit, which a short run waits for. ``gc.freeze`` moves
    them out of its sight: once here, after the imports, and once at exit (an ``atexit``
    hook, which runs after the command finished and its outputs were written and closed).
    Objects made during the run are still collected as usual.
    """
    gc.freeze()
    atexit.register(gc.freeze)
    # NumPy's overflow and invalid-value warnings on extreme input are not messages for a
    # user: every value they concern is checked and refused in one line by name
    warnings.simplefilter("ignore", RuntimeWarning)
    try:
        with _signals_stop_the_run():
            app(argv, prog_name="thesis-rbd")
    except (Stopped, SystemError) as exc:
        stop = _stopped_in(exc)
        if stop is None:
            raise
        name = signal.Signals(stop.signum).name
        typer.echo(f"thesis-rbd: stopped by {name}; no output written", err=True)
        sys.exit(128 + stop.signum)


def _stopped_in(exc: BaseException) -> Stopped | None:
    """The :class:`Stopped` that ``exc`` is, or that caused it: raised while a numba kernel
    was calling back into Python, it reaches the command wrapped in SystemErrors."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, Stopped):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


class Stopped(BaseException):
    """SIGTERM or SIGHUP arrived: raised where the main thread is, like KeyboardInterrupt for
    SIGINT, so the run unwinds and every partial output is removed on the way
    (:func:`thesis_rbd._atomic.atomic_path`); the process then exits with 128 + the signal's
    number, as a shell reports a process the signal killed (143 for SIGTERM, 129 for SIGHUP).
    """

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


@contextlib.contextmanager
def _signals_stop_the_run():
    """SIGTERM and SIGHUP raise :class:`Stopped` while the command runs."""

    def stop(signum, frame):
        raise Stopped(signum)

    handled = [getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name)]
    previous = {signum: signal.signal(signum, stop) for signum in handled}
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
