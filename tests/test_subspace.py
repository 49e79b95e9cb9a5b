"""The one decomposition of the identification Jacobian."""

import numpy as np

from calib_pin.estimators.subspace import RCOND, Subspace


def test_blind_directions_are_cut_and_whitened_steps_are_unit():
    """A column that equals another's negative leaves one blind direction; a unit step
    in z moves the linearised residual by 1 in norm."""
    rng = np.random.default_rng(1)
    jac = rng.normal(size=(50, 3))
    jac = np.column_stack([jac, -jac[:, 0]])  # x_0 - x_3 ... x_0 + x_3 is blind
    space = Subspace.of(jac, np.ones(4))
    assert space.rank == 3 and space.rcond == RCOND
    for k in range(space.dim):
        z = np.zeros(space.dim)
        z[k] = 1.0
        assert abs(np.linalg.norm(jac @ (space.to_x(z) - space.x0)) - 1.0) < 1e-12
    blind = np.array([1.0, 0, 0, 1.0])
    assert np.allclose(space.vt @ blind, 0.0)


def test_economy_svd_memory_stays_linear():
    """Many rows: the decomposition never builds the rows x rows square."""
    jac = np.random.default_rng(2).normal(size=(50_000, 5))
    space = Subspace.of(jac, np.ones(5))
    assert space.vt.shape == (5, 5) and space.singular_values.shape == (5,)
