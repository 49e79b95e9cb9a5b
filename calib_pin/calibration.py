"""The calibration pipeline: measurement set in, corrected model and report out."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from .errors import CABLE_EXTRAS, CableModel, CalibrationProblem, Drawstring
from .estimators import DEFAULT_METHOD, EstimateResult, get_estimator, get_robust, run_estimator
from .exceptions import CalibPinError, DataError
from .export import write_calibrated_urdf
from .measurements import MeasurementSet, read_measurements
from .metrics import Metrics, split_rows
from .model import Chain, load_chain
from .robots import RobotDescription, resolve_robot
from .parameters import ParameterModel, parameter_model
from .position import PositionDevice, PositionModel, fit_device
from .simulate import deviations_for_humans

#: Sensor noise assumed when neither the data (``# noise_mm``) nor the caller give it.
DEFAULT_NOISE_MM = 0.05

#: No exported deviation may exceed these (a real arm's errors are a few mm and tenths
#: of a degree); a larger one means the data could not determine it.
SANITY_MM = 20.0
SANITY_DEG = 5.0


@dataclass
class CalibrationResult:
    """A calibrated robot.

    Attributes:
        chain: The nominal robot chain.
        params: Parameter model of the robot's deviations.
        method: Estimator name.
        x: Estimated unknowns, shape (n_params,), SI units ([m], [rad]): the robot's
            deviations, then any sensor unknowns (``problem.model.names``).
        estimate: The estimator's own result (history, iterations, time).
        problem: All rows of the data with the measurement model.
        data: The measurement set.
        train, test: Data-row indices (0-based) of the two splits.
        metrics: ``metrics[split][stage]`` for split in (train, test) and stage in
            (before, after): per-row errors in [mm] (|reading error| for a cable,
            Euclidean position error for positions). ``test`` is absent when no rows
            were held out.
        seed: Seed of the split and the estimator.
        noise: Sensor noise (1 sigma) the Kalman filters assumed, [m].
        loss: ``linear`` or the robust loss used.
        model_name: ``dh``, ``hayati`` or ``placement``.
    """

    chain: Chain
    params: ParameterModel
    method: str
    x: np.ndarray
    estimate: EstimateResult
    problem: CalibrationProblem
    data: MeasurementSet
    train: np.ndarray
    test: np.ndarray
    metrics: dict[str, dict[str, Metrics]]
    seed: int
    noise: float
    loss: str = "linear"
    model_name: str = "dh"

    @property
    def sensor(self) -> Drawstring | PositionDevice:
        """The sensor geometry after calibration (estimated parts updated)."""
        model = self.problem.model
        return model.sensor_at(self.x) if isinstance(model, CableModel) else model.device_at(self.x)

    @property
    def outlier_rows(self) -> list[int]:
        """Data rows (0-based) the robust estimate judged outliers."""
        return [int(self.train[i]) for i in self.estimate.outliers]

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
        return deviations_for_humans(self.problem.model.robot(self.x), self.params.names, self.params.units)

    @property
    def sensor_corrections(self) -> dict[str, float]:
        """Estimated corrections of the sensor's geometry by name with unit
        (``anchor_x_mm``, ``device_rz_deg``, ``marker1_y_mm``); empty if none."""
        model = self.problem.model
        n = model.n_robot
        return deviations_for_humans(self.x[n:], model.names[n:], model.units[n:])

    @property
    def kinematic(self) -> bool:
        """True when the method estimated kinematic parameters (all but ``rbf``)."""
        return self.estimate.kinematic

    def predict(self, q: np.ndarray, markers: np.ndarray | None = None) -> np.ndarray:
        """What the calibration predicts at joint angles q (n_poses, n_joints) [rad]:
        readings (n_poses,) [m], or for position data the positions (n_poses, 3) [m]
        of the markers with the given indices, in the device frame."""
        if isinstance(self.problem.model, PositionModel):
            return self.problem.model.predict(self.x, q, markers)
        return self.estimate.predict(self.problem.model, q)

    def to_urdf(self, path: str | Path) -> Path:
        """Write the corrected URDF (only joint origins differ from the input).

        Raises:
            CalibPinError: the method yields no kinematic parameters (``rbf``), or a
                deviation is beyond the sanity bound.
        """
        if not self.kinematic:
            raise CalibPinError(
                f"method '{self.method}' learns a correction of the readings, not kinematic "
                "parameters: there is no corrected URDF to write"
            )
        self.check_sanity()
        return write_calibrated_urdf(self.chain, self.deltas, path)

    def check_sanity(self) -> None:
        """Refuse deviations (robot or sensor) beyond SANITY_MM / SANITY_DEG, naming the first.

        Raises:
            CalibPinError: a deviation ran away.
        """
        for name, value in {**self.deviations, **self.sensor_corrections}.items():
            bound = SANITY_MM if name.endswith("_mm") else SANITY_DEG
            if abs(value) > bound:
                unit = "mm" if name.endswith("_mm") else "deg"
                raise CalibPinError(
                    f"{name.rsplit('_', 1)[0]} = {value:+.3g} {unit} is beyond the sanity bound "
                    f"{bound:g} {unit}: the data cannot support it (a parameter the poses barely "
                    "see, see --analyze; a wrong anchor_mm/tool_mm or unit; or outliers, see "
                    "--loss); no URDF written"
                )

    @property
    def uncertainty(self):
        """Standard errors and flange uncertainty (:mod:`calib_pin.uncertainty`); None for rbf."""
        if not self.kinematic:
            return None
        from .uncertainty import estimate_uncertainty

        return estimate_uncertainty(self.problem.subset(self.train), self.x, seed=self.seed)

    @property
    def identifiability(self):
        """What the training poses can identify (:func:`calib_pin.identifiability.analyze` at zero)."""
        from .identifiability import analyze

        return analyze(self.problem.subset(self.train))

    def _sensor_report(self) -> dict:
        sensor = self.sensor
        if isinstance(sensor, Drawstring):
            return {
                "anchor_mm": (sensor.anchor * 1e3).tolist(),
                "tool_mm": (sensor.hook * 1e3).tolist(),
                "length_offset_mm": sensor.offset * 1e3,
            }
        return {
            "device_frame": {
                "translation_mm": (sensor.frame.translation * 1e3).tolist(),
                "rpy_deg": np.rad2deg(pin.rpy.matrixToRpy(sensor.frame.rotation)).tolist(),
                "meaning": "p_device = R p_base + t",
            },
            "markers_mm": {str(label): (m * 1e3).tolist() for label, m in zip(sensor.labels, sensor.markers, strict=True)},
        }

    def report(self) -> dict:
        """JSON-ready summary: metrics, deviations, sensor, split, timing."""
        return {
            "robot": self.chain.name,
            "end_frame": self.chain.end_frame,
            "data": self.data.source,
            "data_kind": self.data.kind,
            "model": self.model_name,
            "method": self.method,
            "seed": self.seed,
            **{
                split: {stage: m.as_dict() for stage, m in stages.items()}
                for split, stages in self.metrics.items()
            },
            "time_s": self.estimate.time_s,
            "iterations": self.estimate.iterations,
            "stages": self.estimate.stages,
            "evaluations": self.estimate.nfev,
            "stop_reason": self.estimate.message,
            "train_rmse_history_mm": [h * 1e3 for h in self.estimate.history],
            "kinematic_parameters": self.kinematic,
            "deviations": self.deviations if self.kinematic else {},
            "sensor_corrections": self.sensor_corrections if self.kinematic else {},
            "uncertainty": self.uncertainty.as_dict() if self.kinematic else None,
            "identifiability": self.identifiability.as_dict(),
            **self._sensor_report(),
            "noise_mm": self.noise * 1e3,
            "loss": self.loss,
            "outlier_rows": self.outlier_rows,
            "outlier_lines": [int(self.data.lines[r]) for r in self.outlier_rows] if self.data.lines is not None else [],
            "split": {"train": self.train.tolist(), "test": self.test.tolist()},
        }


def _vector_mm(value, name: str) -> np.ndarray:
    v = np.asarray(value, dtype=float).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise CalibPinError(f"{name} needs 3 finite numbers (x, y, z in mm)")
    return v * 1e-3


def _sensor(data: MeasurementSet, anchor_mm, tool_mm, offset_mm) -> Drawstring:
    anchor = _vector_mm(anchor_mm, "anchor_mm") if anchor_mm is not None else data.anchor
    tool = _vector_mm(tool_mm, "tool_mm") if tool_mm is not None else data.tool
    if anchor is None:
        raise DataError(data.source, "no sensor point: add '# anchor_mm: x, y, z' or pass --anchor-mm", None, "anchor_mm")
    if tool is None:
        raise DataError(data.source, "no hook point: add '# tool_mm: x, y, z' or pass --tool-mm", None, "tool_mm")
    offset = data.length_offset if offset_mm is None else float(offset_mm) * 1e-3
    return Drawstring(anchor=anchor, hook=tool, offset=offset)


def check_estimate(estimate) -> tuple[str, ...]:
    """The drawstring unknowns named in ``estimate`` (names, blanks dropped).

    Raises:
        CalibPinError: a name that is not one of CABLE_EXTRAS.
    """
    estimate = tuple(e.strip() for e in (estimate or ()) if e.strip())
    for e in estimate:
        if e not in CABLE_EXTRAS:
            raise CalibPinError(f"cannot estimate '{e}' (valid: {', '.join(CABLE_EXTRAS)})")
    return estimate


@dataclass
class CalibrationSetup:
    """A robot, a measurement set and a sensor, ready to be calibrated by any method.

    Attributes:
        chain: The robot chain.
        params: Parameter model of the robot's deviations.
        data: The measurement set.
        noise: Sensor noise (1 sigma) the Kalman filters assume, [m].
        problem: All rows of the data with the measurement model (cable or position).
        model_name: ``dh``, ``hayati`` or ``placement``.
    """

    chain: Chain
    params: ParameterModel
    data: MeasurementSet
    noise: float
    problem: CalibrationProblem
    model_name: str = "dh"

    @property
    def sensor(self) -> Drawstring | PositionDevice:
        """The sensor geometry the data starts from (for positions: the best fit with the nominal robot)."""
        model = self.problem.model
        return model.sensor if isinstance(model, CableModel) else model.device

    def split(self, test_fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
        """Seeded train/test rows, checked to leave enough training values.

        Rows of a position set are split by pose: all markers of a pose go to the
        same side, so the test poses are unseen configurations.

        Raises:
            CalibPinError: bad fraction, or fewer training values than unknowns.
        """
        if not 0.0 <= test_fraction < 1.0:
            raise CalibPinError(f"test fraction must be in [0, 1), got {test_fraction:g}")
        if self.data.kind == "position" and self.data.pose_ids is not None:
            poses = np.unique(self.data.pose_ids)
            train_poses, _ = split_rows(len(poses), test_fraction, seed)
            in_train = np.isin(self.data.pose_ids, poses[train_poses])
            train, test = np.flatnonzero(in_train), np.flatnonzero(~in_train)
        else:
            train, test = split_rows(len(self.data), test_fraction, seed)
        n_params = self.problem.n_params
        values = len(train) * self.problem.model.values_per_row
        if values < n_params:
            raise DataError(
                self.data.source,
                f"{len(self.data)} rows leave {values} values for training, fewer than the "
                f"{n_params} unknowns to estimate",
            )
        return train, test

    def run(
        self, method: str = DEFAULT_METHOD, *, seed: int = 0, test_fraction: float = 0.2, loss: str = "linear"
    ) -> CalibrationResult:
        """Estimate with ``method`` (and ``loss``) on the training rows and score both splits."""
        get_robust(method, loss)
        if method == "rbf" and self.data.kind == "position":
            raise CalibPinError("method 'rbf' learns a correction of cable readings; position data needs a parameter method")
        train, test = self.split(test_fraction, seed)
        x0 = np.zeros(self.problem.n_params)
        estimate = run_estimator(method, self.problem.subset(train), x0, seed=seed, noise=self.noise, loss=loss)
        metrics = {}
        for split, rows in (("train", train), ("test", test)):
            if len(rows):
                part = self.problem.subset(rows)
                metrics[split] = {
                    "before": Metrics.of(part.row_errors(part.residual(x0))),
                    "after": Metrics.of(part.row_errors(estimate.residual(part))),
                }
        return CalibrationResult(
            chain=self.chain, params=self.params, method=method, x=estimate.x,
            estimate=estimate, problem=self.problem, data=self.data, train=train, test=test,
            metrics=metrics, seed=seed, noise=self.noise, loss=loss, model_name=self.model_name,
        )


def _measurement_problem(chain, params, data: MeasurementSet, anchor_mm, tool_mm, offset_mm, estimate) -> CalibrationProblem:
    if data.kind == "cable":
        sensor = _sensor(data, anchor_mm, tool_mm, offset_mm)
        return CalibrationProblem(CableModel(chain, params, sensor, estimate), data.q, data.lengths)
    for value, name in ((anchor_mm, "--anchor-mm"), (tool_mm, "--tool-mm"), (offset_mm, "--length-offset-mm")):
        if value is not None:
            raise CalibPinError(f"{name} is for drawstring data; {data.source} holds positions")
    if estimate:
        raise CalibPinError(
            f"--estimate {','.join(estimate)} is for drawstring data; with positions ({data.source}) "
            "the device frame and the marker points are always estimated"
        )
    labels = tuple(int(v) for v in np.unique(data.point_ids))
    markers = np.searchsorted(labels, data.point_ids)
    device = fit_device(chain, params, data.q, data.positions, markers, labels)
    return CalibrationProblem(PositionModel(chain, params, device), data.q, data.positions, markers)


def prepare(
    robot: str,
    data: str | Path | MeasurementSet | None = None,
    *,
    end_frame: str | None = None,
    anchor_mm=None,
    tool_mm=None,
    length_offset_mm: float | None = None,
    noise_mm: float | None = None,
    model: str | None = None,
    estimate: tuple[str, ...] = (),
) -> CalibrationSetup:
    """Load a robot and a measurement set for calibration (arguments as :func:`calibrate`).

    Raises:
        CalibPinError: any bad input (robot, file, option), with a one-line message.
    """
    estimate = check_estimate(estimate)
    description = robot if isinstance(robot, RobotDescription) else resolve_robot(robot)
    if end_frame is None and description.end_frame is None and data is not None:
        # No tool0 in the URDF: the data file may name the end frame.
        end_frame = (data if isinstance(data, MeasurementSet) else read_measurements(data)).end_frame
    chain = load_chain(description, end_frame)

    def params_for(chain: Chain) -> tuple[ParameterModel, str]:
        name = model or ("dh" if chain.description.dh is not None else "placement")
        return parameter_model(chain, name), name  # a robot that cannot be calibrated says so first

    params, model_name = params_for(chain)
    if data is None:
        data = chain.description.default_data
        if data is None or not Path(data).is_file():
            raise CalibPinError(f"robot '{chain.name}' has no default measurement set: pass --data")
    if not isinstance(data, MeasurementSet):
        data = read_measurements(data, chain)
        if end_frame is None and data.end_frame and data.end_frame != chain.end_frame:
            chain = load_chain(chain.description, data.end_frame)
            params, model_name = params_for(chain)
            data = read_measurements(data.source, chain)
    problem = _measurement_problem(chain, params, data, anchor_mm, tool_mm, length_offset_mm, estimate)
    noise = (noise_mm * 1e-3 if noise_mm is not None else data.noise) or DEFAULT_NOISE_MM * 1e-3
    return CalibrationSetup(chain, params, data, noise, problem, model_name)


def calibrate(
    robot: str,
    data: str | Path | MeasurementSet | None = None,
    *,
    method: str = DEFAULT_METHOD,
    seed: int = 0,
    test_fraction: float = 0.2,
    end_frame: str | None = None,
    anchor_mm=None,
    tool_mm=None,
    length_offset_mm: float | None = None,
    noise_mm: float | None = None,
    loss: str = "linear",
    model: str | None = None,
    estimate: tuple[str, ...] = (),
) -> CalibrationResult:
    """Calibrate a robot's kinematic deviations from drawstring readings or positions.

    Args:
        robot: Robot name or URDF path (``irb120``).
        data: Measurement CSV or set (cable readings or marker positions); None uses
            the robot's shipped default set.
        method: Estimator name (see ``calib_pin.ESTIMATORS``; default ``ekf-qibas``).
        seed: Seed of the train/test split and of the estimator.
        test_fraction: Share of rows (of poses, for positions) held out for the test metrics.
        end_frame: End frame; default the file's ``end_frame`` or the robot's.
        anchor_mm, tool_mm: Override the file's sensor point (base frame) and hook
            point (end frame), 3 numbers each, [mm].
        length_offset_mm: Override the file's sensor zero offset, [mm].
        noise_mm: Sensor noise (1 sigma) [mm] for the Kalman filters; default the
            file's ``noise_mm`` or 0.05.
        loss: ``linear``, or a robust loss (``huber``, ``soft_l1``, ``cauchy``).
        model: Parameter model: ``dh`` (default with a DH table), ``hayati`` or
            ``placement`` (default without one; any URDF).
        estimate: Drawstring geometry to estimate with the robot: ``anchor``,
            ``offset`` (positions always estimate the device frame and markers).

    Raises:
        CalibPinError: any bad input (robot, file, option), with a one-line message.
    """
    get_robust(method, loss)
    if not 0.0 <= test_fraction < 1.0:
        raise CalibPinError(f"test fraction must be in [0, 1), got {test_fraction:g}")
    setup = prepare(
        robot, data, end_frame=end_frame, anchor_mm=anchor_mm, tool_mm=tool_mm,
        length_offset_mm=length_offset_mm, noise_mm=noise_mm, model=model, estimate=estimate,
    )
    return setup.run(method, seed=seed, test_fraction=test_fraction, loss=loss)
