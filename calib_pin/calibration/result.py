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
from ..export.urdf import write_calibrated_urdf
from ..measurements import MeasurementSet
from ..parameters import ParameterModel
from ..parameters.sanity import beyond_sanity
from ..robot import Chain
from ..robot.chain import as_angles_rad
from ..util.units import for_humans
from .problem import Problem

if TYPE_CHECKING:
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
                        "--analyze; a wrong anchor_mm/tool_mm or unit; or outliers, see --loss); no URDF written")
        return None

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
        return write_calibrated_urdf(self.chain, self.deltas, path)

    @cached_property
    def uncertainty(self) -> Uncertainty | None:
        """Standard errors and end-frame position uncertainty; None for rbf.

        See :mod:`calib_pin.analysis.uncertainty`.
        """
        if not self.kinematic:
            return None
        from ..analysis.uncertainty import estimate_uncertainty

        return estimate_uncertainty(self.problem.subset(self.train), self.x, seed=self.seed)

    @cached_property
    def identifiability(self) -> Identifiability:
        """What the training poses can identify (:func:`calib_pin.analysis.identifiability.analyze` at zero)."""
        from ..analysis.identifiability import analyze

        return analyze(self.problem.subset(self.train), fixed=self.fixed)

    @property
    def fixed(self) -> tuple[str, ...]:
        """Unknowns held at their start (``calibrate --fix``/``--free``), by name; empty if none."""
        return tuple(self.problem.model.names[i] for i in self.estimate.extras.get("fixed", ()))


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
            "noise_mm": self.sigma * 1e3, "noise_from": self.sigma_origin,
            "train_rows": len(self.train), "test_rows": len(self.test),
            **{split: {stage: m.as_dict() for stage, m in stages.items()} for split, stages in self.metrics.items()},
            "error": self.model.error_name, "error_unit": self.unit, "sensor": self.model.describe(), **self.geometry,
            "setup_from_caller": list(self.overrides), "setup_over_file": list(self.overridden),
        }
