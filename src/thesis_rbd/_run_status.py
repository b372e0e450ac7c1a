"""What a command shows on stderr while it works: a spinner while numba compiles kernels, and
a progress bar once a run has lasted a second.

On a terminal both are one live rich display (rich allows one at a time), removed when the
command ends. Elsewhere (a pipe, a log file) the progress bar stays silent and compiling is
said once, on one line, so that a long first run is never a silent one.
"""

from __future__ import annotations

from time import perf_counter

__all__ = ["COMPILING_MESSAGE", "RunStatus"]

PROGRESS_AFTER_SECONDS = 1.0
COMPILING_MESSAGE = "compiling kernels, first run only"
COMPILING_NOTE = (
    f"thesis-rbd: {COMPILING_MESSAGE} (numba keeps them in its cache for later runs; "
    "`thesis-rbd warmup` compiles them all ahead)"
)


class RunStatus:
    """The live status of a command on stderr.

    Parameters
    ----------
    label : str
        What the progress bar is of (a scene's name).
    enabled : bool
        False shows nothing at all (``--quiet``).
    unit : str
        What the progress bar counts.
    after_seconds : float
        The progress bar appears once the work has lasted this long.
    console : rich.console.Console, optional
        Where to show it; stderr by default.

    Notes
    -----
    Called as ``status(steps_done, steps_total)`` it is the progress callback of
    :func:`thesis_rbd.simulate`; :meth:`compiling` is told the kernel numba compiles (or None
    once it is done) by a :class:`thesis_rbd._numba.compile_log.CompileLog`.
    """

    def __init__(
        self,
        label: str,
        enabled: bool = True,
        unit: str = "steps",
        after_seconds: float = PROGRESS_AFTER_SECONDS,
        console=None,
    ):
        from rich.console import Console

        self.label, self.enabled = label, enabled
        self.unit, self.after_seconds = unit, after_seconds
        self.console = Console(stderr=True) if console is None else console
        self.terminal = self.console.is_terminal
        self.start = perf_counter()
        self.display = None
        self.steps_task = self.compile_task = None
        self.compile_noted = False

    def _live(self):
        """The rich display, started on first use."""
        if self.display is None:
            from rich.progress import (
                BarColumn,
                Progress,
                SpinnerColumn,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )

            self.display = Progress(
                SpinnerColumn(),
                TextColumn("{task.description}"),
                BarColumn(),
                TextColumn("{task.fields[detail]}"),
                TimeElapsedColumn(),
                TimeRemainingColumn(),
                console=self.console,
                transient=True,
            )
            self.display.start()
        return self.display

    def compiling(self, kernel: str | None) -> None:
        """Show that numba compiles ``kernel`` (its dotted name), or that it is done (None)."""
        if not self.enabled:
            return
        if not self.terminal:
            if kernel is not None and not self.compile_noted:
                self.console.print(COMPILING_NOTE, markup=False, highlight=False, soft_wrap=True)
                self.compile_noted = True
            return
        display = self._live()
        if self.compile_task is None:
            self.compile_task = display.add_task(COMPILING_MESSAGE, total=None, detail="")
        if kernel is None:
            display.update(self.compile_task, visible=False)
        else:
            display.update(self.compile_task, visible=True, detail=kernel.rsplit(".", 1)[-1])

    def __call__(self, done: int, total: int, label: str | None = None) -> None:
        """Progress: ``done`` of ``total`` (steps of a run), now at ``label`` if given."""
        if label is not None:
            self.label = label
        if not (self.enabled and self.terminal):
            return
        if self.steps_task is None:
            if perf_counter() - self.start < self.after_seconds:
                return
            self.steps_task = self._live().add_task(self.label, total=total, detail="")
        self.display.update(
            self.steps_task,
            completed=done,
            description=self.label,
            detail=f"{done}/{total} {self.unit}",
        )

    def close(self) -> None:
        """Remove the display."""
        if self.display is not None:
            self.display.stop()
            self.display = None
