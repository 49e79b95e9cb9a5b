"""Which directions of the robot's deviations the data determines, and which it leaves to the prior.

A calibration's unknowns are the robot's deviations (and compliances) and each sensor's
own (an anchor, a device frame, fixtures). A user wants the robot; the sensor's unknowns
take whatever the robot does not explain. So the sensor's columns are projected out of
the training Jacobian J (J_R the robot's, J_S the sensor's):

    J~ = (I - P_S) J_R,    P_S the projection onto the columns of J_S,

and J~ is measured in units of the :class:`~calib_pin.parameters.prior.Prior` (W the
prior's standard deviations): A = J~ W = U S V^T, from A^T A (the robot's information with
the sensor's unknowns free). Along a right singular vector v_i a move of one prior standard
deviation changes the residual by s_i, so the data determines
v_i better than the prior does when s_i exceeds the noise (and the estimators' relative
cut, ``RCOND`` times the largest). The others are **not determined**: exactly blind (a turn
of the arm about a cable's anchor, d_2 - d_3 of parallel joints) or seen so weakly that
the prior knows more. A calibration keeps the robot at its start along them
(:mod:`calib_pin.calibration.gauge`); the error that leaves is bounded by the prior.

The estimate's error covariance splits into the two (robot unknowns, SI):

- noise: sigma^2 W V_d S_d^-2 V_d^T W (the determined directions, from the reading noise);
- blind: W V_u V_u^T W (the prior along the directions not determined).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from scipy.linalg import eigh

from ..estimators.subspace import RCOND
from ..parameters.prior import Prior

#: A deviation carrying more than this share of its prior variance into the directions not
#: determined is not determined at all.
UNSEEN = 0.99


@dataclass(frozen=True)
class Determined:
    """The robot directions a calibration's data determines, at an estimate.

    Attributes:
        robot: Indices of the free robot unknowns (deviations, compliances) in x, shape (n,).
        sigma: Their prior standard deviations, SI, shape (n,).
        singular_values: Of A = J~ W, descending, shape (n,), [residual unit per prior sigma].
        vt: Right singular vectors, shape (n, n), rows in prior units.
        rank: Directions determined (the first ``rank`` rows of ``vt``).
        noise: The residual's noise (1 sigma) the cut compares with, [m].
        n_params: Length of x.
    """

    robot: np.ndarray
    sigma: np.ndarray
    singular_values: np.ndarray
    vt: np.ndarray
    rank: int
    noise: float
    n_params: int
    free: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int), repr=False)
    gram: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)), repr=False)

    @property
    def n_undetermined(self) -> int:
        return len(self.robot) - self.rank

    @cached_property
    def undetermined(self) -> np.ndarray:
        """The directions not determined, as changes of the robot unknowns, SI, shape (n, k)."""
        return self.sigma[:, None] * self.vt[self.rank:].T

    def toward(self, x: np.ndarray, start: np.ndarray) -> np.ndarray:
        """The change of the robot unknowns that takes x to ``start`` where nothing is determined, SI.

        The change of the robot unknowns (SI, shape (n,)) that takes x to ``start`` along
        every direction not determined, and leaves the determined ones.
        """
        v = self.vt[self.rank:]
        gap = (np.asarray(start)[self.robot] - np.asarray(x)[self.robot]) / self.sigma
        return self.sigma * (v.T @ (v @ gap))

    def covariance(self) -> tuple[np.ndarray, np.ndarray]:
        """The (noise, blind) covariances of the robot unknowns, SI.

        (noise, blind) covariances of the robot unknowns, each shape (n_params, n_params),
        SI, zero outside :attr:`robot` (module docstring).
        """
        noise = np.zeros((self.n_params, self.n_params))
        blind = np.zeros((self.n_params, self.n_params))
        at = np.ix_(self.robot, self.robot)
        basis = self.sigma[:, None] * self.vt[: self.rank].T / self.singular_values[: self.rank]
        noise[at] = self.noise**2 * basis @ basis.T
        undetermined = self.undetermined
        blind[at] = undetermined @ undetermined.T
        return noise, blind

    def blind_share(self) -> np.ndarray:
        """Per free robot unknown, the share of its prior variance the data leaves, shape (n,).

        Per free robot unknown, the share of its prior variance the data leaves, shape (n,):
        0 for a parameter the data determines alone, 1 for one it does not see at all.
        """
        v = self.vt[self.rank:]
        return np.sum(v**2, axis=0)


def pinv_gram(gram: np.ndarray, rcond: float) -> np.ndarray:
    """The pseudo-inverse of a Gram matrix J^T J, its eigenvalues below ``rcond``^2 times the
    largest (singular values of J below ``rcond`` times the largest) left out."""
    if not len(gram):
        return gram.copy()
    w, v = eigh(gram)
    keep = w > rcond**2 * max(w[-1], 0.0) if w[-1] > 0 else np.zeros(len(w), dtype=bool)
    return (v[:, keep] / w[keep]) @ v[:, keep].T


def determined(problem: Any, x: np.ndarray, free: np.ndarray, prior: Prior, noise: float | None,
               rcond: float = RCOND) -> Determined:
    """What the rows of ``problem`` determine of the free robot unknowns at x.

    The rows' residual is in units of ``noise``. From the Gram matrix of the scaled
    Jacobian: the sensor's columns are projected out by the Schur complement (the robot's
    information with the sensor's unknowns free), so every step is on matrices of the
    unknowns' size, never of the rows'.

    Args:
        problem: A calibration problem (its training rows).
        x: The estimate, shape (n_params,), SI.
        free: Indices of the unknowns not held, shape (n_free,).
        prior: The prior whose units measure the robot's directions.
        noise: The residual's noise (1 sigma), [m]; None: sqrt(RSS / (m - r)) at x, r the
            rank of the free unknowns (a noise no one stated, nor estimated).
        rcond: The estimators' relative cut (:data:`calib_pin.estimators.subspace.RCOND`).
    """
    model = problem.model
    free = np.asarray(free, dtype=int)
    scale = np.asarray(model.scale, dtype=float)
    scaled = problem.jacobian(x)[:, free] * scale[free]
    gram = scaled.T @ scaled
    if noise is None:
        w = np.linalg.eigvalsh(gram)
        rank = int(np.sum(w > rcond**2 * w[-1])) if len(w) and w[-1] > 0 else 0
        r = problem.residual(x)
        noise = float(np.sqrt(r @ r / max(len(r) - rank, 1)))
    on_robot = free < model.sensor_start
    robot, sensor = free[on_robot], free[~on_robot]
    information = gram[np.ix_(on_robot, on_robot)]
    if len(sensor):  # what the sensor's unknowns cannot explain of the robot's columns
        across = gram[np.ix_(on_robot, ~on_robot)]
        information = information - across @ pinv_gram(gram[np.ix_(~on_robot, ~on_robot)], rcond) @ across.T
    sigma = prior.sigma(model.units, scale)[robot]
    ratio = sigma / scale[robot]  # one prior sigma in typical sizes
    w, v = eigh(ratio[:, None] * information * ratio[None, :])
    order = np.argsort(w)[::-1]
    s = np.sqrt(np.clip(w[order], 0.0, None))
    vt = v[:, order].T
    top = s[0] if len(s) else 0.0
    rank = int(np.sum((s > rcond * top) & (s > noise))) if top > 0 else 0
    return Determined(robot=robot, sigma=sigma, singular_values=s, vt=vt, rank=rank, noise=float(noise),
                      n_params=int(problem.n_params), free=free, gram=gram)
