"""A calibrated robot: the estimate, its scores and what can be derived from it."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from ..analysis.metrics import Metrics
from ..estimators.base import EstimateResult
from ..exceptions import ArgumentError, CalibPinError
from ..export.urdf import AddedFrame, frame_links, write_calibrated_urdf
from ..measurements import MeasurementSet
from ..parameters import ParameterModel
from ..parameters.prior import Prior
from ..parameters.sanity import beyond_sanity
from ..robot import Chain
from ..robot.chain import as_angles_rad
from ..util.units import for_humans
from .problem import Problem

if TYPE_CHECKING:
    from ..analysis.accuracy import Accuracy, NamedPoint
    from ..analysis.determined import Determined
    from ..analysis.identifiability import Identifiability
    from ..analysis.uncertainty import Uncertainty



@dataclass(frozen=True)
class CalibrationResult:
    """A calibrated robot.

    Attributes:
        chain: The nominal robot chain.
        params: Parameter model of the robot's deviations (``params.name``).
        method: Estimator name.
        x: Estimated unknowns, shape (n_params,), SI units ([m], [rad]): the robot's
            deviations, then any sensor unknowns (``problem.model.names``).
        estimate: The estimator's own result (history, iterations, time).
        problem: All rows of every set with their measurement models, each set's starting
            sensor geometry fitted on its training rows only (:class:`~calib_pin.calibration.problem.Problem`).
        data: The measurement set; with several sets, every set's rows in turn (pose
            labels ``<label>:<pose>``).
        train, test: Data-row indices (0-based) of the two splits.
        metrics: ``metrics[split][stage]`` for split in (train, test) and stage in
            (before, after): per-row errors in [mm] (``problem.model.error_name``), every
            set's rows together (none when the sets' errors are in different units).
            ``test`` is absent when no rows were held out.
        seed: Seed of the split and the estimator.
        noise: Sensor noise (1 sigma) the Kalman filters assumed, [m].
        loss: ``linear`` or the robust loss used.
        warnings: What a person must know about this result (one line each).
        test_source: The separate validation session scored as ``test``, if any.
        test_registration: A validation session on a new set-up: which of its rows
            re-registered it and which were scored (:func:`calib_pin.calibration.validation.register_session`);
            None when it shares the training set-up, or without one.
        sets: Each set's :class:`SetResult` (its sigma and where it came from, its rows, its
            metrics before/after per split in its own unit, its sensor geometry and model):
            one for one set.
        noise_from: Where ``noise`` came from: ``stated`` (the caller's or the file's),
            ``default`` (none stated, a method that does not weigh rows by it), or
            ``estimated: ...`` (none stated: from the residual, :mod:`calib_pin.calibration.noise`).
        cross_validation: K-fold held-out metrics of this model on the training poses
            (:meth:`calib_pin.calibration.solve.CrossValidation.as_dict`), when asked.
        start: The start of ``--nominal`` (None: the catalogue geometry); ``x`` stays the
            deviations from the catalogue URDF.
    """

    chain: Chain
    params: ParameterModel
    method: str
    x: np.ndarray
    estimate: EstimateResult
    problem: Problem
    data: MeasurementSet
    train: np.ndarray
    test: np.ndarray
    metrics: dict[str, dict[str, Metrics]]
    seed: int
    noise: float
    loss: str = "linear"
    warnings: tuple[str, ...] = ()
    test_source: str = ""
    sets: tuple[Any, ...] = ()
    test_registration: dict[str, Any] | None = None
    cross_validation: dict[str, Any] | None = None
    noise_from: str = "stated"
    #: Where the estimate started (``calibrate --nominal``, a
    #: :class:`~calib_pin.calibration.start.Start`); None: the catalogue URDF (zero).
    start: Any = None
    #: The unknowns the estimate started from, shape (n_params,), SI (zero deviations, or
    #: the start's with each sensor's geometry fitted to it): the "before" of the metrics.
    x0: np.ndarray | None = None
    #: The prior bounding what the data does not determine (:class:`~calib_pin.parameters.prior.Prior`).
    prior: Prior = Prior()
    #: The points of the end frame the user works with, each (3,) [m]; empty: the defaults
    #: (:attr:`named_points`).
    tcp: tuple[np.ndarray, ...] = ()

    @property
    def model_name(self) -> str:
        """The parameter model's name (``dh``, ``hayati``, ``placement``)."""
        return self.params.name

    @property
    def sensor(self) -> Any:
        """The sensor geometry after calibration (estimated parts updated)."""
        return self.problem.model.geometry_at(self.x)

    @property
    def outlier_rows(self) -> list[int]:
        """Data rows (0-based) the robust estimate judged outliers.

        A contact set's known-distance rows, no data row, are never named.
        """
        from ..estimators.problem import data_rows

        if not self.estimate.outliers:
            return []
        at = {int(r): k for k, r in enumerate(data_rows(self.problem.subset(self.train)))}
        return [int(self.train[at[i]]) for i in self.estimate.outliers if i in at]

    @property
    def deltas(self) -> list[pin.SE3]:
        return self.params.deltas(self.problem.model.robot(self.x))

    @property
    def model(self) -> pin.Model:
        """Pinocchio model of the whole corrected robot (a new model on each call).

        For ``rbf``, which estimates no kinematic parameters, the nominal model.
        """
        return self.chain.perturbed_model(self.deltas)

    @property
    def deviations(self) -> dict[str, float]:
        """Estimated robot deviations by name with unit: ``a_2_mm``, ``theta_6_deg``."""
        return for_humans(self.problem.model.robot(self.x), self.params.names, self.params.units)

    @property
    def sensor_corrections(self) -> dict[str, float]:
        """Estimated corrections of the sensor's geometry by name with unit; empty if none.

        Names carry the unit: ``anchor_x_mm``, ``device_rz_deg``, ``marker1_y_mm``.
        """
        model = self.problem.model
        n = model.sensor_start
        return for_humans(model.sensor_part(self.x), model.names[n:], model.units[n:])

    @property
    def compliances(self) -> dict[str, float]:
        """Estimated joint compliances (``compliance_joint_2_urad_per_Nm``); empty if none."""
        model = self.problem.model
        n, m = model.n_robot, model.sensor_start
        return for_humans(model.compliance(self.x), model.names[n:m], model.units[n:m])

    @property
    def bounded_compliance(self) -> tuple[str, ...]:
        """Joints whose compliance fitted negative and was fixed at zero; empty if none.

        A compliance is >= 0, see :mod:`calib_pin.estimators.active_set`.
        """
        spec = self.problem.model.compliance_spec
        first = self.problem.model.n_robot
        return tuple(spec.joints[i - first] for i in self.estimate.bounded) if spec is not None else ()

    @property
    def kinematic(self) -> bool:
        """True when the method estimated kinematic parameters (all but ``rbf``)."""
        return self.estimate.kinematic

    def predict(self, q: Any, point_ids: Any = None, set: int | str | None = None) -> np.ndarray:
        """What the calibration predicts a set's sensor reads at joint angles q, for any number of poses.

        Args:
            q: Joint angles [rad], shape (n_poses, n_joints), or (n_joints,) for one pose.
            point_ids: Positions only: which marker each pose measures, as the data's
                ``point_id`` labels (numbers or text; ``2`` and ``"2"`` are the same): one
                label for every pose, or one per pose. May be left out when the set has
                one marker (every pose predicts it); with several it is required.
            set: Which set's sensor (its label or index); may be left out with one set.

        Returns:
            Readings, shape (n_poses,), [m]; or positions, shape (n_poses, 3), [m], in the
            device frame.

        Raises:
            ArgumentError: naming the argument: q is not finite numbers of shape (n_poses, n_joints), or is
                outside the joint limits (degrees given as radians); point_ids
                is left out with several markers, or is not one label or one per pose;
                ``set`` left out with several sets, or naming none.
            DataError: a label that is not a marker of this calibration.
        """
        return self.set_result(set).predict(q, point_ids)

    def set_result(self, set: int | str | None = None) -> SetResult:
        """The :class:`SetResult` of a set named by its label or index (None: the only set).

        Args:
            set: The set's label or index (0-based); None with one set.

        Raises:
            ArgumentError: naming ``set``: None with several sets, or a label or index of no set.
        """
        labels = [s.label for s in self.sets]
        if set is None:
            if len(self.sets) == 1:
                return self.sets[0]
            raise ArgumentError("set", f"left out: a calibration of {len(self.sets)} sets predicts per set, name "
                                f"one of {', '.join(labels)}")
        if isinstance(set, str) and set in labels:
            return self.sets[labels.index(set)]
        if isinstance(set, int | np.integer) and not isinstance(set, bool) and 0 <= set < len(self.sets):
            return self.sets[int(set)]
        raise ArgumentError("set", f"{set!r} is no set of this calibration (labels: {', '.join(labels)}, or an index "
                            f"from 0 to {len(self.sets) - 1})")

    def sanity_error(self) -> str | None:
        """Why the estimate may not be exported, or None.

        A negative compliance, or a deviation, robot or sensor, beyond SANITY_M / SANITY_RAD
        of :mod:`calib_pin.parameters.sanity`, naming the first.
        """
        model = self.problem.model
        for i in model.nonnegative:
            if not self.x[i] >= 0:
                return (f"{model.names[i]} = {self.x[i] * 1e6:.3g} urad/Nm is negative (a joint cannot give way "
                        "against its load): the calibration is not written")
        for value, name, unit in zip(self.x, model.names, model.units, strict=True):
            beyond = beyond_sanity(value, unit)  # compliances: see report.json's compliance section
            if beyond:
                return (f"{name} = {beyond}: the data cannot support it (a parameter the poses barely see, see "
                        f"--analyze; {_setup_hint(model)}; or outliers, see --loss){self._misfits()}; "
                        "no URDF written")
        return None

    def _misfits(self) -> str:
        """With several sets, which one the nominal robot misses most (a unit or set-up
        mistake shows there first): each set's training RMSE at the start, largest first."""
        if len(self.sets) < 2:
            return ""
        cells = sorted(((s.metrics["train"]["before"].rmse_mm, s.label, s.unit) for s in self.sets
                        if "train" in s.metrics), key=lambda c: -c[0])
        if not cells:
            return ""
        (worst, label, unit), others = cells[0], cells[1:]
        shown = ", ".join(f"{other} {rmse:.3g} {u}" for rmse, other, u in others)
        return (f"; set {label} misfits most: the start misses its training rows by {worst:.3g} {unit} RMS "
                f"(the other sets: {shown})")

    def check_sanity(self) -> None:
        """Raises CalibPinError when :meth:`sanity_error` finds a runaway deviation."""
        error = self.sanity_error()
        if error:
            raise CalibPinError(error)

    def to_urdf(self, path: str | Path) -> Path:
        """Write the corrected URDF (only joint origins differ from the input).

        Args:
            path: The URDF file to write.

        Raises:
            CalibPinError: the method yields no kinematic parameters (``rbf``), or a
                deviation is beyond the sanity bound.
        """
        if not self.kinematic:
            raise CalibPinError(
                f"method '{self.method}' learns a correction of the measured values, which a URDF cannot hold: "
                "there is no corrected URDF to write")
        self.check_sanity()
        return write_calibrated_urdf(self.chain, self.deltas, path, notes=self.determination_notes(),
                                     frames=self.added_frames())

    def setup_exports(self) -> list[tuple[str, Any]]:
        """What each set's calibrated set-up adds to the outputs, in set order: (tag, its
        :class:`~calib_pin.sensors.base.SetupExports`), the tag "" when one set adds any, else
        ``_<label>`` (its frames' and files' names carry it)."""
        import re

        links = frame_links(self.chain)
        exports = [s.model.setup_exports(s.x, links) for s in self.sets]
        if sum(bool(e.frames or e.files) for e in exports) <= 1:
            return [("", e) for e in exports]
        tags = [f"_{re.sub(r'[^A-Za-z0-9_.-]', '_', s.label)}" for s in self.sets]
        return [(tag, s.model.setup_exports(s.x, links, tag)) for tag, s in zip(tags, self.sets, strict=True)]

    def added_frames(self) -> tuple[AddedFrame, ...]:
        """The frames the sets' calibrated set-ups add to the URDF (a camera and its board)."""
        return tuple(f for _, e in self.setup_exports() for f in e.frames)

    @cached_property
    def uncertainty(self) -> Uncertainty | None:
        """Standard errors and 95 % intervals of what the data determines; None for rbf.

        Also the combinations it determines only together (:mod:`calib_pin.analysis.uncertainty`).
        """
        if not self.kinematic:
            return None
        from ..analysis.uncertainty import estimate_uncertainty

        return estimate_uncertainty(self.problem.subset(self.train), self.x, self.determined,
                                    held=tuple(self.estimate.extras.get("fixed", ())))

    @cached_property
    def determined(self) -> Determined:
        """What the training rows determine of the robot at the estimate, in prior units.

        What the training rows determine of the robot at the estimate, in units of the
        prior (:mod:`calib_pin.analysis.determined`).
        """
        from ..analysis.determined import determined

        held = self.estimate.extras.get("fixed", ())
        free = np.setdiff1d(np.arange(self.problem.n_params), np.asarray(held, dtype=int))
        gauge = self.estimate.extras.get("gauge")
        noise = gauge.noise if gauge is not None and gauge.noise > 0 else self.noise  # as the gauge judged them
        training = self.problem.subset(self.train)
        if self.loss != "linear":  # a robust fit's covariance is that of a larger noise on heavy tails
            from ..estimators.robust import robust_noise

            noise = max(noise, robust_noise(training.residual(self.x), self.loss))
        return determined(training, self.x, free, self.prior, noise)

    @property
    def named_points(self) -> tuple[NamedPoint, ...]:
        """The points the accuracy is given at: (name, point [m], derivative or None) each.

        The points the accuracy is given at: (name, point in the end frame (3,) [m], its
        derivative (3, n_params) when a sensor estimates it, else None) each.

        The caller's ``tcp``, else every set's measured points, the flange origin (the end
        frame's) and the tool a set's file gives.
        """
        if self.tcp:
            return tuple(("tcp", p, None) for p in self.tcp)
        named: list[NamedPoint] = []
        model = self.problem.model
        for k, s in enumerate(self.sets):
            prefix = f"{s.label} " if len(self.sets) > 1 else ""
            columns = model.columns[k] if len(self.sets) > 1 else np.arange(self.problem.n_params)
            derivatives = _point_derivatives(s.model, s.x, columns, self.problem.n_params)
            named += [(prefix + name, p, d) for (name, p), d in zip(s.model.measured_points(s.x), derivatives,
                                                                     strict=True)]
        named.append((f"{self.chain.end_frame} origin", np.zeros(3), None))
        given = self.data.tool
        if given is not None and not any(d is None and np.allclose(given, p, atol=1e-9) for _, p, d in named):
            named.append(("tool", np.asarray(given, dtype=float), None))
        return _distinct(named)

    @cached_property
    def accuracy(self) -> Accuracy | None:
        """Predicted position error at :attr:`named_points` over the workspace (:meth:`predict_accuracy`)."""
        return self.predict_accuracy()

    def predict_accuracy(self, held_out: bool = True) -> Accuracy | None:
        """Predicted position error at :attr:`named_points` over the workspace; None for rbf.

        From the noise, what the model does not explain and what the data does not
        determine (:mod:`calib_pin.analysis.accuracy`).

        Args:
            held_out: Estimate what the model does not explain from the held-out rows when
                there are enough (False: from the training rows only, so that the held-out
                rows can check the prediction).
        """
        if not self.kinematic:
            return None
        from ..analysis.accuracy import predict_accuracy, unexplained
        from ..analysis.repeatability import repeatability
        from ..measurements.schema import SCHEMAS

        split = self.determined
        sensor_free = sum(1 for i in range(self.problem.model.sensor_start, self.problem.n_params)
                          if i not in set(self.estimate.extras.get("fixed", ())))
        rank = split.rank + sensor_free
        train_values = sum(len(_length_residual(s, s.train)) for s in self.sets)
        sets = []
        for s in self.sets:
            if _no_length(s):  # a camera's pixels: no model error of the robot in mm to tell
                continue
            schema = SCHEMAS.get(s.kind)
            lengths = schema is not None and len(schema.value_columns) in (1, 3) and not s.model.noise_parts()
            problem = s.problem  # every row: a sensor's repeatability is no fit's
            rep = repeatability(problem.q, np.asarray(problem.readings) if lengths else None,
                                problem.points, s.sigma if s.sigma_origin in ("file", "caller") else None,
                                s.sigma_origin)
            test = _length_residual(s, s.test) if held_out and not self.test_source else np.zeros(0)
            sets.append(unexplained(s.label, _length_residual(s, s.train), test, rank, train_values, rep))
        return predict_accuracy(self.problem.subset(self.train), self.x, split, self.named_points, sets,
                                self.prior, seed=self.seed)

    def determination_notes(self) -> list[str]:
        """Lines for an exported file's header: what the data determines of the deviations.

        Lines for an exported file's header: which deviations the data determines, which
        only together (with what it gives of them), which it does not (held at the start).
        Empty for a method that learns no kinematics.
        """
        u = self.uncertainty
        if u is None:
            return []
        start = "the start (--nominal)" if self.start is not None else "nominal"
        robot = range(self.problem.model.sensor_start)
        by = {status: [u.names[i] for i in robot if u.status[i] == status]
              for status in ("identified", "combination", "not determined", "held")}
        lines = [f"calib-pin: {len(by['identified'])} of {len(robot)} deviations determined by the data"
                 + (f"; not determined, held at {start}: {', '.join(by['not determined'])}"
                    if by["not determined"] else "")
                 + (f"; held by --fix/--free: {', '.join(by['held'])}" if by["held"] else "")]
        if by["combination"]:
            lines.append(f"calib-pin: determined only together (their split is the one nearest {start}): "
                         + "; ".join(f"{c['combination']} = {c['value']:.4g} +- {c['std']:.2g} {c['unit']}"
                                     for c in u.as_dict()["combinations"]))
        return lines

    @cached_property
    def identifiability(self) -> Identifiability:
        """What the training poses can identify (:func:`calib_pin.analysis.identifiability.analyze` at zero)."""
        from ..analysis.identifiability import analyze

        return analyze(self.problem.subset(self.train), fixed=self.fixed)

    @property
    def fixed(self) -> tuple[str, ...]:
        """Unknowns held at their start (``calibrate --fix``/``--free``), by name; empty if none."""
        return tuple(self.problem.model.names[i] for i in self.estimate.extras.get("fixed", ()))


def _distinct(named: list[NamedPoint]) -> tuple[NamedPoint, ...]:
    """``named`` without a fixed point already named (the first name kept)."""
    out: list[NamedPoint] = []
    for name, p, d in named:
        if d is not None or not any(e is None and np.allclose(p, q, atol=1e-9) for _, q, e in out):
            out.append((name, np.asarray(p, dtype=float), d))
    return tuple(out)


def _point_derivatives(model: Any, x: np.ndarray, columns: np.ndarray, n_params: int) -> list[np.ndarray | None]:
    """Each measured point's derivative with respect to the calibration's unknowns (3, n_params).

    Each of ``model.measured_points(x)``'s derivative with respect to the calibration's
    unknowns (3, n_params), by central differences over the set's sensor unknowns (``columns``:
    the set's unknowns in the calibration's x); None for a point the sensor does not estimate.
    """
    base = model.measured_points(x)
    out = [np.zeros((3, n_params)) for _ in base]
    for j in range(model.sensor_start, model.n_params):
        h = 1e-6 * float(model.scale[j])
        up, down = np.array(x, dtype=float), np.array(x, dtype=float)
        up[j] += h
        down[j] -= h
        for k, ((_, a), (_, b)) in enumerate(zip(model.measured_points(up), model.measured_points(down), strict=True)):
            out[k][:, columns[j]] = (a - b) / (2 * h)
    return [d if np.any(d) else None for d in out]


def _no_length(s: SetResult) -> bool:
    """A set whose errors are no length (a camera's pixels): it says nothing of the model error in mm."""
    own = s.model.noise_parts()
    return bool(own) and own[0].unit != "mm"


def _length_residual(s: SetResult, rows: np.ndarray) -> np.ndarray:
    """A set's residual on ``rows`` in metres, unweighted, flattened.

    A set's residual on ``rows`` in metres, unweighted, flattened: its position part
    for a sensor whose rows have parts (a 6-D pose's).
    """
    if not len(rows):
        return np.zeros(0)
    part = s.problem.subset(rows)
    if _no_length(s):
        return np.zeros(0)
    if s.model.noise_parts():
        return np.asarray(s.model.part_residuals(s.x, part.q, part.readings, part.points)[0])
    return np.asarray(part.residual(s.x))


def _joint_angles(q: Any, n_joints: int) -> np.ndarray:
    """q as finite floats of shape (n_poses, n_joints) [rad] (one pose may be 1-D).

    Raises:
        ArgumentError: naming ``q``: not numbers, not finite, no poses, or another shape.
    """
    try:
        angles = np.array(q, dtype=float)
    except (TypeError, ValueError):
        raise ArgumentError("q", f"not numbers (joint angles [rad], shape (n_poses, {n_joints}))") from None
    if angles.ndim == 1 and angles.shape == (n_joints,):
        angles = angles[None, :]
    if angles.ndim != 2 or angles.shape[1] != n_joints:
        raise ArgumentError("q", f"shape {angles.shape}, expected (n_poses, {n_joints}) joint angles [rad]")
    if not len(angles):
        raise ArgumentError("q", "no poses")
    if not np.all(np.isfinite(angles)):
        raise ArgumentError("q", "not finite (NaN or inf)")
    return angles


@dataclass(frozen=True)
class SetResult:
    """One set of a calibration: its noise, rows, scores and calibrated sensor.

    Attributes:
        label, source, kind, role: The set's label, file ("" in memory), data kind and role.
        sigma: The noise (1 sigma) its rows were weighted by, [m]; ``sigma_origin``:
            ``caller``, ``file``, ``estimate`` (from the residual) or ``default``.
        rows: Its rows in the calibration's data (``result.train``/``result.test`` index those).
        train, test: Its own row indices (0-based, into its data) of the two splits.
        metrics: ``metrics[split][stage]`` as ``CalibrationResult.metrics``, in its own unit.
        geometry: Its sensor geometry after calibration, for report.json (mm, degrees).
        model: Its measurement model; ``x``: its own unknown vector (robot, then its sensor's).
        estimate: The calibration's estimate (a learnt correction of the values, with ``rbf``).
        overrides: The set-up fields the caller gave for this set (its FitSet's ``setup``),
            each winning over its file's; ``overridden``: those of them the file also had.
        unit: The unit of its row errors and metrics (its sensor's ``value_unit``).
        chain: The robot chain (for the joint angles' limits).
        problem: Its problem: every row of the set, its sensor's start as fitted.
    """

    label: str
    source: str
    kind: str
    role: str
    sigma: float
    sigma_origin: str
    rows: np.ndarray
    train: np.ndarray
    test: np.ndarray
    metrics: dict[str, dict[str, Metrics]]
    geometry: dict
    model: Any = field(repr=False)
    x: np.ndarray = field(repr=False)
    estimate: EstimateResult | None = field(default=None, repr=False)
    overrides: tuple[str, ...] = ()
    overridden: tuple[str, ...] = ()
    unit: str = "mm"
    chain: Chain = field(repr=False, kw_only=True)
    problem: Any = field(default=None, repr=False)

    def predict(self, q: Any, point_ids: Any = None) -> np.ndarray:
        """What this set's sensor reads at joint angles q, as :meth:`CalibrationResult.predict`.

        Args:
            q: Joint angles [rad], shape (n_poses, n_joints), or (n_joints,) for one pose.
            point_ids: Positions only: which marker each pose measures (one label, or one
                per pose); None with one marker.

        Returns:
            Readings, shape (n_poses,), [m]; or positions, shape (n_poses, 3), [m], in the
            device frame.

        Raises:
            ArgumentError: as :meth:`CalibrationResult.predict`.
            DataError: a label that is not a marker of this set.
        """
        q = as_angles_rad(_joint_angles(q, self.chain.n_joints), "q", self.chain)  # within limits: not degrees
        labels = None
        if point_ids is not None:
            labels = np.asarray(point_ids, dtype=object).reshape(-1)
            if labels.shape == (1,):
                labels = np.repeat(labels, len(q))
            if labels.shape != (len(q),):
                raise ArgumentError("point_ids", f"{labels.size} labels for {len(q)} poses (give one label, or one per pose)")
        points = self.model.point_index(labels, len(q))
        if labels is not None and points is None:  # a sensor of one point has no labels: they would be ignored
            raise ArgumentError("point_ids", f"this calibration's sensor ({self.model.describe()}) measures one "
                                "point, which has no label: leave point_ids out")
        values = self.model.predict(self.x, q, points)
        correction = None if self.estimate is None else self.estimate.correction
        if correction is not None:
            values = values + correction(q, points).reshape(values.shape)
        return values

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready: the set's table and set-up."""
        return {
            "label": self.label, "data": self.source, "data_kind": self.kind, "role": self.role,
            f"noise_{self.unit}": self.sigma * 1e3, "noise_from": self.sigma_origin,
            "train_rows": len(self.train), "test_rows": len(self.test),
            **{split: {stage: m.as_dict() for stage, m in stages.items()} for split, stages in self.metrics.items()},
            "error": self.model.error_name, "error_unit": self.unit, "sensor": self.model.describe(), **self.geometry,
            "setup_from_caller": list(self.overrides), "setup_over_file": list(self.overridden),
        }


def _setup_hint(model: Any) -> str:
    """What set-up of the sets a sanity-bound refusal may blame: the values their sensors
    take in mm (``a wrong anchor_mm/tool_mm/length_offset_mm or unit``), else a unit."""
    keys = dict.fromkeys(key for part in model.parts for key in type(part).setup_keys())
    return f"a wrong {'/'.join(keys)} or unit" if keys else "a unit or order mistake in the data"
