"""Where a calibration starts (``calibrate --nominal FILE``): a robot's own calibrated kinematics.

By default the deviations start at zero: the catalogue geometry of the URDF. A start file
gives the robot's own kinematics instead, and the estimate starts there: what the poses
identify moves, the blind directions keep the start's value (not zero), and ``--fix``
holds a parameter at the start's value. The deviations written stay those from the
catalogue URDF (a calibration file, compensate and the URDF export need nothing new);
the report adds the start and the deviations relative to it.

Two files are read:

- a calib-pin calibration file (``<robot>_calibration.json``,
  :func:`calib_pin.export.calibration_file.load_calibration`): its deviations, in the same
  parameter model, and its compliances when the same joints are compliant;
- ur_description's ``default_kinematics.yaml`` layout
  (:func:`calib_pin.export.yaml.read_ur_kinematics_yaml`; the file ``--export yaml``
  writes, and that ``ur_calibration`` extracts from a controller): its corrections are
  expressed in the parameter model by Gauss-Newton on the corrections' twists
  (:meth:`~calib_pin.parameters.base.ParameterModel.delta_jacobian`), exact for the
  ``placement`` model; what the model cannot hold is reported (``fit_m``).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from ..exceptions import CalibPinError, DataError
from ..parameters.base import ParameterModel
from ..parameters.sanity import SANITY_M, SANITY_RAD
from ..robot.chain import Chain
from ..sensors.misreading import Misreading, Reading, Suspect

#: A start whose corrections the parameter model holds worse than this is refused, [m, rad].
FIT_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Start:
    """A calibration's start.

    Attributes:
        source: The file.
        kind: ``calibration`` (a calib-pin calibration file) or ``ur-kinematics-yaml``.
        robot_x: The robot deviations from the catalogue URDF, shape (len(params.names),), SI.
        compliance: Start compliances [rad/Nm] of the run's compliant joints, or None (zero).
        fit_m: How far the parameter model is from the file's corrections (largest twist
            entry, [m] / [rad]); 0 for a calibration file.
    """

    source: str
    kind: str
    robot_x: np.ndarray
    compliance: np.ndarray | None
    fit_m: float

    def x0(self, problem: Any, training: Any) -> np.ndarray:
        """Where an estimate of ``problem``'s unknowns starts, shape (n_params,), SI.

        The start's robot deviations and compliances, the sensor's geometry fitted to
        ``training`` (rows of ``problem``, or all of it) with the robot held there
        (:meth:`sensor_fit`).
        """
        x = np.zeros(problem.n_params)
        model = problem.model
        x[:model.n_robot] = self.robot_x
        if self.compliance is not None:
            x[model.n_robot:model.sensor_start] = self.compliance
        return self.sensor_fit(training, x)

    def sensor_fit(self, problem: Any, x0: np.ndarray) -> np.ndarray:
        """x0 with its sensor unknowns fitted to ``problem``'s rows, the robot held at the start.

        The sensor unknowns are the device frame, markers, anchor; the fit is scipy least
        squares on the active set's :class:`~calib_pin.estimators.active_set.Fixed` problem.
        The sensor's starting geometry is fitted with the catalogue robot, and would
        otherwise carry the start's difference from it.
        """
        from scipy.optimize import least_squares

        from ..estimators.active_set import Fixed

        sensor = np.arange(problem.model.sensor_start, problem.n_params)
        if not len(sensor):
            return x0
        part = Fixed(problem, sensor, x0)
        fit = least_squares(part.residual, x0[sensor], jac=part.jacobian, method="lm", x_scale=part.scale)
        return part.expand(fit.x)

    def describe(self) -> str:
        """One line for people."""
        what = "calib-pin calibration file" if self.kind == "calibration" else "UR default_kinematics.yaml"
        fit = f", held by the model to {self.fit_m:.1g}" if self.kind != "calibration" else ""
        return f"{Path(self.source).name} ({what}{fit})"

    def as_dict(self, params: ParameterModel, x: np.ndarray) -> dict:
        """JSON-ready: the file, its kind and the deviations relative to it (x the run's robot part)."""
        from ..util.units import for_humans

        return {"source": self.source, "kind": self.kind, "fit": self.fit_m,
                "deviations_from_start": for_humans(np.asarray(x) - self.robot_x, params.names, params.units)}


def fit_deltas(params: ParameterModel, deltas: list[pin.SE3], iterations: int = 30) -> tuple[np.ndarray, float]:
    """Deviations x whose ``params.deltas(x)`` are closest to ``deltas``, and the largest misfit.

    Least squares on the twists log6(delta(x)^-1 target); returns (x, largest remaining
    twist entry).
    """
    x = np.zeros(len(params.names))

    def residual(x: np.ndarray) -> np.ndarray:
        return np.concatenate([pin.log6(d.actInv(t)).vector for d, t in zip(params.deltas(x), deltas, strict=True)])

    r = residual(x)
    for _ in range(iterations):
        step = np.linalg.lstsq(params.delta_jacobian(x), r, rcond=None)[0]
        x = x + step
        r = residual(x)
        if np.abs(step).max() < 1e-15:
            break
    return x, float(np.abs(r).max())


def start_file(path: str | Path) -> Path:
    """The file of ``--nominal path``: the file, or the one ``*_calibration.json`` of a
    calibrate output folder (as ``compensate --calibration`` takes it).

    Raises:
        CalibPinError: no such file, or a folder without exactly one calibration file.
    """
    path = Path(path)
    if path.is_dir():
        from ..export.calibration_file import find_calibration

        try:
            return find_calibration(path)
        except CalibPinError as e:
            raise DataError(str(path), f"{str(e).removeprefix(f'{path}: ')} (--nominal: a calibrate output folder, "
                            "a calib-pin calibration .json or a UR default_kinematics.yaml)") from None
    if not path.is_file():
        raise DataError(str(path), "no such start file (--nominal: a calib-pin calibration .json, a calibrate output "
                        "folder, or a UR default_kinematics.yaml)")
    return path


def load_start(path: str | Path, chain: Chain, params: ParameterModel, compliant: tuple[str, ...] = ()) -> Start:
    """The start of ``--nominal path`` (a file, or a calibrate output folder:
    :func:`start_file`) for a calibration of ``chain`` in ``params``.

    Args:
        compliant: The run's compliant joints (their start compliances come from a
            calibration file with the same joints).

    Raises:
        CalibPinError: unreadable or another robot's file, another parameter model, a
            start the model cannot hold.
    """
    path = start_file(path)
    if path.suffix.lower() in (".yaml", ".yml"):
        from ..export.yaml import read_ur_kinematics_yaml

        x, fit = fit_deltas(params, read_ur_kinematics_yaml(chain, path))
        if fit > FIT_TOLERANCE:
            raise CalibPinError(f"{path}: the {params.name} model holds this start only to {fit:.2g} m/rad; "
                                "use --model placement")
        return Start(str(path), "ur-kinematics-yaml", x, None, fit)
    from ..export.calibration_file import load_calibration

    robot = load_calibration(path, chain.name)
    if robot.chain.end_frame != chain.end_frame:
        raise DataError(str(path), f"a calibration of end frame '{robot.chain.end_frame}', this one's is "
                        f"'{chain.end_frame}'", None, "end_frame")
    if robot.params.name != params.name:
        raise DataError(str(path), f"deviations of the {robot.params.name} model; give --model {robot.params.name} "
                        "to start from them", None, "parameter_model")
    spec = robot.compliance_spec
    compliance = None
    if compliant and spec is not None and tuple(spec.joints) == tuple(compliant):
        compliance = np.array(robot.compliance, dtype=float)
    return Start(str(path), "calibration", np.array(robot.deviations, dtype=float), compliance, 0.0)


def _degrees(s: Suspect) -> Iterator[Reading]:
    """A ``default_kinematics.yaml`` start's angles read as degrees, when some is beyond pi."""
    from ..export.yaml import read_ur_entries, read_ur_kinematics_yaml

    if s.start is None or s.start.kind != "ur-kinematics-yaml":
        return
    entries, _ = read_ur_entries(s.start.source)
    largest = max(abs(a) for v in entries.values() for a in v[3:])
    if not largest > np.pi + 1e-9:
        return
    x, fit = fit_deltas(s.params, read_ur_kinematics_yaml(s.chain, s.start.source, np.pi / 180.0))
    if fit <= FIT_TOLERANCE:
        yield Reading("degrees, not radians", "roll, pitch, yaw", None, f"its angles reach {largest:.4g}",
                      "read as degrees", "give roll, pitch and yaw in radians (x pi/180)", robot_x=x)


#: ur_description's arms calib-pin finds by name (example-robot-data), whose
#: ``default_kinematics.yaml`` may be given for another.
UR_MODELS = ("ur5", "ur10", "ur3")


def _largest_offset(entries: dict[str, list[float]], nominal: dict[str, pin.SE3]) -> tuple[float, float]:
    """How far a file's joint origins are from ``nominal``'s: the largest translation [m] and rotation [rad]."""
    moved, turned = 0.0, 0.0
    for key, v in entries.items():
        origin = pin.SE3(pin.rpy.rpyToMatrix(*v[3:]), np.array(v[:3]))
        moved = max(moved, float(np.linalg.norm(origin.translation - nominal[key].translation)))
        turned = max(turned, float(np.linalg.norm(pin.log3(nominal[key].rotation.T @ origin.rotation))))
    return moved, turned


def _another_model(s: Suspect) -> Iterator[Reading]:
    """The catalogue robot, when a ``default_kinematics.yaml`` start holds another UR arm's
    joint origins (within the sanity bounds of its catalogue ones, and not this arm's)."""
    from ..export.yaml import read_ur_entries, ur_kinematics
    from ..robot.chain import load_chain

    if s.start is None or s.start.kind != "ur-kinematics-yaml":
        return
    entries, _ = read_ur_entries(s.start.source)
    identity = [pin.SE3.Identity()] * (s.chain.n_joints + 1)
    own = _largest_offset(entries, ur_kinematics(s.chain, identity)[0])
    if own[0] <= SANITY_M and own[1] <= SANITY_RAD:
        return
    seen = {Path(s.chain.description.urdf).resolve()}
    for name in UR_MODELS:
        try:
            other = load_chain(name, "tool0")
            urdf = Path(other.description.urdf).resolve()
            if name == s.chain.name or urdf in seen:
                continue  # this arm, or one of the same URDF (example-robot-data's ur3 is its ur5)
            seen.add(urdf)
            moved, turned = _largest_offset(entries, ur_kinematics(other, identity)[0])
        except CalibPinError:
            continue
        if moved <= SANITY_M and turned <= SANITY_RAD:
            yield Reading(f"a {name}'s file, not a {s.chain.name}'s", "kinematics", None,
                          f"its joint origins are within {moved * 1e3:.1f} mm and {np.degrees(turned):.2f} deg of "
                          f"a {name}'s, and {own[0] * 1e3:.4g} mm from a {s.chain.name}'s",
                          f"from the catalogue {s.chain.name}", f"give the {s.chain.name}'s own "
                          "default_kinematics.yaml (or leave --nominal out)", robot_x=np.zeros(len(s.params.names)))
            return


#: The usual mistakes of a start file, tried by the pre-fit misfit check
#: (:mod:`calib_pin.calibration.misfit`) when the start misses the rows far more than a robot
#: within its tolerances would.
START_MISREADINGS = (Misreading("a default_kinematics.yaml in degrees", _degrees),
                     Misreading("another UR arm's default_kinematics.yaml", _another_model))
