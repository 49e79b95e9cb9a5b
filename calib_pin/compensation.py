"""The calibrated robot in use: its real end frame, and compensated joint commands.

A robot program is a list of joint targets computed with the nominal model. The real
arm differs from that model by its geometric deviations and, with joint compliance, by
the deflection of its joints under load (:mod:`calib_pin.robot.deflection`). A
:class:`CalibratedRobot` predicts the real arm's end frame (:meth:`CalibratedRobot.forward`)
through the same forward-kinematics path as the measurement models
(:class:`~calib_pin.robot.kinematics.Kinematics` under the parameter model's
perturbation, at the deflected joint angles q - c tau(q)), and
:meth:`CalibratedRobot.compensate` finds the joint command that puts the real end frame
where the nominal model puts it.

Compensation solves T_real(q_c) = T_nominal(q_nominal) (position and orientation) by
damped Gauss-Newton on the error e = log6(T_real(q_c)^-1 T_nominal(q_nominal)) (the end
frame's local twist), with Pinocchio's frame Jacobian (``pin.LOCAL``) of the calibrated
geometry at the deflected angles. The deflection's own derivative (c dtau/dq, a few 1e-3
of the identity at the sizes of real arms) is left out of the Jacobian, not out of the
error: the iteration is then a fixed point that converges linearly at that rate to the
exact solution of the deflecting model, to 1 nm / 1 nrad in a handful of iterations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .arguments import (
    as_angles_rad,
    as_array,
    as_chain,
    as_instance,
    as_int,
    as_optional,
    as_parameter_model,
)
from .exceptions import ArgumentError, CalibPinError
from .parameters import ParameterModel
from .robot.chain import Chain
from .robot.deflection import ComplianceSpec, Deflection
from .robot.kinematics import Kinematics

#: What compensation must reach: end-frame position [m] and orientation [rad] error.
TOLERANCE_M = 1e-6
TOLERANCE_RAD = 1e-6
#: Where the iteration stops early (a thousand times finer).
_STOP_M, _STOP_RAD = 1e-9, 1e-9
#: Damping of the least-squares step (near singular poses), [m] and [rad] per unit.
_DAMPING = 1e-6
#: Largest change of a joint in one step, [rad].
_MAX_STEP_RAD = 0.05


@dataclass(frozen=True)
class Compensation:
    """Compensated commands for many targets.

    Attributes:
        q: Joint commands, shape (n_targets, n_joints), [rad].
        position_error_m: Remaining end-frame position error of the calibrated arm, [m].
        orientation_error_rad: Remaining end-frame orientation error (rotation angle), [rad].
        iterations: Gauss-Newton iterations taken.
        problems: Per target, why it failed ("" when it did not): a joint limit or no
            convergence.
    """

    q: np.ndarray
    position_error_m: np.ndarray
    orientation_error_rad: np.ndarray
    iterations: int
    problems: tuple[str, ...]

    def check(self) -> None:
        """Raises CalibPinError naming the first target that failed (0-based index)."""
        for k, problem in enumerate(self.problems):
            if problem:
                raise CalibPinError(f"target {k + 1}: {problem}")


class CalibratedRobot:
    """A calibrated robot: geometry (a parameter model's deviations) and joint compliance.

    Args:
        chain: The nominal robot chain.
        params: Its parameter model.
        deviations: The robot's deviations, shape (len(params.names),), SI ([m], [rad]).
        compliance: Compliant joints and loads, or None for a rigid arm.
        compliance_values: Their compliances, shape (n_compliant,), [rad/Nm] (the basis
            model, ``compliance.model == "basis"``: its signed coefficients [rad]).
        cable: Hook [m, end frame] and anchor [m, base frame] of a drawstring whose pull
            the arm carries (only with ``compliance.cable_tension_n``); None: no cable.
    """

    def __init__(self, chain: Chain, params: ParameterModel, deviations: np.ndarray,
                 compliance: ComplianceSpec | None = None, compliance_values: np.ndarray | None = None,
                 cable: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        self.chain = as_chain(chain, "chain")
        self.params = as_parameter_model(params, "params", chain)
        self.deviations = as_array(deviations, "deviations", (len(params.names),))
        as_optional(as_instance, compliance, "compliance", ComplianceSpec,
                    "a ComplianceSpec (calib_pin.robot.deflection) or None")
        if compliance_values is not None:
            values = as_array(compliance_values, "compliance_values", (None,), unit="rad/Nm")
            if np.any(values < 0) and not (compliance is not None and compliance.model == "basis"):  # signed
                raise ArgumentError("compliance_values", f"a compliance is >= 0 [rad/Nm], got {values.tolist()}")
        if cable is not None and (not isinstance(cable, tuple) or len(cable) != 2):
            raise ArgumentError("cable", "expected (hook, anchor), each 3 numbers in m, or None")
        if cable is not None:
            cable = (as_array(cable[0], "cable", (3,)), as_array(cable[1], "cable", (3,)))
        if compliance is not None and compliance.cable_tension_n and cable is None:
            compliance = ComplianceSpec(compliance.joints, compliance.payload, 0.0)
        self.compliance_spec = compliance
        self.deflection = None if compliance is None else Deflection(chain, compliance, cable)
        self.compliance = np.asarray(compliance_values if compliance_values is not None else [], dtype=float)
        if self.deflection is not None and self.compliance.shape != (self.deflection.n,):
            raise CalibPinError(f"give {self.deflection.n} compliance(s) for {', '.join(self.deflection.spec.joints)}")
        self._real = Kinematics(chain)
        self._real.set_perturbation(params.delta_matrices(self.deviations))
        self._nominal = Kinematics(chain)

    @property
    def model(self) -> pin.Model:
        """Pinocchio model of the whole corrected robot (geometry only; a new model on each call)."""
        return self.chain.perturbed_model(self.params.deltas(self.deviations))

    def joint_angles(self, q: np.ndarray) -> np.ndarray:
        """The link angles of the real arm at commands q (n, n_joints) [rad]: q - c tau(q)."""
        return self._link_angles(np.atleast_2d(as_angles_rad(q, "q", self.chain)))

    def _link_angles(self, q: np.ndarray) -> np.ndarray:
        """:meth:`joint_angles` of checked q (n, n_joints), also beyond the limits (iterates)."""
        if self.deflection is None:
            return q
        return self.deflection.joint_angles(q, self.compliance)[0]

    def _frames(self, q: np.ndarray, jacobian: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        return self._real.frames(self._link_angles(np.atleast_2d(q)), jacobian)

    def forward(self, q: np.ndarray) -> pin.SE3 | list[pin.SE3]:
        """The real arm's end frame at joint angles q: geometry and deflection.

        Args:
            q: Joint angles, shape (n_joints,) or (n_poses, n_joints), [rad].

        Returns:
            The end frame's placement in the base frame ([m]), one pin.SE3 for one pose,
            a list for many.
        """
        q = as_angles_rad(q, "q", self.chain)
        rot, trans, _ = self._frames(q)
        frames = [pin.SE3(r, t) for r, t in zip(rot, trans, strict=True)]
        return frames[0] if np.ndim(q) == 1 else frames

    def nominal(self, q: np.ndarray) -> pin.SE3 | list[pin.SE3]:
        """The nominal model's end frame at q (as :meth:`forward`)."""
        q = as_angles_rad(q, "q", self.chain)
        rot, trans, _ = self._nominal.frames(np.atleast_2d(q))
        frames = [pin.SE3(r, t) for r, t in zip(rot, trans, strict=True)]
        return frames[0] if np.ndim(q) == 1 else frames

    def compensate(self, q_nominal: np.ndarray) -> np.ndarray:
        """Joint commands that put the real end frame where the nominal model puts it at q_nominal.

        Args:
            q_nominal: Joint targets, shape (n_joints,) or (n_targets, n_joints), [rad].

        Returns:
            Commands of the same shape, [rad]; the calibrated arm's end frame there is
            within 1 um and 1 urad of the nominal one.

        Raises:
            CalibPinError: a target needs a joint beyond its limit, or does not converge
                (near a singularity), naming the target (1-based).
        """
        q_nominal = as_angles_rad(q_nominal, "q_nominal", self.chain)
        result = self.solve(q_nominal)
        result.check()
        return result.q[0] if np.ndim(q_nominal) == 1 else result.q

    def solve(self, q_nominal: np.ndarray, max_iterations: int = 50) -> Compensation:
        """:meth:`compensate` for many targets, with the remaining errors; failures are
        reported per target in ``problems`` instead of raised.

        Levenberg-Marquardt per target: a step that raises the error is undone and the
        damping raised tenfold; each step moves a joint by at most ``_MAX_STEP_RAD``.
        """
        q_nom = np.atleast_2d(as_angles_rad(q_nominal, "q_nominal", self.chain))
        max_iterations = as_int(max_iterations, "max_iterations", 1, 10**6)
        rot_t, trans_t, _ = self._nominal.frames(q_nom)
        targets = [pin.SE3(r, t) for r, t in zip(rot_t, trans_t, strict=True)]
        q, best_q = q_nom.copy(), q_nom.copy()
        best = np.full(len(q), np.inf)
        damping = np.full(len(q), _DAMPING)
        active = np.arange(len(q))
        iterations = 0
        while len(active) and iterations < max_iterations:
            rot, trans, jac = self._frames(q[active], jacobian=True)
            assert jac is not None
            done = np.zeros(len(active), dtype=bool)
            for i, k in enumerate(active):
                error = pin.log6(pin.SE3(rot[i], trans[i]).actInv(targets[k])).vector
                if np.abs(error[:3]).max() < _STOP_M and np.abs(error[3:]).max() < _STOP_RAD:
                    done[i] = True
                    continue
                size = float(np.linalg.norm(error))
                if size >= best[k]:  # worse: back to the best command, damp harder
                    q[k], damping[k] = best_q[k], damping[k] * 10.0
                    continue
                best[k], best_q[k], damping[k] = size, q[k], max(damping[k] / 10.0, _DAMPING)
                j = jac[i]
                step = j.T @ np.linalg.solve(j @ j.T + damping[k] ** 2 * np.eye(6), error)
                q[k] = q[k] + step * min(1.0, _MAX_STEP_RAD / max(np.abs(step).max(), 1e-300))
            active = active[~done]
            iterations += 1
        return self._result(q, targets, iterations)

    def _result(self, q: np.ndarray, targets: list[pin.SE3], iterations: int) -> Compensation:
        rot, trans, _ = self._frames(q)
        position = np.array([np.linalg.norm(t - target.translation) for t, target in zip(trans, targets, strict=True)])
        orientation = np.array([np.linalg.norm(pin.log3(r.T @ target.rotation))
                                for r, target in zip(rot, targets, strict=True)])
        problems = []
        names, lower, upper = self.chain.joint_names, self.chain.lower, self.chain.upper
        for k in range(len(q)):
            below, above = q[k] < lower - 1e-12, q[k] > upper + 1e-12
            if below.any() or above.any():
                j = int(np.flatnonzero(below | above)[0])
                bound = lower[j] if below[j] else upper[j]
                problems.append(f"needs {names[j]} at {np.rad2deg(q[k, j]):.6f} deg, beyond its limit "
                                f"{np.rad2deg(bound):g} deg")
            elif position[k] > TOLERANCE_M or orientation[k] > TOLERANCE_RAD:
                problems.append(f"no convergence to 1 um / 1 urad after {iterations} iterations (position "
                                f"{position[k] * 1e6:.3g} um, orientation {orientation[k] * 1e6:.3g} urad; "
                                "near a singularity, or beyond the real arm's reach)")
            else:
                problems.append("")
        return Compensation(q, position, orientation, iterations, tuple(problems))
