"""The calibration pipeline: measurement set in, corrected model and report out."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from .errors import CableModel, CalibrationProblem, Drawstring
from .estimators import DEFAULT_METHOD, EstimateResult, get_estimator, get_robust, run_estimator
from .exceptions import CalibPinError, DataError
from .export import write_calibrated_urdf
from .measurements import MeasurementSet, read_measurements
from .metrics import Metrics, split_rows
from .model import Chain, load_chain
from .parameters import ParameterModel, parameter_model
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
        params: Parameter model of the deviations.
        method: Estimator name.
        x: Estimated deviations, shape (n_params,), SI units ([m], [rad]).
        estimate: The estimator's own result (history, iterations, time).
        sensor: Drawstring geometry used.
        data: The measurement set.
        train, test: Data-row indices (0-based) of the two splits.
        metrics: ``metrics[split][stage]`` for split in (train, test) and stage in
            (before, after): reading residuals in [mm]. ``test`` is absent when no rows
            were held out.
        seed: Seed of the split and the estimator.
        noise: Sensor noise (1 sigma) the EKF assumed, [m].
        loss: ``linear`` or the robust loss used.
    """

    chain: Chain
    params: ParameterModel
    method: str
    x: np.ndarray
    estimate: EstimateResult
    sensor: Drawstring
    data: MeasurementSet
    train: np.ndarray
    test: np.ndarray
    metrics: dict[str, dict[str, Metrics]]
    seed: int
    noise: float
    loss: str = "linear"

    @property
    def outlier_rows(self) -> list[int]:
        """Data rows (0-based) the robust estimate judged outliers."""
        return [int(self.train[i]) for i in self.estimate.outliers]

    @property
    def deltas(self) -> list[pin.SE3]:
        return self.params.deltas(self.x)

    @property
    def model(self) -> pin.Model:
        """Pinocchio model of the whole corrected robot (a new model on each call).

        For ``rbf``, which estimates no kinematic parameters, the nominal model.
        """
        return self.chain.perturbed_model(self.deltas)

    @property
    def deviations(self) -> dict[str, float]:
        """Estimated deviations by name with unit: ``a_2_mm``, ``theta_6_deg``."""
        return deviations_for_humans(self.x, self.params.names, self.params.units)

    @property
    def kinematic(self) -> bool:
        """True when the method estimated kinematic parameters (all but ``rbf``)."""
        return self.estimate.kinematic

    def predict(self, q: np.ndarray) -> np.ndarray:
        """Readings the calibration predicts, shape (n_poses,), [m], q in [rad]."""
        return self.estimate.predict(CableModel(self.chain, self.params, self.sensor), q)

    def to_urdf(self, path: str | Path) -> Path:
        """Write the corrected URDF (only joint origins differ from the input).

        Raises:
            CalibPinError: the method yields no kinematic parameters (``rbf``).
        """
        if not self.kinematic:
            raise CalibPinError(
                f"method '{self.method}' learns a correction of the readings, not kinematic "
                "parameters: there is no corrected URDF to write"
            )
        self.check_sanity()
        return write_calibrated_urdf(self.chain, self.deltas, path)

    def check_sanity(self) -> None:
        """Refuse deviations beyond SANITY_MM / SANITY_DEG, naming the first one.

        Raises:
            CalibPinError: a deviation ran away.
        """
        for name, value in self.deviations.items():
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

        train = CalibrationProblem(CableModel(self.chain, self.params, self.sensor),
                                   self.data.q[self.train], self.data.lengths[self.train])
        return estimate_uncertainty(train, self.x, seed=self.seed)

    def report(self) -> dict:
        """JSON-ready summary: metrics, deviations, sensor, split, timing."""
        return {
            "robot": self.chain.name,
            "end_frame": self.chain.end_frame,
            "data": self.data.source,
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
            "uncertainty": self.uncertainty.as_dict() if self.kinematic else None,
            "anchor_mm": (self.sensor.anchor * 1e3).tolist(),
            "tool_mm": (self.sensor.hook * 1e3).tolist(),
            "length_offset_mm": self.sensor.offset * 1e3,
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


@dataclass
class CalibrationSetup:
    """A robot, a measurement set and a sensor, ready to be calibrated by any method.

    Attributes:
        chain: The robot chain.
        params: Parameter model of the deviations.
        data: The measurement set.
        sensor: Drawstring geometry.
        noise: Sensor noise (1 sigma) the Kalman filters assume, [m].
        problem: All rows of the data with the cable model.
    """

    chain: Chain
    params: ParameterModel
    data: MeasurementSet
    sensor: Drawstring
    noise: float
    problem: CalibrationProblem

    def split(self, test_fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
        """Seeded train/test rows, checked to leave enough training rows.

        Raises:
            CalibPinError: bad fraction, or fewer training rows than parameters.
        """
        if not 0.0 <= test_fraction < 1.0:
            raise CalibPinError(f"test fraction must be in [0, 1), got {test_fraction:g}")
        train, test = split_rows(len(self.data), test_fraction, seed)
        n_params = len(self.params.names)
        if len(train) < n_params:
            raise DataError(
                self.data.source,
                f"{len(self.data)} rows leave {len(train)} for training, fewer than the "
                f"{n_params} parameters to estimate",
            )
        return train, test

    def run(
        self, method: str = DEFAULT_METHOD, *, seed: int = 0, test_fraction: float = 0.2, loss: str = "linear"
    ) -> CalibrationResult:
        """Estimate with ``method`` (and ``loss``) on the training rows and score both splits."""
        get_robust(method, loss)
        train, test = self.split(test_fraction, seed)
        x0 = np.zeros(len(self.params.names))
        estimate = run_estimator(method, self.problem.subset(train), x0, seed=seed, noise=self.noise, loss=loss)
        metrics = {}
        for split, rows in (("train", train), ("test", test)):
            if len(rows):
                part = self.problem.subset(rows)
                metrics[split] = {
                    "before": Metrics.of(part.residual(x0)),
                    "after": Metrics.of(estimate.residual(part)),
                }
        return CalibrationResult(
            chain=self.chain, params=self.params, method=method, x=estimate.x,
            estimate=estimate, sensor=self.sensor, data=self.data, train=train, test=test,
            metrics=metrics, seed=seed, noise=self.noise, loss=loss,
        )


def prepare(
    robot: str,
    data: str | Path | MeasurementSet | None = None,
    *,
    end_frame: str | None = None,
    anchor_mm=None,
    tool_mm=None,
    length_offset_mm: float | None = None,
    noise_mm: float | None = None,
) -> CalibrationSetup:
    """Load a robot and a measurement set for calibration (arguments as :func:`calibrate`).

    Raises:
        CalibPinError: any bad input (robot, file, option), with a one-line message.
    """
    chain = load_chain(robot, end_frame)
    params = parameter_model(chain)  # a robot that cannot be calibrated says so first
    if data is None:
        data = chain.description.default_data
        if data is None or not Path(data).is_file():
            raise CalibPinError(f"robot '{chain.name}' has no default measurement set: pass --data")
    if not isinstance(data, MeasurementSet):
        data = read_measurements(data, chain)
        if end_frame is None and data.end_frame and data.end_frame != chain.end_frame:
            chain = load_chain(chain.description, data.end_frame)
            params = parameter_model(chain)
            data = read_measurements(data.source, chain)
    sensor = _sensor(data, anchor_mm, tool_mm, length_offset_mm)
    noise = (noise_mm * 1e-3 if noise_mm is not None else data.noise) or DEFAULT_NOISE_MM * 1e-3
    problem = CalibrationProblem(CableModel(chain, params, sensor), data.q, data.lengths)
    return CalibrationSetup(chain, params, data, sensor, noise, problem)


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
) -> CalibrationResult:
    """Calibrate a robot's DH deviations from drawstring readings.

    Args:
        robot: Robot name or URDF path (``irb120``).
        data: Measurement CSV or set; None uses the robot's shipped default set.
        method: Estimator name (see ``calib_pin.ESTIMATORS``; default ``ekf-qibas``).
        seed: Seed of the train/test split and of the estimator.
        test_fraction: Share of rows held out for the test metrics.
        end_frame: End frame; default the file's ``end_frame`` or the robot's.
        anchor_mm, tool_mm: Override the file's sensor point (base frame) and hook
            point (end frame), 3 numbers each, [mm].
        length_offset_mm: Override the file's sensor zero offset, [mm].
        noise_mm: Sensor noise (1 sigma) [mm] for the Kalman filters; default the
            file's ``noise_mm`` or 0.05.
        loss: ``linear``, or a robust loss (``huber``, ``soft_l1``, ``cauchy``) for the
            methods that have one (``lm``).

    Raises:
        CalibPinError: any bad input (robot, file, option), with a one-line message.
    """
    get_robust(method, loss)
    if not 0.0 <= test_fraction < 1.0:
        raise CalibPinError(f"test fraction must be in [0, 1), got {test_fraction:g}")
    setup = prepare(
        robot, data, end_frame=end_frame, anchor_mm=anchor_mm, tool_mm=tool_mm,
        length_offset_mm=length_offset_mm, noise_mm=noise_mm,
    )
    return setup.run(method, seed=seed, test_fraction=test_fraction, loss=loss)
