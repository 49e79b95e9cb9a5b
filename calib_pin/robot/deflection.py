"""Joint compliance: static joint torques from Pinocchio and the deflection they cause.

An arm's joints twist under the loads they carry. calib-pin models each chosen joint j as
a torsional spring of compliance c_j [rad/Nm] (stiffness 1/c_j [Nm/rad]) between the
motor, whose angle q_j the controller reports, and the link. With tau(q) the static joint
torque the motors must hold (the generalized gravity of Pinocchio, plus what a payload
and a cable's pull demand), the link sits at

    q_eff = q + dq,   dq_j = -c_j tau_j(q)   (dq_j = 0 for the other joints).

Sign: tau is the torque the motor applies to hold the arm (the generalized force of the
loads is -tau); the spring gives way along that generalized force, so the arm sags. On
the IRB120 with the upper arm horizontal along +x (q_2 = +90 deg), gravity's pull about
joint 2's y axis is +y (tip down), tau_2 is negative and dq_2 = -c_2 tau_2 > 0: the
tip moves down (checked in the tests).

Loads (base frame = URDF root; gravity is Pinocchio's model.gravity, -9.81 m/s^2 along
the root's z axis, i.e. the robot stands upright):

- the links: ``pin.computeGeneralizedGravity`` on the chain's reduced model (which
  keeps the inertias of locked subtrees), from the URDF's inertial data;
- a payload of mass m [kg] with centre of mass r [m] in the end frame: the force
  f = m g at r, tau = -J_r^T f with the point's frame Jacobian (LOCAL_WORLD_ALIGNED);
- a drawstring's pull of tension T [N] at the hook point h [m] (end frame), directed
  from the hook towards the anchor P0 [m] (base frame): f = T (P0 - p)/|P0 - p|,
  tau = -J_h^T f.

Small-deflection approximation: the torques are evaluated at the commanded q (not at
q_eff) and on the nominal geometry (no geometric deviations; the cable's direction
from the given anchor, not an estimated correction of it). The torques therefore depend
on q only, the deflection is linear in c, and d q_eff / d c_j = -tau_j(q) e_j exactly.
The error is second order (c times the torque's change over dq). Measured on the IRB120
over 500 random poses within the joint limits, against the fixed point
q_eff = q - c tau(q_eff): with joints 2 and 3 at 3e-5 rad/Nm (deflections up to
0.7 mrad, sag up to 0.5 mm at the flange) the flange moves by at most 0.2 um
(the tests assert < 1 um); with the compliances fitted on the real
IRB120 set (6.6e-5 and 2.9e-4 rad/Nm, sag up to 1.7 mm) by at most 2.3 um, twenty
times below the laser tracker's noise. The nominal-geometry torques differ from the
deviated ones by the relative size of the deviations (1e-3), a further factor 1e-3 down.

Two models (:data:`MODELS`): ``cad``, the above, needs the URDF's inertias; ``basis``
(:mod:`calib_pin.robot.gravity_basis`) needs none: each joint's deflection is a linear
combination of the gravity torque patterns its kinematics allows, with coefficients
[rad] as unknowns. ``compliance_spec`` picks ``cad`` when the URDF has inertial data
(:func:`has_inertial_data`), else ``basis``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from ..exceptions import ArgumentError, CalibPinError, RobotError
from ..util.arguments import as_float, as_names, as_point_mm, shown_value
from ..util.deprecation import warn_deprecated
from .chain import Chain
from .gravity_basis import BASIS_SCALE, GravityBasis

#: Typical compliance [rad/Nm] (stiffness 5e4 Nm/rad, the order of a 3-25 kg
#: industrial arm's joints): the column scale of the estimators and the Kalman prior.
COMPLIANCE_SCALE = 2e-5


@dataclass(frozen=True)
class Payload:
    """A load carried by the end frame.

    Attributes:
        mass_kg: Mass [kg].
        com_m: Centre of mass in the end frame, shape (3,), [m].
    """

    mass_kg: float
    com_m: np.ndarray


@dataclass(frozen=True)
class CablePull:
    """A drawstring's pull on the end effector.

    Attributes:
        tension_n: Cable tension [N] (a few newtons for a drawstring sensor).
        hook_m: Where the cable hooks on, shape (3,), [m], end frame.
        anchor_m: The sensor's fixed point P0, shape (3,), [m], base frame.
    """

    tension_n: float
    hook_m: np.ndarray
    anchor_m: np.ndarray


#: Largest payload mass [kg] and cable tension [N] accepted (beyond: a unit mistake).
MAX_LOAD = 1e6

#: The deflection models: the URDF's inertias (``cad``) or the gravity basis (``basis``).
MODELS = ("cad", "basis")

#: The loads of a :class:`Compliance`, by field name, in the order of the record.
LOAD_FIELDS = ("payload_kg", "payload_com_mm", "cable_tension_n")


@dataclass(frozen=True)
class Compliance:
    """Which joints deflect, and the extra loads they carry.

    The options that travel together, validated once when the record is made.

    Attributes:
        joints: Compliant joint names (``("joint_2", "joint_3")``, or the comma-separated
            text ``"joint_2,joint_3"``), ``"all"`` for every moving chain joint, or empty
            for none (a rigid arm); stored as a tuple of names.
        payload_kg: Payload mass carried by the end frame [kg], or None (no payload).
        payload_com_mm: The payload's centre of mass in the end frame, (x, y, z) [mm], or
            None (the end frame's origin); stored as a tuple of floats.
        cable_tension_n: Drawstring tension [N] pulling the end effector towards the
            anchor (drawstring data only), or None (no pull).
        model: ``cad`` (the URDF's inertias), ``basis`` (the gravity basis, no inertias
            needed) or None: ``cad`` when the URDF has inertial data, else ``basis``.

    Which joints the robot has, and whether its URDF holds inertial data, is checked
    against the robot when the record is used (:meth:`spec`).

    Raises:
        ArgumentError: naming the field: not names, a joint named twice, a mass or tension
            not a finite number >= 0, a centre of mass not 3 finite numbers in mm, or loads
            without compliant joints.
    """

    joints: tuple[str, ...] | str = ()
    payload_kg: float | None = None
    payload_com_mm: tuple[float, float, float] | None = None
    cable_tension_n: float | None = None
    model: str | None = None

    def __post_init__(self) -> None:
        names = as_names(self.joints, "joints")
        mass = None if self.payload_kg is None else as_float(self.payload_kg, "payload_kg", 0.0, MAX_LOAD, unit="kg")
        com = None if self.payload_com_mm is None else tuple(
            float(v) for v in as_point_mm(self.payload_com_mm, "payload_com_mm", "end frame"))
        tension = None if self.cable_tension_n is None else as_float(
            self.cable_tension_n, "cable_tension_n", 0.0, MAX_LOAD, unit="N")
        loaded = [k for k, v in zip(LOAD_FIELDS, (mass, com, tension), strict=True) if v is not None]
        if loaded and not names:
            raise ArgumentError(loaded[0], "needs compliant joints (Compliance('joint_2,joint_3', ...) or 'all')")
        object.__setattr__(self, "joints", names)
        object.__setattr__(self, "payload_kg", mass)
        object.__setattr__(self, "payload_com_mm", com)
        object.__setattr__(self, "cable_tension_n", tension)
        if self.model is not None and self.model not in MODELS:
            raise ArgumentError("model", f"expected one of {', '.join(MODELS)}, got {shown_value(self.model)}")

    def __bool__(self) -> bool:
        """True when some joint is compliant."""
        return bool(self.joints)

    def spec(self, chain: Chain) -> ComplianceSpec | None:
        """The record for ``chain`` (``all`` expanded; None for a rigid arm).

        Args:
            chain: The robot chain whose joints and inertias it is checked against.

        Raises:
            CalibPinError: a joint the chain does not have, or a URDF without inertial data.
        """
        return compliance_spec(chain, self.joints, self.payload_kg, self.payload_com_mm, self.cable_tension_n,
                               model=self.model)

    def words(self) -> str:
        """The compliant joints, for people (``joint_2, joint_3``)."""
        return ", ".join(self.joints)


def as_compliance(value: Any, arg: str = "compliance", *, payload_kg: Any = None, payload_com_mm: Any = None,
                  cable_tension_n: Any = None) -> Compliance | None:
    """A :class:`Compliance` from what a caller gave as ``compliance``.

    The loose keywords ``payload_kg``, ``payload_com_mm`` and ``cable_tension_n`` are
    deprecated aliases of the record's fields (kept for one release, with a
    DeprecationWarning); given with a record, they are refused.

    Args:
        value: A record, joint names as shorthand (``"joint_2,joint_3"``, ``"all"``, a
            sequence of str), or None.
        arg: The argument's name, for messages.
        payload_kg: Deprecated: payload mass [kg].
        payload_com_mm: Deprecated: the payload's centre of mass in the end frame [mm].
        cable_tension_n: Deprecated: drawstring tension [N]; the warning is at the caller's
            line outside calib_pin.

    Raises:
        ArgumentError: ``value`` of another type, a bad field (named), or a loose keyword
            beside a record.
    """
    loose = {k: v for k, v in zip(LOAD_FIELDS, (payload_kg, payload_com_mm, cable_tension_n), strict=True)
             if v is not None}
    if loose:
        if isinstance(value, Compliance):
            key = next(iter(loose))
            raise ArgumentError(key, f"given beside {arg}=Compliance(...): give it once, as the record's field")
        warn_deprecated(f"{', '.join(loose)} as separate keyword(s) are deprecated: pass "
                        f"{arg}=calib_pin.Compliance(joints, {', '.join(f'{k}=...' for k in loose)})")
    if value is None and not loose:
        return None
    if isinstance(value, Compliance):
        return value
    if value is None or isinstance(value, (str, list, tuple)) or (isinstance(value, np.ndarray) and value.ndim == 1):
        return Compliance(as_names(value, arg), **loose)
    raise ArgumentError(arg, "expected a calib_pin.Compliance, joint names ('joint_2,joint_3' or 'all') "
                             f"or None, got {shown_value(value)}")


@dataclass(frozen=True)
class ComplianceSpec:
    """What the user asks for: which joints deflect and under which extra loads.

    Attributes:
        joints: Names of the compliant chain joints (e.g. ``joint_2``, ``joint_3``).
        payload: Optional payload in the end frame.
        cable_tension_n: Drawstring tension [N]; only for cable models, which supply
            the hook and anchor.
        model: ``cad`` (compliances [rad/Nm] on the URDF's inertias) or ``basis`` (the
            gravity basis's coefficients [rad]; :mod:`calib_pin.robot.gravity_basis`).
    """

    joints: tuple[str, ...]
    payload: Payload | None = None
    cable_tension_n: float = 0.0
    model: str = "cad"

    def to_dict(self) -> dict:
        """JSON-ready, in kg, mm and N."""
        payload = None if self.payload is None else {
            "mass_kg": self.payload.mass_kg, "com_mm": (np.asarray(self.payload.com_m) * 1e3).tolist()}
        return {"joints": list(self.joints), "payload": payload, "cable_tension_n": self.cable_tension_n,
                "compliance_model": self.model}

    @classmethod
    def from_dict(cls, doc: dict) -> ComplianceSpec:
        """Inverse of :meth:`to_dict`."""
        p = doc.get("payload")
        payload = None if p is None else Payload(float(p["mass_kg"]), np.asarray(p["com_mm"], dtype=float) * 1e-3)
        return cls(tuple(doc["joints"]), payload, float(doc.get("cable_tension_n", 0.0)),
                   str(doc.get("compliance_model", "cad")))


def compliance_report(spec: ComplianceSpec, compliance: np.ndarray, bounded: Sequence[str] = (),
                      effects: dict | None = None) -> dict:
    """The compliances [rad/Nm] and stiffnesses [Nm/rad] of the joints of ``spec``, for report.json.

    With its loads, and that the URDF does not hold them; for the basis model its
    coefficients [rad] per joint instead.

    Args:
        bounded: Joints whose compliance fitted negative and was fixed at zero (a
            compliance is >= 0); their stiffness is infinite (JSON null).
        effects: :func:`deflection_effects` over the data (peak deflection, end-frame
            effect, gravity agreement), merged in.
    """
    c = np.asarray(compliance, dtype=float)
    if spec.model == "basis":
        return {
            **spec.to_dict(),
            **(effects or {}),
            "model": "q_link = q + sum_k beta_jk b_jk(q): the gravity torque patterns of each joint's carried "
                     "links (Pinocchio's static regressor, reduced by an SVD), coefficients fitted; no inertias",
            "in_urdf": False,
            "note": "the calibrated URDF holds the geometry only; joint deflection is not in it "
                    "(the calibration JSON beside it holds the basis coefficients)",
        }
    return {
        **spec.to_dict(),
        "compliance_rad_per_Nm": dict(zip(spec.joints, c.tolist(), strict=True)),
        "stiffness_Nm_per_rad": dict(zip(spec.joints, stiffness(c).tolist(), strict=True)),
        "bounded_at_zero": list(bounded),
        "bound": "a compliance is >= 0: a joint that fits negative is fixed at zero (rigid) and the fit repeated",
        "model": "q_link = q - c tau(q): static joint torques tau from gravity on the URDF's inertias, "
                 "payload and cable pull, evaluated at the commanded q",
        "in_urdf": False,
        "note": "the calibrated URDF holds the geometry only; joint deflection is not in it "
                "(the calibration JSON beside it holds the compliances)",
        **(effects or {}),
    }


def deflection_effects(deflection: Deflection, end_origins: Any, q: np.ndarray, c: np.ndarray) -> dict:
    """What the fitted deflection does over poses q, per joint.

    Each joint's peak deflection [urad] and the largest move of the end frame's origin it
    alone causes [mm]; for the basis model also each joint's coefficients and gravity agreement (see
    :mod:`calib_pin.robot.gravity_basis`) and the joints that deflect against gravity.

    Args:
        deflection: The model's deflection.
        end_origins: q (n, n_joints) [rad] -> end-frame origins (n, 3) [m] of the
            calibrated geometry without deflection.
        q: Commanded joint angles of the data, (n_poses, n_joints) [rad].
        c: The deflection's unknowns (compliances [rad/Nm] or coefficients [rad]).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    joints = deflection.spec.joints
    dq = deflection.joint_deflections(q, c)
    base = end_origins(q)
    peak, moved = {}, {}
    for i, joint in enumerate(joints):
        shifted = q.copy()
        shifted[:, deflection.chain.joint_names.index(joint)] += dq[:, i]
        peak[joint] = float(np.max(np.abs(dq[:, i]), initial=0.0) * 1e6)
        moved[joint] = float(np.max(np.linalg.norm(end_origins(shifted) - base, axis=1), initial=0.0) * 1e3)
    out: dict[str, Any] = {"compliance_model": deflection.spec.model, "peak_deflection_urad": peak,
                           "end_frame_effect_mm": moved}
    basis = deflection.basis
    if basis is not None:
        owner = np.repeat(np.arange(len(joints)), basis.terms)
        beta = np.asarray(c, dtype=float)
        agree = basis.gravity_agreement(q, beta)
        out["basis_terms"] = dict(zip(joints, basis.terms.tolist(), strict=True))
        out["basis_coefficients_rad"] = {j: beta[owner == i].tolist() for i, j in enumerate(joints)}
        out["gravity_agreement"] = {j: (float(a) if np.isfinite(a) else None)
                                    for j, a in zip(joints, agree, strict=True)}
        out["against_gravity"] = [j for j, a in zip(joints, agree, strict=True) if np.isfinite(a) and a < 0]
    return out


def against_gravity_warning(joints: Sequence[str]) -> str:
    """The one line for basis deflections that lift the arm (sign-inconsistent with gravity)."""
    return (f"basis deflection against gravity: {', '.join(joints)} (the fitted deflection lifts the links "
            "this joint carries instead of letting them sag: a torque pattern gravity cannot produce; "
            "the term fits something else, e.g. an unmodelled error or noise: drop the joint or check the data)")


def has_inertial_data(chain: Chain) -> bool:
    """True when any body of the chain's model carries mass."""
    return any(inertia.mass > 0.0 for inertia in chain.model.inertias)


class StaticTorque:
    """Static joint torques tau(q) [Nm] the motors hold, batched over poses.

    Args:
        chain: The robot chain (its nominal reduced model is used).
        payload: Optional payload.
        cable: Optional cable pull.
    """

    def __init__(self, chain: Chain, payload: Payload | None = None, cable: CablePull | None = None) -> None:
        self.chain = chain
        self.payload = payload
        self.cable = cable
        self._model = chain.model
        self._data = chain.model.createData()

    def _point_jacobian(self, config: np.ndarray, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Base-frame position [m] and Jacobian (3, n_joints) of a point of the end frame."""
        model, data, fid = self._model, self._data, self.chain.frame_id
        frame = model.frames[fid]
        # A frame at the point, on the end frame's joint, for Pinocchio's frame Jacobian.
        placement = frame.placement * pin.SE3(np.eye(3), np.asarray(point, dtype=float))
        oMi = data.oMi[frame.parentJoint]
        jac = pin.getFrameJacobian(model, data, frame.parentJoint, placement, pin.LOCAL_WORLD_ALIGNED)
        return (oMi * placement).translation, jac[:3]

    def __call__(self, q: np.ndarray) -> np.ndarray:
        """Torques at joint angles q.

        Args:
            q: Joint angles, shape (n_poses, n_joints), [rad].

        Returns:
            tau: shape (n_poses, n_joints), [Nm] ([N] for a prismatic joint): the
            generalized force the motors apply to hold the arm still.
        """
        configs = self.chain.configuration(np.atleast_2d(q))
        model, data = self._model, self._data
        gravity = model.gravity.linear
        tau = np.empty((len(configs), self.chain.n_joints))
        for k, config in enumerate(configs):
            tau[k] = pin.computeGeneralizedGravity(model, data, config)
            if self.payload is None and self.cable is None:
                continue
            pin.computeJointJacobians(model, data, config)
            if self.payload is not None:
                _, jac = self._point_jacobian(config, self.payload.com_m)
                tau[k] -= jac.T @ (self.payload.mass_kg * gravity)
            if self.cable is not None and self.cable.tension_n:
                p, jac = self._point_jacobian(config, self.cable.hook_m)
                pull = self.cable.anchor_m - p
                tau[k] -= jac.T @ (self.cable.tension_n * pull / np.linalg.norm(pull))
        return tau


class Deflection:
    """Compliance unknowns of a measurement model and the joint angles they imply.

    Args:
        chain: The robot chain.
        spec: Compliant joints and loads.
        cable: Hook [m, end frame] and anchor [m, base frame] of the drawstring, when
            the measurement model is a cable; required for a cable tension.

    With ``spec.model == "basis"`` the unknowns are the coefficients [rad] of the gravity
    basis (:class:`~calib_pin.robot.gravity_basis.GravityBasis`), several per joint
    (``columns`` then repeats a joint), and no inertias are needed.

    Raises:
        RobotError: no compliant joint, a name that is not a chain joint, or a URDF
            without inertial data (CAD model).
        CalibPinError: a cable tension without a cable (or with the basis model), or a
            negative mass or tension.
    """

    def __init__(self, chain: Chain, spec: ComplianceSpec,
                 cable: tuple[np.ndarray, np.ndarray] | None = None) -> None:
        if not spec.joints:
            raise RobotError("compliance needs at least one joint name")
        unknown = [j for j in spec.joints if j not in chain.joint_names]
        if unknown:
            raise RobotError(
                f"robot '{chain.name}' has no chain joint '{unknown[0]}' for compliance "
                f"(joints: {', '.join(chain.joint_names)})"
            )
        if spec.model not in MODELS:
            raise CalibPinError(f"compliance model must be one of {', '.join(MODELS)}, got {spec.model!r}")
        if spec.model == "cad" and not has_inertial_data(chain):
            raise RobotError(
                f"{chain.description.urdf}: the URDF has no inertial data (all link masses are "
                "zero); the CAD compliance model needs the links' masses and centres of mass "
                "(the basis model needs none: --compliance-model basis)"
            )
        if spec.model == "basis" and spec.cable_tension_n:
            raise CalibPinError("a cable tension needs the CAD compliance model (the URDF's inertias): the "
                                "gravity basis cannot hold the cable's pull")
        if spec.payload is not None and spec.payload.mass_kg < 0:
            raise CalibPinError(f"payload mass must be >= 0 kg, got {spec.payload.mass_kg:g}")
        if spec.cable_tension_n < 0:
            raise CalibPinError(f"cable tension must be >= 0 N, got {spec.cable_tension_n:g}")
        if spec.cable_tension_n and cable is None:
            raise CalibPinError("a cable tension applies to drawstring data only")
        pull = None
        if spec.cable_tension_n and cable is not None:
            pull = CablePull(spec.cable_tension_n, np.asarray(cable[0], float), np.asarray(cable[1], float))
        self.spec = spec
        self.chain = chain
        self.torque = StaticTorque(chain, spec.payload if spec.model == "cad" else None, pull)
        self.basis = GravityBasis(chain, spec.joints) if spec.model == "basis" else None
        if self.basis is not None:
            self.columns = self.basis.columns
            self.names = self.basis.names
            self.units = ("rad",) * self.basis.n
            self.scale = np.full(self.basis.n, BASIS_SCALE)
        else:
            self.columns = np.array([chain.joint_names.index(j) for j in spec.joints])
            self.names = tuple(f"compliance_{j}" for j in spec.joints)
            self.units = ("rad/Nm",) * len(spec.joints)
            self.scale = np.full(len(spec.joints), COMPLIANCE_SCALE)

    @property
    def nonnegative(self) -> bool:
        """True when the unknowns are compliances (>= 0); the basis's coefficients are signed."""
        return self.basis is None

    @property
    def n(self) -> int:
        """Number of compliance unknowns."""
        return len(self.columns)

    def joint_angles(self, q: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Deflected joint angles and the derivative's factor.

        Args:
            q: Commanded joint angles, shape (n_poses, n_joints), [rad].
            c: Compliances of the chosen joints, shape (n,), [rad/Nm] (basis model: the
                basis coefficients [rad]).

        Returns:
            q_eff: shape (n_poses, n_joints), [rad]: q - c tau(q) on the chosen joints
            (basis: q + sum_k beta_k b_k(q)).
            minus_tau: shape (n_poses, n), [Nm]: -tau of the chosen joints, which is
            d q_eff[:, columns[i]] / d c_i (basis: the basis b(q), dimensionless).
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        factor = self.basis.values(q) if self.basis is not None else -self.torque(q)[:, self.columns]
        q_eff = q.copy()
        np.add.at(q_eff.T, self.columns, (factor * np.asarray(c, dtype=float)).T)  # a joint may repeat (basis)
        return q_eff, factor

    def joint_deflections(self, q: np.ndarray, c: np.ndarray) -> np.ndarray:
        """delta q of each joint of the spec, shape (n_poses, len(spec.joints)), [rad]."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        if self.basis is not None:
            return self.basis.deflections(q, c)
        return -self.torque(q)[:, self.columns] * np.asarray(c, dtype=float)


def fixed_point_angles(deflection: Deflection, q: np.ndarray, c: np.ndarray,
                       iterations: int = 20) -> np.ndarray:
    """Joint angles solving q_eff = q - c tau(q_eff) by fixed-point iteration, [rad].

    The reference for the small-deflection approximation (torques at q instead).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    q_eff = q.copy()
    if deflection.basis is not None:
        raise CalibPinError("the fixed point needs the CAD model's torques")
    for _ in range(iterations):
        tau = deflection.torque(q_eff)[:, deflection.columns]
        q_eff = q.copy()
        q_eff[:, deflection.columns] -= tau * np.asarray(c, dtype=float)
    return q_eff


def stiffness(compliance: Sequence[float] | np.ndarray) -> np.ndarray:
    """Stiffness [Nm/rad] of each compliance [rad/Nm] (inf where the compliance is <= 0)."""
    c = np.asarray(compliance, dtype=float)
    with np.errstate(divide="ignore"):
        return np.where(c > 0, 1.0 / np.where(c > 0, c, 1.0), np.inf)


def compliance_spec(chain: Chain, joints: str | Sequence[str] | None, payload_kg: float | None = None,
                    payload_com_mm: Sequence[float] | None = None,
                    cable_tension_n: float | None = None, model: str | None = None) -> ComplianceSpec | None:
    """The user's compliance options as a spec (None when no joint is compliant).

    Args:
        joints: Compliant joint names (a sequence or comma-separated text), ``all`` for
            every moving chain joint, or None/empty for none.
        payload_kg: Payload mass [kg]; payload_com_mm: its centre of mass in the end
            frame, 3 numbers [mm] (default the end frame's origin).
        cable_tension_n: Drawstring tension [N].
        model: ``cad``, ``basis``, or None: ``cad`` when the URDF has inertial data,
            else ``basis``.

    Raises:
        CalibPinError: loads without compliant joints, a negative or non-finite value,
            an unknown joint, an unknown model, the CAD model on a URDF without inertial
            data, or a cable tension with the basis model.
    """
    names = as_names(joints, "compliance")  # a joint named twice is refused
    if names == ("all",):
        names = tuple(chain.joint_names)
    loads = {"payload_kg": payload_kg, "payload_com_mm": payload_com_mm, "cable_tension_n": cable_tension_n}
    given = [k for k, v in loads.items() if v is not None]
    if not names:
        if given:
            raise CalibPinError(f"{given[0]} needs compliant joints (compliance=joint_2,joint_3 or all)")
        return None
    for key, value in (("payload_kg", payload_kg), ("cable_tension_n", cable_tension_n)):
        if value is not None and not (np.isfinite(value) and value >= 0):
            raise CalibPinError(f"{key} must be a finite number >= 0, got {value}")
    payload = None
    if payload_kg or payload_com_mm is not None:
        com = np.zeros(3) if payload_com_mm is None else np.asarray(payload_com_mm, dtype=float).reshape(-1)
        if com.shape != (3,) or not np.all(np.isfinite(com)):
            raise CalibPinError("payload_com_mm needs 3 finite numbers (x, y, z in mm, end frame)")
        payload = Payload(float(payload_kg or 0.0), com * 1e-3)
    if model is None:
        model = "cad" if has_inertial_data(chain) else "basis"
    spec = ComplianceSpec(names, payload, float(cable_tension_n or 0.0), str(model))
    Deflection(chain, spec, (np.zeros(3), np.ones(3)))  # refuse a bad joint or a massless URDF here
    return spec
