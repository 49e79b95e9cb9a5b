"""Gravity deflection without inertias: a basis of the static torque a joint can carry.

The CAD model (:mod:`calib_pin.robot.deflection`) needs the links' masses and centres
of mass. Without them the deflection is still linear in a few unknowns. At rest a
joint's torque is linear in the mass parameters of the links it carries,

    tau_j(q) = Y_j(q) pi,   pi_i = (m_i, m_i c_i) of each link i (c_i in link i's frame),

with Y_j the row of joint j of Pinocchio's joint torque regressor at zero velocity and
acceleration (``pin.computeJointTorqueRegressor``; its rotational-inertia columns are zero
at rest). So the deflection delta q_j = -c_j tau_j(q) = Y_j(q) (-c_j pi) lies in the
span of the columns of Y_j, restricted to the links joint j carries (its subtree): the
first :data:`FREE_LINKS` of them (the joint's own link and the next) with a free centre
of mass, the links beyond as point masses at their joints' origins (a wrist's links are
light and nearly centred on its axes; with every centre free, ``free_links=None``, the
IRB120's shoulder pitch gets 10 terms and the held-out mean over the Wu set's 10 splits
is 0.171 mm, against 0.163 with 5). Many of those columns are dependent (a link's mass
at its origin acts like its parent's first moment) and some are zero (a mass on the
joint's axis), so they are reduced to the combinations the kinematics can tell apart: an
SVD of Y_j's columns stacked over :data:`SAMPLES` seeded poses within the joint limits,
keeping the right singular vectors above :data:`RANK_TOLERANCE` of the whole chain's
sampled regressor (its norm). With them

    delta q_j(q) = sum_k beta_jk b_jk(q),   b_jk(q) = Y_j(q) v_jk / (s_jk / sqrt(S)),

each b_jk dimensionless with RMS 1 over the sampled poses, beta_jk [rad] the unknowns.
A joint with a vertical axis carries no gravity torque and gets no term. For a 6R arm's
shoulder pitch the terms are the sines and cosines of q2 and q2+q3 (upper arm and
forearm) and one for the flange's mass off the wrist centre: the IRB120's and the UR5's
joint 2 get 5 terms.

Any load the end frame carries (a payload of unknown mass at an unknown point) is a
change of the last link's mass parameters: it lies in the same span, so the basis holds
it. A drawstring's pull does not (its direction depends on the anchor): it needs the CAD
model.

Physical check: a deflection is a sag, delta q_j tau_j <= 0 along the torque gravity
demands. Without inertias tau_j is unknown, but its sign pattern is not: with point
masses at the joint origins the links join and at the end frame (every link's mass lies
somewhere between its joints) the prior torque tau0_j(q) follows the arm's reach.
:meth:`GravityBasis.gravity_agreement` is the cosine between a fitted deflection and
-tau0_j over the poses: near +1 a sag, negative a deflection that lifts the arm against
gravity (flagged, with that reason). A joint whose prior torque vanishes (the forearm
roll of a spherical wrist) has no check.

Units: q [rad], deflections [rad], the basis dimensionless.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from .chain import Chain

#: Poses sampled within the joint limits to find the basis (seeded: the same basis every run).
SAMPLES = 240
#: Seed of the sampled poses.
SEED = 20231
#: A combination whose singular value is below this fraction of the sampled regressor's norm is not seen.
RANK_TOLERANCE = 1e-8
#: Typical size of a basis coefficient [rad] (a deflection of 0.2 mrad): the column
#: scale of the estimators and the Kalman prior.
BASIS_SCALE = 2e-4
#: Carried links whose centre of mass is free (from the joint's own link on); the links
#: beyond are point masses at their joint origins (a wrist's links are light and centred).
FREE_LINKS = 2
#: Parameters of a link in Pinocchio's regressor, and those that act at rest (m, m c).
_PER_BODY, _AT_REST = 10, 4


def _sample_poses(chain: Chain, n: int, seed: int) -> np.ndarray:
    """Uniform poses within the limits (a continuous joint in [-pi, pi]), (n, n_joints) [rad]."""
    lower = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)
    upper = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
    return np.random.default_rng(seed).uniform(lower, upper, size=(n, chain.n_joints))


class GravityBasis:
    """The deflection basis of some joints of a chain, derived from its kinematics alone.

    Args:
        chain: The robot chain (its nominal reduced model).
        joints: Names of the compliant chain joints.

    Attributes:
        joints: The joints, in the order given.
        columns: Chain index of the joint each basis term deflects, shape (n_terms,)
            (a joint repeats once per term).
        terms: Number of terms of each joint, shape (n_joints,) of ``joints``.
        directions: Per joint, the combinations of its carried links' mass parameters
            (columns of the regressor) each term stands for: (regressor columns (n_cols,),
            directions (n_cols, n_terms_j) scaled by sqrt(S)/s).
    """

    def __init__(self, chain: Chain, joints: Sequence[str], free_links: int | None = FREE_LINKS) -> None:
        self.chain = chain
        self.free_links = free_links
        self.joints = tuple(joints)
        self._model = chain.model
        self._data = chain.model.createData()
        self._cache: tuple[bytes, np.ndarray] | None = None
        samples = self.regressor(_sample_poses(chain, SAMPLES, SEED))
        self.directions: list[tuple[np.ndarray, np.ndarray]] = []
        columns, terms = [], []
        floor = RANK_TOLERANCE * np.linalg.norm(samples)  # the whole chain's scale: a vertical axis has none
        for name in self.joints:
            j = chain.joint_names.index(name)
            cols = self._carried_columns(j)
            block = samples[:, j, :][:, cols]
            _, s, vt = np.linalg.svd(block, full_matrices=False)
            rank = int(np.sum(s > floor))
            v = vt[:rank].T
            v = v * np.sign(v[np.argmax(np.abs(v), axis=0), np.arange(rank)])  # a fixed sign per direction
            self.directions.append((cols, v * (np.sqrt(SAMPLES) / s[:rank])))
            columns += [j] * rank
            terms.append(rank)
        self.columns = np.array(columns, dtype=int)
        self.terms = np.array(terms, dtype=int)

    def _carried_columns(self, j: int) -> np.ndarray:
        """Regressor columns of the links chain joint j carries (its subtree).

        (m, m c) of the first ``free_links``, the mass alone (a point mass at the link's
        joint) of the rest.
        """
        jid = j + 1  # Pinocchio's joint 0 is the universe
        bodies = sorted(self._model.subtrees[jid])
        free = len(bodies) if self.free_links is None else self.free_links
        return np.array([_PER_BODY * (b - 1) + k for n, b in enumerate(bodies)
                         for k in range(_AT_REST if n < free else 1)], dtype=int)

    @property
    def names(self) -> tuple[str, ...]:
        """``basis_<joint>_<k>`` (k from 1) of every term."""
        return tuple(f"basis_{name}_{k + 1}" for name, n in zip(self.joints, self.terms, strict=True)
                     for k in range(n))

    @property
    def n(self) -> int:
        """Number of basis terms (unknowns)."""
        return len(self.columns)

    def regressor(self, q: np.ndarray) -> np.ndarray:
        """Pinocchio's static joint torque regressor, (n_poses, n_joints, 10 n_bodies).

        Unit: [N or m/s^2 times the unit of each inertial parameter].
        """
        configs = self.chain.configuration(np.atleast_2d(np.asarray(q, dtype=float)))
        zero = np.zeros(self._model.nv)
        return np.array([pin.computeJointTorqueRegressor(self._model, self._data, c, zero, zero)
                         for c in configs]).reshape(len(configs), self._model.nv, -1)

    def values(self, q: np.ndarray) -> np.ndarray:
        """The basis at joint angles q, (n_poses, n_terms), dimensionless.

        Term i is d q_eff[:, columns[i]] / d beta_i.
        """
        q = np.atleast_2d(np.asarray(q, dtype=float))
        key = q.tobytes() + str(q.shape).encode()
        if self._cache is not None and self._cache[0] == key:
            return self._cache[1]
        y = self.regressor(q)
        blocks = [y[:, self.chain.joint_names.index(name), :][:, cols] @ v
                  for name, (cols, v) in zip(self.joints, self.directions, strict=True)]
        out = np.concatenate(blocks, axis=1) if blocks else np.zeros((len(q), 0))
        self._cache = (key, out)
        return out

    def deflections(self, q: np.ndarray, beta: np.ndarray) -> np.ndarray:
        """delta q of each joint of ``joints``, (n_poses, len(joints)), [rad]."""
        terms = self.values(q) * np.asarray(beta, dtype=float)
        out = np.zeros((len(terms), len(self.joints)))
        owner = np.repeat(np.arange(len(self.joints)), self.terms)
        np.add.at(out.T, owner, terms.T)
        return out

    def prior_torque(self, q: np.ndarray) -> np.ndarray:
        """Torque of unit point masses at every joint origin and at the end frame, (n_poses, len(joints)) [Nm].

        The sign pattern gravity gives any arm of this kinematics (see the module).
        """
        model = self._model
        pi = np.zeros(_PER_BODY * (model.njoints - 1))
        pi[0::_PER_BODY] = 1.0  # a unit mass at each link's origin (its joint)
        frame = model.frames[self.chain.frame_id]
        body = frame.parentJoint
        pi[_PER_BODY * (body - 1)] += 1.0  # and one at the end frame
        pi[_PER_BODY * (body - 1) + 1 : _PER_BODY * (body - 1) + 4] += frame.placement.translation
        tau = self.regressor(q) @ pi
        return tau[:, [self.chain.joint_names.index(name) for name in self.joints]]

    def gravity_agreement(self, q: np.ndarray, beta: np.ndarray) -> np.ndarray:
        """Cosine over the poses q between each joint's fitted deflection and -tau0, shape (len(joints),).

        tau0 is :meth:`prior_torque`; +1 a sag, < 0 a lift against gravity; NaN where the
        joint has no deflection or no prior torque.
        """
        dq = self.deflections(q, beta)
        minus_tau = -self.prior_torque(q)
        num = np.sum(dq * minus_tau, axis=0)
        den = np.linalg.norm(dq, axis=0) * np.linalg.norm(minus_tau, axis=0)
        tiny = den <= 1e-12 * max(1.0, float(np.max(den, initial=0.0)))
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(tiny, np.nan, num / np.where(tiny, 1.0, den))
