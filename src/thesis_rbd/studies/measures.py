"""How far a run strays from its reference: the error columns of a study's table.

Every measure is the largest over the whole run (not the value at its end), in the scene's
own units:

* ``position_error`` (m): the largest distance of a body's centre of mass from where the
  reference has it at the same time;
* ``orientation_error`` (rad): the largest angle between a body's orientation and the
  reference's;
* ``energy_error`` (J): the largest difference between the world's energy (kinetic plus
  gravitational) and the reference's at the same time;
* ``penetration`` (m): the deepest penetration of any contact during the run (the run's own,
  not a difference);
* ``momentum_error`` (N s) and ``angular_momentum_error`` (N m s, about the origin): the
  largest change of the total momentum from its start, only where nothing outside the bodies
  acts on them (NaN elsewhere).

The reference is sampled at its own, finer steps; it is interpolated to the run's sample
times (linearly for positions and energy, by normalised linear interpolation for
orientations), which is exact where a run's steps fall on the reference's.
"""

from __future__ import annotations

import numpy as np

from thesis_rbd.studies.sampling import RunSamples

__all__ = ["MEASURES", "UNITS", "run_errors", "seed_spread"]

MEASURES = (
    "position_error",
    "orientation_error",
    "energy_error",
    "penetration",
    "momentum_error",
    "angular_momentum_error",
)
UNITS = {
    "position_error": "m",
    "orientation_error": "rad",
    "energy_error": "J",
    "penetration": "m",
    "momentum_error": "N s",
    "angular_momentum_error": "N m s",
}


def _at_times(reference: RunSamples, times: np.ndarray):
    """Indices and weights that interpolate the reference's samples at ``times``."""
    t = reference.times
    j = np.clip(np.searchsorted(t, times, side="right") - 1, 0, max(len(t) - 2, 0))
    if len(t) < 2:
        return j, np.zeros(len(times))
    w = np.clip((times - t[j]) / (t[j + 1] - t[j]), 0.0, 1.0)
    return j, w


def _mix(values: np.ndarray, j: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Linear interpolation of ``values`` (T, ...) between samples j and j + 1."""
    if len(values) < 2:
        return values[j]
    shape = (len(j),) + (1,) * (values.ndim - 1)
    return (1.0 - w.reshape(shape)) * values[j] + w.reshape(shape) * values[j + 1]


def _orientations_at(reference: RunSamples, j, w) -> np.ndarray:
    q0 = reference.orientations[j]
    q1 = reference.orientations[np.minimum(j + 1, len(reference) - 1)]
    # q and -q are one rotation: interpolate towards the nearer sign
    q1 = np.where(np.sum(q0 * q1, axis=-1, keepdims=True) < 0, -q1, q1)
    q = (1.0 - w[:, None, None]) * q0 + w[:, None, None] * q1
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def run_errors(run: RunSamples, reference: RunSamples, conserves_momentum: bool) -> dict:
    """The error measures of ``run`` against ``reference`` (see the module docstring).

    Parameters
    ----------
    run, reference : RunSamples
        Of the same bodies; only the run's samples within the reference's time span count.
    conserves_momentum : bool
        Whether nothing outside the bodies acts on them; if not, the momentum columns are NaN.

    Returns
    -------
    dict
        One float per name of ``MEASURES``.
    """
    inside = run.times <= reference.times[-1] + 1e-9 * max(1.0, abs(reference.times[-1]))
    times = run.times[inside]
    j, w = _at_times(reference, times)
    positions = _mix(reference.positions, j, w)
    orientations = _orientations_at(reference, j, w)
    dot = np.abs(np.sum(run.orientations[inside] * orientations, axis=-1))
    errors = {
        "position_error": _largest(np.linalg.norm(run.positions[inside] - positions, axis=-1)),
        "orientation_error": _largest(2.0 * np.arccos(np.clip(dot, 0.0, 1.0))),
        "energy_error": _largest(np.abs(run.energy[inside] - _mix(reference.energy, j, w))),
        "penetration": _largest(run.penetration),
        "momentum_error": np.nan,
        "angular_momentum_error": np.nan,
    }
    if conserves_momentum:
        errors["momentum_error"] = _drift(run.linear_momentum)
        errors["angular_momentum_error"] = _drift(run.angular_momentum)
    return errors


def seed_spread(references: list[RunSamples], conserves_momentum: bool) -> dict:
    """How far the reference runs of the perturbed seeds stray from the unperturbed one:
    the floor below which a study's errors are the scene's own sensitivity, not the
    settings' fault. Zero for every measure with one seed; NaN for the penetration (not a
    distance from the reference) and, where something outside acts, the momenta."""
    spread = dict.fromkeys(MEASURES, 0.0)
    spread["penetration"] = np.nan  # a run's own depth, not a distance from the reference
    if not conserves_momentum:
        spread["momentum_error"] = spread["angular_momentum_error"] = np.nan
    for other in references[1:]:
        errors = run_errors(other, references[0], conserves_momentum)
        for name, value in errors.items():
            if name != "penetration":
                spread[name] = max(spread[name], value)
    return spread


def _largest(values: np.ndarray) -> float:
    return float(np.max(values)) if values.size else 0.0


def _drift(values: np.ndarray) -> float:
    return _largest(np.linalg.norm(values - values[0], axis=-1))
