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

Near a wrist, elbow or shoulder singularity, or at a joint limit, the 6-D goal needs large
joint swings or none exists within the limits; there the position is met first and the
orientation error minimised (:meth:`CalibratedRobot.solve`, stage 2), and the target is
reported ``position-only`` with its orientation residual. Each target gets a status
(``ok``, ``position-only``, ``refused`` with the reason); one target never stops the others.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from scipy.optimize import least_squares, lsq_linear

from ..exceptions import ArgumentError, CalibPinError
from ..parameters import ParameterModel
from ..parameters.base import as_parameter_model
from ..robot.chain import Chain, as_angles_rad, as_chain
from ..robot.deflection import ComplianceSpec, Deflection
from ..robot.kinematics import Kinematics
from ..util.arguments import as_array, as_bool, as_instance, as_int, as_optional

#: What compensation must reach: end-frame position [m] and orientation [rad] error.
TOLERANCE_M = 1e-6
TOLERANCE_RAD = 1e-6
#: Where the iteration stops early (a thousand times finer).
_STOP_M, _STOP_RAD = 1e-9, 1e-9
#: Damping of the least-squares step (near singular poses), [m] and [rad] per unit.
_DAMPING = 1e-6
#: Largest change of a joint in one step, [rad].
_MAX_STEP_RAD = 0.05


#: Per-target status of a compensation.
OK, POSITION_ONLY, REFUSED = "ok", "position-only", "refused"
#: Largest correction of one joint a command may carry, [rad] (10 deg): a full 6-D solution
#: that needs more (a wrist swing near q5 = 0) is not taken; the position-first solve stays
#: within it.
MAX_CORRECTION_RAD = float(np.deg2rad(10.0))
#: Weight of the joint correction against the orientation error in the position-first
#: solve, [rad of orientation per rad of joints]^2: a joint moves by 0.1 rad only where that
#: buys about 0.01 rad of orientation. With a much smaller weight, near the shoulder
#: singularity (wrist centre on axis 1) joint_1 swings to the 10 deg bound, sweeping the
#: upper arm and forearm through the cell, for a few mrad of orientation; a much larger one
#: keeps the joints closer still but leaves a far larger orientation residual (see
#: tests/test_compensation.py's targets on the Wu calibration).
_REGULARISATION = 1e-2
#: Weight of the position error in the position-first solve, [1/m]: 1 um counts as 10 mrad.
_POSITION_WEIGHT = 1e6


@dataclass(frozen=True)
class Compensation:
    """Compensated commands for many targets, with a status per target.

    Attributes:
        q: Joint commands, shape (n_targets, n_joints), [rad]. A refused target's row is
            the best command found, which must not be sent (see ``status``).
        position_error_m: Remaining end-frame position error of the calibrated arm, [m].
        orientation_error_rad: Remaining end-frame orientation error (rotation angle), [rad].
        iterations: Iterations taken (the most of any target, both stages).
        status: Per target ``"ok"`` (position within 1 um and orientation within 1 urad),
            ``"position-only"`` (position within 1 um, the orientation error minimised:
            near a singularity; see ``orientation_error_rad``) or ``"refused"``.
        reasons: Per target, why it was refused or is position-only ("" when ok).
    """

    q: np.ndarray
    position_error_m: np.ndarray
    orientation_error_rad: np.ndarray
    iterations: int
    status: tuple[str, ...]
    reasons: tuple[str, ...]

    @property
    def problems(self) -> tuple[str, ...]:
        """Per target, why it was refused ("" for ok and position-only targets)."""
        return tuple(r if s == REFUSED else "" for s, r in zip(self.status, self.reasons, strict=True))

    def check(self, position_only: bool = False) -> None:
        """Refuse a compensation with a refused target, or a position-only one unless ``position_only``.

        Raises CalibPinError naming the first such target (1-based).
        """
        for k, (status, reason) in enumerate(zip(self.status, self.reasons, strict=True)):
            if status == REFUSED or (status == POSITION_ONLY and not position_only):
                raise CalibPinError(f"target {k + 1}: {status}: {reason}")


@dataclass(frozen=True)
class Determination:
    """What a calibration determined of the robot, as its calibration file keeps it.

    Attributes:
        columns: Index of each of its robot unknowns among the parameter model's names, shape (n,).
        sigma: Their prior standard deviations, SI, shape (n,).
        undetermined: The directions the data did not determine, rows in prior units, shape (k, n).
        noise: The noise covariance of the determined part, SI, shape (n, n).
        model_error: What the model did not explain, 1 sigma per coordinate, [m].
        points: The points the user named at calibration (``--tcp-mm``): (name, point in the
            end frame (3,) [m]) each; empty when none was named.
    """

    columns: np.ndarray
    sigma: np.ndarray
    undetermined: np.ndarray
    noise: np.ndarray
    model_error: float
    points: tuple[tuple[str, np.ndarray], ...] = ()

    @classmethod
    def from_dict(cls, doc: dict, names: tuple[str, ...]) -> Determination | None:
        """From a calibration file's ``determined`` section; None without one.

        From a calibration file's ``determined`` section; None without one (an older file)
        or with unknowns that are not the parameter model's deviations alone.
        """
        try:
            unknowns = list(doc["unknowns"])
            keep = [k for k, u in enumerate(unknowns) if u in names]  # compliances left out
            sigma = np.asarray(doc["prior_sigma_si"], dtype=float)[keep]
            undetermined = np.asarray(doc["undetermined_prior_units"], dtype=float).reshape(-1, len(unknowns))[:, keep]
            noise = np.asarray(doc["noise_covariance_si"], dtype=float)[np.ix_(keep, keep)]
            points = tuple((str(p["name"]), np.asarray(p["point_mm"], dtype=float).reshape(3) * 1e-3)
                           for p in doc.get("accuracy_mm", ())) if doc.get("points_named_by_user") else ()
            return cls(np.array([names.index(unknowns[k]) for k in keep], dtype=int), sigma, undetermined, noise,
                       float(doc.get("model_error_mm_per_coordinate", 0.0)) * 1e-3, points)
        except (KeyError, TypeError, ValueError):
            return None


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
        #: What the calibration determined (:class:`Determination`), when its file says.
        self.determination: Determination | None = None

    def point_accuracy(self, q: np.ndarray, point: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """A point's predicted RMS error [m] at each pose, and the prior's part of it.

        A point of the end frame's predicted RMS error [m] at each pose q (n, n_joints) [rad],
        and the part of it that is the prior's (what the data did not determine), each shape
        (n,); None when the calibration file does not say what it determined.
        """
        d = self.determination
        if d is None:
            return None
        kin = Kinematics(self.chain)
        kin.set_perturbation(self.params.delta_matrices(self.deviations))
        _, d_place = kin.points(np.atleast_2d(q), np.asarray(point, dtype=float), jacobian=True)
        assert d_place is not None
        k = 6 * self.chain.n_joints + 6
        jac = (d_place[:, :, :k] @ self.params.delta_jacobian(self.deviations))[:, :, d.columns]
        blind_basis = jac @ (d.sigma[:, None] * d.undetermined.T)
        blind = np.sum(blind_basis**2, axis=(1, 2))
        noise = np.einsum("nip,pk,nik->n", jac, d.noise, jac)
        return np.sqrt(blind + noise + 3 * d.model_error**2), np.sqrt(blind)

    def set_reference(self, deviations: np.ndarray | None) -> None:
        """Set the model the targets were computed with (:meth:`nominal`, what :meth:`solve` aims at).

        The catalogue URDF (None, the default) or that geometry corrected by ``deviations``
        (shape (len(params.names),), SI), e.g. a controller's own factory calibration
        (``compensate --nominal``).
        """
        self._nominal = Kinematics(self.chain)
        if deviations is not None:
            deviations = as_array(deviations, "deviations", (len(self.params.names),))
            self._nominal.set_perturbation(self.params.delta_matrices(deviations))

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
        """The nominal model's end frame at q, as :meth:`forward`.

        The reference of :meth:`set_reference` when one is set.
        """
        q = as_angles_rad(q, "q", self.chain)
        rot, trans, _ = self._nominal.frames(np.atleast_2d(q))
        frames = [pin.SE3(r, t) for r, t in zip(rot, trans, strict=True)]
        return frames[0] if np.ndim(q) == 1 else frames

    def compensate(self, q_nominal: np.ndarray, position_only: bool = False) -> np.ndarray:
        """Joint commands that put the real end frame where the nominal model puts it at q_nominal.

        Args:
            q_nominal: Joint targets, shape (n_joints,) or (n_targets, n_joints), [rad].
            position_only: Accept targets near a singularity where only the position is
                met (the orientation error minimised); :meth:`solve` gives their residual.

        Returns:
            Commands of the same shape, [rad]; the calibrated arm's end frame there is
            within 1 um and 1 urad of the nominal one (1 um only for position-only targets).

        Raises:
            CalibPinError: a target is refused (a joint beyond its limit, or out of reach),
                or position-only without ``position_only``, naming the target (1-based).
        """
        q_nominal = as_angles_rad(q_nominal, "q_nominal", self.chain)
        result = self.solve(q_nominal)
        result.check(as_bool(position_only, "position_only"))
        return result.q[0] if np.ndim(q_nominal) == 1 else result.q

    def solve(self, q_nominal: np.ndarray, max_iterations: int = 50) -> Compensation:
        """:meth:`compensate` for many targets, with the remaining errors and a status per target.

        A refused target never stops the others.

        Two stages, each started from the target itself:

        1. The full 6-D goal: Levenberg-Marquardt per target on log6 of the end-frame
           error (a step that raises the error is undone and the damping raised tenfold;
           each step moves a joint by at most ``_MAX_STEP_RAD``). A target met to
           1 um / 1 urad within the joint limits, no joint corrected by more than
           :data:`MAX_CORRECTION_RAD`, is ``ok``.
        2. The others (near a wrist or elbow singularity, or at a joint limit): position
           first. Gauss-Newton with the position as a constraint and the orientation
           error in its null space, regularised by the joint correction
           (:func:`_prioritised_step`); joints held inside their URDF limits and within
           :data:`MAX_CORRECTION_RAD` of the target. Position met: ``position-only`` (or
           ``ok`` when the orientation is met too); not met: ``refused``, with the reason.
        """
        q_nom = np.atleast_2d(as_angles_rad(q_nominal, "q_nominal", self.chain))
        max_iterations = as_int(max_iterations, "max_iterations", 1, 10**6)
        rot_t, trans_t, _ = self._nominal.frames(q_nom)
        targets = [pin.SE3(r, t) for r, t in zip(rot_t, trans_t, strict=True)]
        q, iterations = self._solve_full(q_nom, targets, max_iterations)
        position, orientation = self._errors(q, targets)
        lower, upper = self.chain.lower, self.chain.upper
        full = ((position <= TOLERANCE_M) & (orientation <= TOLERANCE_RAD)
                & np.all((q >= lower - 1e-12) & (q <= upper + 1e-12), axis=1)
                & (np.abs(q - q_nom).max(axis=1) <= MAX_CORRECTION_RAD))
        again = np.flatnonzero(~full)
        if len(again):
            q[again], more = self._solve_position_first(q_nom[again], [targets[k] for k in again], max_iterations)
            iterations = max(iterations, more)
        return self._result(q, q_nom, targets, iterations, full)

    def _solve_full(self, q_nom: np.ndarray, targets: list[pin.SE3], max_iterations: int) -> tuple[np.ndarray, int]:
        """Stage 1 of :meth:`solve`: the 6-D goal by Levenberg-Marquardt; (commands, iterations).

        Each target keeps its best command with its error and Jacobian; every iteration
        tries a step from there (damped by that target's damping), keeps it when the error
        falls (damping / 10) and else raises the damping tenfold and tries again from the
        best command. (Going back to the best command without a new step would find the
        same error there in the next iteration, reject it as "not better", and stall the
        target at its start, leaving a reachable target to stage 2.)
        """
        n = len(q_nom)
        q, best_q = q_nom.copy(), q_nom.copy()
        best = np.full(n, np.inf)
        best_error = np.zeros((n, 6))
        best_jac = np.zeros((n, 6, q_nom.shape[1]))
        damping = np.full(n, _DAMPING)
        active = np.arange(n)
        iterations = 0
        while len(active) and iterations < max_iterations:
            rot, trans, jac = self._frames(q[active], jacobian=True)
            assert jac is not None
            done = np.zeros(len(active), dtype=bool)
            for i, k in enumerate(active):
                error = pin.log6(pin.SE3(rot[i], trans[i]).actInv(targets[k])).vector
                size = float(np.linalg.norm(error))
                if size < best[k]:  # better (or the start): the new best, damp less
                    best[k], best_q[k], best_error[k], best_jac[k] = size, q[k], error, jac[i]
                    damping[k] = max(damping[k] / 10.0, _DAMPING)
                else:  # worse: back to the best command, damp harder
                    damping[k] *= 10.0
                e = best_error[k]
                if (np.abs(e[:3]).max() < _STOP_M and np.abs(e[3:]).max() < _STOP_RAD) or damping[k] > 1e6:
                    q[k], done[i] = best_q[k], True
                    continue
                j = best_jac[k]
                step = j.T @ np.linalg.solve(j @ j.T + damping[k] ** 2 * np.eye(6), e)
                q[k] = best_q[k] + step * min(1.0, _MAX_STEP_RAD / max(np.abs(step).max(), 1e-300))
            active = active[~done]
            iterations += 1
        q[active] = best_q[active]
        return q, iterations

    def _solve_position_first(self, q_nom: np.ndarray, targets: list[pin.SE3],
                              max_iterations: int) -> tuple[np.ndarray, int]:
        """Stage 2 of :meth:`solve`: position first, then the orientation; (commands, iterations).

        Per target, Gauss-Newton on the merit ||r(q)||^2 with r(q) = [W (p(q) - p_t),
        log3(R_t^T R(q)), sqrt(mu) (q - q_t)] (W = ``_POSITION_WEIGHT`` per m, mu =
        ``_REGULARISATION``): each step is the bounded linear least-squares step (scipy's
        ``lsq_linear``, exact active set) that keeps every joint within [max(lower, q_t -
        B), min(upper, q_t + B)], B = :data:`MAX_CORRECTION_RAD`, halved until the merit
        falls. The weight makes 1 um of position cost as much as 10 mrad of orientation:
        the position is met wherever it can be, the orientation error is the least the
        joints allow without swinging far for little gain.
        """
        lo = np.maximum(self.chain.lower, q_nom - MAX_CORRECTION_RAD)
        hi = np.minimum(self.chain.upper, q_nom + MAX_CORRECTION_RAD)
        mu = np.sqrt(_REGULARISATION)
        q = np.clip(q_nom, lo, hi)
        n = q.shape[1]
        iterations = 0

        def residual(x: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
            rot, trans, jac = self._frames(x[None], jacobian=True)
            assert jac is not None
            relative = targets[k].rotation.T @ rot[0]
            r = np.concatenate([_POSITION_WEIGHT * (trans[0] - targets[k].translation), pin.log3(relative),
                                mu * (x - q_nom[k])])
            j = np.vstack([_POSITION_WEIGHT * rot[0] @ jac[0][:3], pin.Jlog3(relative) @ jac[0][3:], mu * np.eye(n)])
            return r, j

        for k in range(len(q)):
            r, j = residual(q[k], k)
            merit = float(r @ r)
            for it in range(1, max(max_iterations, 100) + 1):
                iterations = max(iterations, it)
                step = lsq_linear(j, -r, bounds=(lo[k] - q[k], hi[k] - q[k] + 1e-300), method="bvls").x
                step *= min(1.0, _MAX_STEP_RAD / max(np.abs(step).max(), 1e-300))
                for _ in range(30):  # halve until the merit falls
                    trial = np.clip(q[k] + step, lo[k], hi[k])
                    r_t, j_t = residual(trial, k)
                    if float(r_t @ r_t) < merit:
                        break
                    step = step / 2
                else:
                    break
                moved = np.abs(trial - q[k]).max()
                q[k], r, j, merit = trial, r_t, j_t, float(r_t @ r_t)
                if moved < 1e-13:
                    break
            if np.linalg.norm(r[:3]) > TOLERANCE_M * _POSITION_WEIGHT:  # stalled (near the elbow singularity)
                q[k] = self._trust_region(q[k], k, residual, lo[k], hi[k], merit)
        return q, iterations

    @staticmethod
    def _trust_region(x: np.ndarray, k: int, residual: Callable[[np.ndarray, int], tuple[np.ndarray, np.ndarray]],
                      lo: np.ndarray, hi: np.ndarray, merit: float) -> np.ndarray:
        """The position-first merit minimised again from ``x`` by scipy's trust-region least squares.

        Bounded ``trf``, for a target the Gauss-Newton steps left short of its position (near
        the stretched-elbow singularity they crawl); the better of the two commands. Without
        it, some shipped poses of the Wu calibration with the basis model would be refused as
        out of reach, while a command within 2 deg meets them.
        """
        fit = least_squares(lambda z: residual(z, k)[0], x, jac=lambda z: residual(z, k)[1],
                            bounds=(lo, hi + 1e-300), method="trf", x_scale=1.0, xtol=1e-15, ftol=1e-15,
                            gtol=1e-15, max_nfev=300)
        return fit.x if 2.0 * fit.cost < merit else x

    def _errors(self, q: np.ndarray, targets: list[pin.SE3]) -> tuple[np.ndarray, np.ndarray]:
        """Position [m] and orientation [rad] error of the real arm at q against the targets."""
        rot, trans, _ = self._frames(q)
        position = np.array([np.linalg.norm(t - target.translation) for t, target in zip(trans, targets, strict=True)])
        orientation = np.array([np.linalg.norm(pin.log3(r.T @ target.rotation))
                                for r, target in zip(rot, targets, strict=True)])
        return position, orientation

    def _result(self, q: np.ndarray, q_nom: np.ndarray, targets: list[pin.SE3], iterations: int,
                full: np.ndarray) -> Compensation:
        position, orientation = self._errors(q, targets)
        names, lower, upper = self.chain.joint_names, self.chain.lower, self.chain.upper
        status, reasons = [], []
        for k in range(len(q)):
            if full[k] or (position[k] <= TOLERANCE_M and orientation[k] <= TOLERANCE_RAD):
                status.append(OK)
                reasons.append("")
            elif position[k] <= TOLERANCE_M:
                status.append(POSITION_ONLY)
                held = _held(q[k], q_nom[k], lower, upper, names)
                swing = int(np.argmax(np.abs(q[k] - q_nom[k])))
                reasons.append(f"{held + '; ' if held else 'near a singularity: '}position met, orientation off by "
                               f"{orientation[k] * 1e6:.4g} urad (the least the joints allow for their change), "
                               f"largest joint change {names[swing]} {np.rad2deg(q[k, swing] - q_nom[k, swing]):+.3g} deg")
            else:
                status.append(REFUSED)
                held = _held(q[k], q_nom[k], lower, upper, names)
                miss = f"the position is {position[k] * 1e6:.4g} um off"
                reasons.append(f"{'joint limit' if 'its limit' in held else 'out of reach'}: "
                               f"{held + ', ' if held else ''}{miss}")
        return Compensation(q, position, orientation, iterations, tuple(status), tuple(reasons))


def _held(q: np.ndarray, q_nom: np.ndarray, lower: np.ndarray, upper: np.ndarray, names: tuple[str, ...]) -> str:
    """Which joint of command q (n,) [rad] the position-first solve held on a bound ("" if none)."""
    for j in range(len(q)):
        if q[j] <= lower[j] + 1e-9 or q[j] >= upper[j] - 1e-9:
            bound = lower[j] if q[j] <= lower[j] + 1e-9 else upper[j]
            return f"{names[j]} held at its limit {np.rad2deg(bound):g} deg"
    for j in range(len(q)):
        if abs(q[j] - q_nom[j]) >= MAX_CORRECTION_RAD - 1e-9:
            return (f"near a singularity: the full pose needs {names[j]} corrected by more than "
                    f"{np.rad2deg(MAX_CORRECTION_RAD):g} deg, held there")
    return ""
