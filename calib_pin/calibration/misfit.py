"""The pre-fit misfit check: a unit or order mistake named before the fit.

Where a calibration is prepared, each set's sensor start geometry is already fitted with
the nominal robot. A robot within its tolerances (the prior,
:class:`~calib_pin.parameters.prior.Prior`: 1 mm and 0.1 deg per deviation) misses the rows
by what its deviations move them, less what the sensor's own unknowns absorb, plus the
noise: :func:`misfit` measures each row's error in that unit. A set the nominal robot misses
by more than :data:`MISFIT_FAR` of them is far off. Its sensor's usual mistakes
(``MeasurementModel.misreadings``, :mod:`calib_pin.sensors.misreading`) are then tried,
each reading the set as that mistake would have it; the first that brings the misfit
within :data:`MISFIT_EXPLAINED` is named in one line: the file, the column or line, the
likely cause and the fix. A start (``--nominal``) far off is checked against its own
(:data:`~calib_pin.calibration.start.START_MISREADINGS`). When none explains the misfit
the calibration goes on: a robot far from its catalogue is no mistake of the file.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..estimators.problem import data_rows, row_offsets
from ..exceptions import CalibPinError, DataError
from ..parameters.prior import Prior
from ..sensors import sensor_for
from ..sensors.base import check_rows
from ..sensors.misreading import Reading, Suspect

if TYPE_CHECKING:
    from ..sensors.problem import SetProblem

#: A set whose rows the nominal robot misses by more than this many times what a robot
#: within its tolerances would (RMS) is far off: its sensor's usual mistakes are tried.
MISFIT_FAR = 10.0
#: A reading of the set that brings the misfit within this many times explains it (the
#: shipped and simulated sets stay within 3).
MISFIT_EXPLAINED = 5.0


@dataclass(frozen=True)
class Misfit:
    """How far a set's rows are from a robot.

    Attributes:
        times: RMS over the rows of each row's error over what a robot within its
            tolerances would leave there (with the noise): the larger of the data rows'
            and the other rows' (a contact set's known distances).
        text: The RMS errors for people (``310 mm``, ``position 71.6 mm, orientation 98.5 deg``).
    """

    times: float
    text: str


def misfit(problem: SetProblem, x: np.ndarray, sigma: float, prior: Prior) -> Misfit:
    """How far ``problem``'s rows (at most :data:`~calib_pin.sensors.base.CHECK_ROWS`) are
    from the robot at ``x``.

    What a robot within its tolerances leaves on each residual entry: the prior's
    deviation moved through the Jacobian at x, less what the sensor's unknowns absorb
    (the part in the span of their columns), and the noise ``sigma`` [m].
    """
    rows = check_rows(len(problem.q))
    part = problem.subset(rows) if len(rows) < len(problem.q) else problem
    residual, jacobian = part.residual(x), part.jacobian(x)
    model = part.model
    n = model.sensor_start
    moved = jacobian[:, :n] * prior.sigma(model.units[:n], model.scale[:n])
    sensor = jacobian[:, n:]
    if sensor.size:
        u, singular, _ = np.linalg.svd(sensor, full_matrices=False)
        basis = u[:, singular > singular[0] * 1e-9] if singular[0] > 0 else u[:, :0]
        moved = moved - basis @ (basis.T @ moved)
    starts = row_offsets(part)[:-1]
    ratio = np.add.reduceat(residual**2, starts) / np.add.reduceat(np.sum(moved**2, axis=1) + sigma**2, starts)
    data = data_rows(part)
    other = np.setdiff1d(np.arange(len(starts)), data)
    times = max(float(np.sqrt(np.mean(ratio[g]))) for g in (data, other) if len(g))
    errors = np.asarray(part.row_errors(residual))
    factor = 1e3 if model.value_unit == "mm" else float(np.degrees(1.0))
    parts = model.errors_by_part(x, part.q, part.readings)
    if parts:
        text = ", ".join(f"{name.rsplit('_', 1)[0]} {_rms(e):.3g} {name.rsplit('_', 1)[1]}" for name, e in parts.items())
    else:
        text = f"{_rms(errors[data]) * factor:.3g} {model.value_unit}"
    if len(other):
        text += f", {part.other_rows} {_rms(errors[other]) * factor:.3g} {model.value_unit}"
    return Misfit(times, text)


def _rms(values: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(values))))


def _said(reading: Reading, found: Misfit, read: Misfit, prior: Prior, who: str, beside: str = "") -> str:
    """The one line naming a mistake: its cause, what was given, both misfits and the fix."""
    return (f"{reading.cause}? {reading.shown}; {who} misses the rows by {found.text} RMS{beside}, "
            f"{found.times:.3g} times what a robot within its tolerances ({prior.describe()}) would; "
            f"{reading.read_as}, by {read.text}: {reading.fix}")


def check_misfits(calibration: Any) -> None:
    """Name a set, or a start, that the nominal robot misses far more than a robot within
    its tolerances would, when a usual mistake explains it (module docstring).

    Args:
        calibration: A :class:`~calib_pin.calibration.prepare.Calibration` as prepared.

    Raises:
        DataError: naming the file, the column or line, the likely cause and the fix.
    """
    from ..measurements.checks import file_header

    problem = calibration.problem
    prior = calibration.prior
    found: dict[int, tuple[Misfit, Suspect, float]] = {}
    for part, k in zip(problem.parts, problem.sets, strict=True):
        s = calibration.sets[k]
        sigma = s.sigma or calibration.noise
        nominal = misfit(part, np.zeros(part.n_params), sigma, prior)
        suspect = Suspect(calibration.chain, calibration.params, s.data, s.options, part,
                          file_header(s.data.source) if s.data.source else None, calibration.start)
        found[k] = (nominal, suspect, sigma)
        if nominal.times > MISFIT_FAR:
            _explain(suspect, nominal, sigma, prior, s.data.source or f"set {s.label}")
    if calibration.start is not None:
        _check_start(calibration, found)


def _explain(suspect: Suspect, nominal: Misfit, sigma: float, prior: Prior, source: str) -> None:
    """Refuse the set when one of its sensor's misreadings explains its misfit."""
    sensor = sensor_for(suspect.data.kind)
    every = np.arange(len(suspect.data))
    for misreading in sensor.misreadings:
        for reading in misreading.readings(suspect):
            data = suspect.data if reading.data is None else reading.data
            options = suspect.options if reading.options is None else reading.options
            try:
                read = sensor.problem_for(suspect.chain, suspect.params, data, every, options)
                other = misfit(read, np.zeros(read.n_params), sigma, prior)
            except CalibPinError:
                continue  # that reading cannot even be prepared: not it
            if other.times <= MISFIT_EXPLAINED:
                raise DataError(source, _said(reading, nominal, other, prior, "the nominal robot"), reading.line,
                                reading.field)


def _check_start(calibration: Any, found: dict[int, tuple[Misfit, Suspect, float]]) -> None:
    """Refuse a start far off when one of the start's misreadings explains it."""
    from .start import START_MISREADINGS

    start, problem, prior = calibration.start, calibration.problem, calibration.prior
    assert start is not None
    x0 = start.x0(problem, problem)
    at_start = {k: misfit(part, np.asarray(problem.model.part_x(x0, k)), found[k][2], prior)
                for part, k in zip(problem.parts, problem.sets, strict=True)}
    worst = max(at_start, key=lambda k: at_start[k].times)
    if not at_start[worst].times > MISFIT_FAR:
        return
    nominal, suspect, sigma = found[worst]
    part = problem.parts[problem.sets.index(worst)]
    beside = f" (the catalogue {calibration.chain.name}: {nominal.text})"
    for misreading in START_MISREADINGS:
        for reading in misreading.readings(suspect):
            robot_x = start.robot_x if reading.robot_x is None else reading.robot_x
            x = replace(start, robot_x=robot_x, compliance=None).x0(problem, problem)
            other = misfit(part, np.asarray(problem.model.part_x(x, worst)), sigma, prior)
            if other.times <= MISFIT_EXPLAINED:
                raise DataError(start.source, _said(reading, at_start[worst], other, prior, "the start", beside),
                                reading.line, reading.field)
