"""Coordinates in which the search methods (BAS, QIBAS) look for deviations.

Deviations mix metres and radians, and some combinations move the readings a thousand
times more than others; some (``d_2 - d_3`` for parallel joints) do not move them at
all. A derivative-free search in raw parameters wastes nearly every step. The searches
therefore work in whitened coordinates z, fixed once at the start point x0:

    x = x0 + D V_r S_r^-1 z,     J(x0) D = U S V^T (SVD),  D = diag(parameter scale),

keeping the r directions whose singular value exceeds ``rcond`` (1e-3) times the
largest. The others are directions the sensor cannot see at all (``d_2 - d_3``) or
only at second order, a thousand times worse than the best: fitting them fits noise
(on the IRB120 an unrestricted fit drives such combinations to tens of millimetres). Near
x0 the residual is r(x) ~ r(x0) + U_r z: a unit step in z changes the residual vector
by 1 m in norm in every direction, and directions the sensor cannot see are not
searched (they stay at x0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import CalibrationProblem


@dataclass(frozen=True)
class SearchSpace:
    """Affine map from search coordinates z (shape (r,)) to deviations x (shape (n,)).

    Attributes:
        x0: Start point, shape (n_params,), SI units.
        basis: Columns map z to deviation changes, shape (n_params, r).
    """

    x0: np.ndarray
    basis: np.ndarray

    @classmethod
    def whitened(cls, problem: CalibrationProblem, x0: np.ndarray, rcond: float = 1e-3) -> SearchSpace:
        scale = problem.model.scale
        _, s, vt = np.linalg.svd(problem.jacobian(x0) * scale, full_matrices=False)
        keep = s > rcond * s[0]
        return cls(np.array(x0, dtype=float), (scale[:, None] * vt[keep].T) / s[keep])

    @property
    def dim(self) -> int:
        return self.basis.shape[1]

    def to_x(self, z: np.ndarray) -> np.ndarray:
        """Deviations at search point z."""
        return self.x0 + self.basis @ z
