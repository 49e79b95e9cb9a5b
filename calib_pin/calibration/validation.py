"""A separate validation session and its sensor set-up: the training set's, or a new one.

A validation session is often measured with the sensor moved: the tracker relocated, the
drawstring re-anchored. :class:`TestSet` says which, per session:

- ``register=None`` (the default): the same set-up as the training set (``same``: its
  label). The session's own set-up must agree with the calibration's, else it is refused
  (:func:`check_same_setup`: a drawstring's ``# anchor_mm``; a device frame more than 5 mm
  from the calibration's); nothing is fitted on it (:func:`score_session`).
- ``register=k`` (k of the session's poses: its first k, or one of each fixture or point
  in turn, :func:`registration_rows`) or ``register="role"`` (its rows whose
  ``role`` column says ``register``): a new set-up, re-registered first. Only the session's
  own sensor unknowns (a device frame and markers, a drawstring's anchor and offset) are
  fitted on those rows with the calibrated robot fixed (:func:`register_session`); the
  other rows are scored. A registration row is never scored.

Every row of every training set trains; ``same`` names the set whose set-up the session
shares (:func:`choose_training_set`; with one set of its kind it may be left out), and a
re-registered session takes its sensor's model from the first set of its kind.

The "before" error of a re-registered session is the same protocol with the nominal robot:
its sensor unknowns fitted on the same rows with the nominal robot, the rest scored.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis.metrics import Metrics
from ..estimators.problem import data_row_errors
from ..exceptions import ArgumentError, DataError
from ..measurements import MeasurementSet
from ..sensors import SENSORS, sensor_for
from ..sensors.base import FIT_ROWS_KEY
from ..sensors.problem import SetProblem
from .holdout import REGISTER_ROLE, TestSet


def check_same_setup(session: MeasurementSet, training: MeasurementSet, options: Mapping[str, Any]) -> None:
    """Refuse a validation session whose own sensor set-up contradicts the calibration's.

    The calibration's set-up is the training set's, or the caller's overrides in
    ``options``; what contradicts is the sensor's to say
    (:meth:`~calib_pin.sensors.base.MeasurementModel.check_same_setup`).

    Args:
        session: The validation session's measurements.
        training: The training set whose set-up it shares.
        options: That set's sensor options (the caller's overrides).

    Raises:
        DataError: naming the session's file, the key and both values.
    """
    model = SENSORS.get(session.kind)
    if model is not None:
        model.check_same_setup(session, training, options)


def choose_training_set(test: TestSet, session: MeasurementSet, labels: tuple[str, ...] | list[str],
                        kinds: list[str], sources: list[str] | None = None) -> int:
    """The training set (index into ``labels``) a validation session relates to.

    With ``register``, the first set of its kind (whose sensor model re-registers it); else
    the set ``same`` names (its label, or its file's name), or the only set of its kind.

    Args:
        test: The session, with ``same`` and ``register``.
        session: The session's measurements.
        labels: The training sets' labels.
        kinds: The training sets' data kinds, in the same order.
        sources: The training sets' files, in the same order ("" in memory), or None.

    Raises:
        DataError: a session of a kind no training set has, or of another kind than the named set.
        ArgumentError: ``same`` naming no set, or left out with several sets of its kind.
    """
    source = session.source or "test_data"
    of_kind = [k for k, kind in enumerate(kinds) if kind == session.kind]
    if not of_kind:
        raise DataError(source, f"holds {session.kind} data, no training set does ({', '.join(sorted(set(kinds)))})")
    if test.register is not None:
        return of_kind[0]
    if test.same:
        files = [Path(source).name if source else "" for source in (sources or [""] * len(labels))]
        k = next((k for k, label in enumerate(labels) if test.same in (label, files[k])), None)
        if k is None and len(labels) == 1:
            raise ArgumentError("same", f"'{test.same}' is not the training set (its label: {labels[0]})")
        if k is None:
            raise ArgumentError("same", f"'{test.same}' is not a training set's label (labels: {', '.join(labels)})")
        if kinds[k] != session.kind:
            raise DataError(source, f"holds {session.kind} data, set {labels[k]} {kinds[k]} data")
        return k
    if len(of_kind) > 1:
        raise ArgumentError("same", f"{len(of_kind)} training sets of {session.kind} data "
                            f"({', '.join(labels[k] for k in of_kind)}): name the one whose set-up the session shares "
                            "(same=LABEL), or re-register it (register=K)")
    return of_kind[0]


def registration_rows(session: MeasurementSet, register: int | str,
                      targets: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The session's registration rows and scored rows (0-based, disjoint, every row in one).

    ``register=k``: k poses, taken from each target in turn (``targets``: what each row
    measures, a marker or a fixture, :meth:`~calib_pin.sensors.base.MeasurementModel.row_targets`;
    a pose's target is its first row's), in file order within each; with one target (or
    None), the session's first k poses. So a file recorded fixture by fixture registers
    on every fixture it touches.

    Args:
        session: The validation session's measurements.
        register: k poses, or ``"role"`` (its rows of role ``register``).
        targets: What each row measures, or None.

    Raises:
        DataError: no ``role`` column or no row marked ``register``; k poses that leave
            nothing to score.
    """
    source = session.source or "test_data"
    if register == "role":
        column = session.extra.get("role")
        if column is None:
            raise DataError(source, f"register=role needs a 'role' column marking the registration rows "
                            f"'{REGISTER_ROLE}'", None, "role")
        marked = np.array([str(v).strip().lower() == REGISTER_ROLE for v in np.asarray(column, dtype=object)])
        if not marked.any():
            raise DataError(source, f"no row has role '{REGISTER_ROLE}': nothing to re-register the session on",
                            None, "role")
    else:
        groups = np.asarray(session.groups)
        _, first = np.unique(groups, return_index=True)
        first = np.sort(first)
        in_order = groups[first if targets is None else first[_in_turn(np.asarray(targets)[first])]]
        if int(register) >= len(in_order):
            raise DataError(source, f"register={register} poses of its {len(in_order)}: nothing left to score "
                            "(register on fewer poses)", None, "register")

        marked = np.isin(groups, in_order[: int(register)])
    if marked.all():
        raise DataError(source, "every row registers the session: nothing left to score", None, "role")
    return np.flatnonzero(marked), np.flatnonzero(~marked)


def _in_turn(targets: np.ndarray) -> np.ndarray:
    """An order of items (poses, in file order) that takes one of each target in turn
    (targets in the order they first appear; within a target, file order): ``A A B B C``
    gives ``A B C A B``; of one target, file order."""
    labels = [str(t) for t in targets]
    done: dict[str, int] = {}  # items of each target so far
    first: dict[str, int] = {}  # each target's place in the order of first appearance
    turn = np.empty(len(labels), dtype=int)
    appearance = np.empty(len(labels), dtype=int)
    for k, label in enumerate(labels):
        turn[k] = done.get(label, 0)
        done[label] = turn[k] + 1
        appearance[k] = first.setdefault(label, len(first))
    return np.lexsort((np.arange(len(labels)), appearance, turn))


def _fit_sensor(problem: SetProblem, fixed: np.ndarray) -> np.ndarray:
    """x with the problem's robot part held at ``fixed`` and its sensor unknowns fitted.

    The robot part is the deviations and compliances; the sensor unknowns are fitted by
    scipy's least squares (Levenberg-Marquardt) from zero.
    """
    from scipy.optimize import least_squares  # imported when a session is re-registered

    def full(e: np.ndarray) -> np.ndarray:
        return np.concatenate([fixed, e])

    start = len(fixed)
    fit = least_squares(lambda e: problem.residual(full(e)), np.zeros(problem.model.n_params - start),
                        jac=lambda e: problem.jacobian(full(e))[:, start:], method="lm")
    return full(fit.x)


def register_session(test: TestSet, calibrated: Any, x: np.ndarray, options: dict[str, Any]
                     ) -> tuple[dict[str, Metrics], dict[str, Any]]:
    """Re-register a validation session on a new set-up and score its other rows.

    The session's problem (its sensor's :meth:`~calib_pin.sensors.base.MeasurementModel.registration_problem`)
    starts from its set-up fitted on the registration rows with the nominal robot; its
    sensor unknowns are then fitted on those rows with the calibrated robot fixed ("after"),
    and with the nominal robot ("before").

    Args:
        test: The session (its data loaded) and its registration rows.
        calibrated, x: The measurement model of the training set of the session's kind,
            and its unknowns as calibrated (SI).
        options: That set's sensor options (the compliance).

    Returns:
        The ``test`` metrics (before, after) of the scored rows, and what report.json
        shows (``test_registration``: rows, file lines, unknowns fitted, the session's geometry).

    Raises:
        DataError: too few registration values for the session's sensor unknowns, or a
            sensor with none (nothing to re-register).
    """
    session = test.data
    assert isinstance(session, MeasurementSet) and test.register is not None
    source = session.source or "test_data"
    sensor = sensor_for(session.kind)
    targets = sensor.row_targets(session)
    register, scored = registration_rows(session, test.register, targets)
    try:
        problem = sensor.registration_problem(calibrated.chain, calibrated.params, session, register, calibrated, x,
                                              {**options, FIT_ROWS_KEY: "registration rows"})
    except DataError as e:  # too few rows, or a fixture or point none of them locates: say how to choose them
        if test.register == "role":
            raise
        raise DataError(e.path, f"{e.reason} (register={test.register} took {_how(session, register, test.register)}: "
                        "register on more poses, or mark the rows with a role column and register=role)", e.line,
                        e.field) from e
    model = problem.model
    start = model.sensor_start
    n_sensor = model.n_params - start
    if n_sensor == 0:
        raise DataError(source, f"{model.data_name} have no set-up unknowns to re-register: leave register out",
                        None, "register")
    fitted = problem.subset(register)
    if fitted.n_values < n_sensor:
        raise DataError(source, f"{len(register)} registration rows give {fitted.n_values} values, fewer than the "
                        f"{n_sensor} set-up unknowns ({model.describe()}): register on more poses", None, "register")
    before = _fit_sensor(fitted, np.zeros(start))
    after = _fit_sensor(fitted, np.asarray(x, dtype=float)[:start])
    part = problem.subset(scored)
    metrics = {"before": Metrics.of(data_row_errors(part, part.residual(before))),
               "after": Metrics.of(data_row_errors(part, part.residual(after)))}
    lines = None if session.lines is None else np.asarray(session.lines)
    how = f"rows with role={REGISTER_ROLE}" if test.register == "role" else _how(session, register, test.register)
    info = {
        "data": session.source, "setup": "new", "registered_on": how,
        "registered_rows": register.tolist(), "scored_rows": scored.tolist(),
        "registered_lines": None if lines is None else lines[register].tolist(),
        "scored_lines": None if lines is None else lines[scored].tolist(),
        "fitted": list(model.names[start:]), "robot": "calibrated, held fixed",
        "registration_rmse_mm": float(np.sqrt(np.mean(fitted.row_errors(fitted.residual(after)) ** 2)) * 1e3),
        "sensor": model.describe(), "geometry": model.geometry_report(after),
    }
    return metrics, info


def _how(session: MeasurementSet, rows: np.ndarray, register: int | str) -> str:
    """``first 12 poses``, or ``12 poses, one of each fixture or point in turn`` when they are not the first."""
    k = int(register)
    groups = np.asarray(session.groups)
    _, first = np.unique(groups, return_index=True)
    if set(np.unique(groups[rows]).tolist()) == set(groups[np.sort(first)[:k]].tolist()):
        return f"first {k} poses"
    return f"{k} poses, one of each fixture or point in turn (file order within each)"


#: A validation session whose own device frame puts its points farther than this from
#: where the calibration's frame puts them (or whose touches put its fixtures that far
#: from the calibration's) was measured from another placement, [m] (a refit on the same
#: placement moves them by the calibration's residual, < 1 mm).
DEVICE_SHIFT_M = 5e-3


def score_session(model: Any, x: np.ndarray, correction: Any, session: MeasurementSet) -> dict[str, Metrics]:
    """The ``test`` metrics (before, after) of a validation session on a training set's set-up.

    Nothing is fitted on the session: a point the calibration never saw (a new marker) is
    located from its first row with the model being scored, and the session's other rows
    are predicted (see :meth:`calib_pin.sensors.base.MeasurementModel.session_errors`).

    Args:
        model: The measurement model of the training set whose set-up the session shares.
        x: Its unknowns as calibrated, SI.
        correction: A learnt correction of the values, or None.
        session: The validation session's measurements.

    Raises:
        DataError: the session's own device frame (or fixtures) is far from the calibration's
            (moved): :data:`DEVICE_SHIFT_M`.
    """
    shift = getattr(model, "session_frame_shift", lambda x, data: None)(x, session)
    if shift is not None and shift > DEVICE_SHIFT_M:  # scored with the calibration's set-up, every row would be off
        what, hint = model.moved_setup  # a device frame, or fixtures
        verb, over, poses = ("are", "fixtures", "K poses, one of each fixture in turn") if what.endswith("s") else \
            ("is", "points", "its first K poses")
        raise DataError(session.source or "test_data", f"the session's own {verb} {shift * 1e3:.3g} mm (RMS over its "
                        f"{over}) from the calibration's: {hint} Measure both from the same placement, or re-register "
                        f"the session on its own poses (register=K: {poses})", None, what)
    before = model.session_errors(None, session)
    after = model.session_errors(x, session, correction)
    return {"before": Metrics.of(before), "after": Metrics.of(after)}


def session_notes(test: TestSet) -> tuple[str, ...]:
    """The session's extra columns, read past (its ``role`` column is used by ``register=role``)."""
    session = test.data
    assert isinstance(session, MeasurementSet)
    extra = [c for c in session.extra if not (c == "role" and test.register == "role")]
    if not extra:
        return session.dropped
    return session.dropped + (f"ignored columns: {', '.join(extra)} (in {Path(session.source).name or 'test_data'}; "
                              "read and kept, not used)",)
