"""The identifiable directions of the unknowns: one SVD, used everywhere.

Deviations mix metres and radians, and some combinations move the readings a thousand
times more than others; some (``d_2 - d_3`` for parallel joints) do not move them at
all. The estimators, the identifiability analysis (``--analyze``), the uncertainty and
the pose planner therefore share one decomposition of the identification Jacobian J at
a point x0, with each column scaled by the unknown's typical size D:

    J(x0) D = U S V^T (economy SVD),

keeping the r directions whose singular value exceeds ``RCOND`` times the largest. The
others are directions the sensor cannot see at all (``d_2 - d_3``) or only a thousand
times worse than the best: fitting them fits noise. The estimators search whitened
coordinates z,

    x = x0 + D V_r S_r^-1 z,

in which, near x0, a unit step changes the residual vector by 1 m in norm in every
direction; the blind directions stay at x0.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

#: Singular values below RCOND times the largest count as zero, everywhere.
RCOND = 1e-3


@dataclass(frozen=True)
class Subspace:
    """The identifiable subspace of a Jacobian at x0, and the whitened map onto it.

    Attributes:
        x0: The point, shape (n_params,), SI units.
        scale: Typical size of each unknown, shape (n_params,), SI units.
        singular_values: Every singular value of J D, descending, shape (min(m, n),),
            [unit of the residual per typical deviation].
        vt: The kept right singular vectors, shape (rank, n_params), in scaled units.
        rcond: The relative cut used.
    """

    x0: np.ndarray
    scale: np.ndarray
    singular_values: np.ndarray
    vt: np.ndarray
    rcond: float = RCOND

    @classmethod
    def of(cls, jacobian: np.ndarray, scale: np.ndarray, x0: np.ndarray | None = None,
           rcond: float = RCOND) -> Subspace:
        """Decompose ``jacobian`` (n_values, n_params), evaluated at x0 (default zero).

        Memory stays linear in the rows: the economy SVD never forms U's m x m square.
        """
        scale = np.asarray(scale, dtype=float)
        _, s, vt = np.linalg.svd(jacobian * scale, full_matrices=False)
        return cls.of_svd(s, vt, scale, x0, rcond)

    @classmethod
    def of_svd(cls, s: np.ndarray, vt: np.ndarray, scale: np.ndarray, x0: np.ndarray | None = None,
               rcond: float = RCOND) -> Subspace:
        """:meth:`of` from the economy SVD of ``jacobian * scale`` already made.

        Its singular values ``s`` (descending) and right singular vectors ``vt``.
        """
        scale = np.asarray(scale, dtype=float)
        keep = s > rcond * s[0] if len(s) and s[0] > 0 else np.zeros(len(s), dtype=bool)
        x0 = np.zeros(len(scale)) if x0 is None else np.array(x0, dtype=float)
        return cls(x0, scale, s, vt[keep], rcond)

    @classmethod
    def of_problem(cls, problem: Any, x0: np.ndarray | None = None, rcond: float = RCOND) -> Subspace:
        """The subspace of a least-squares problem's Jacobian at x0 (default zero)."""
        x0 = np.zeros(problem.n_params) if x0 is None else np.asarray(x0, dtype=float)
        return cls.of(problem.jacobian(x0), problem.scale, x0, rcond)

    @property
    def rank(self) -> int:
        """Number of identifiable directions."""
        return len(self.vt)

    @property
    def dim(self) -> int:
        """Dimension of the whitened search coordinates (the rank)."""
        return self.rank

    @property
    def kept(self) -> np.ndarray:
        """The kept singular values, shape (rank,)."""
        return self.singular_values[: self.rank]

    @cached_property
    def basis(self) -> np.ndarray:
        """Columns mapping whitened z to changes of x, shape (n_params, rank): D V_r S_r^-1."""
        return (self.scale[:, None] * self.vt.T) / self.kept

    def to_x(self, z: np.ndarray) -> np.ndarray:
        """Unknowns at whitened point z."""
        return self.x0 + self.basis @ z

    def covariance(self, noise: float) -> np.ndarray:
        """Covariance of a least-squares estimate along the identifiable directions, SI.

        For residual noise ``noise`` (1 sigma) per value; shape (n_params, n_params).
        """
        basis = self.basis
        return noise**2 * basis @ basis.T
