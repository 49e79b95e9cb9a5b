"""The EKF's batched linearisation (calib_pin.estimators.ekf): blocks of rows linearised
together, against the row-by-row relinearisation (blocks of one row) and the truth."""

import numpy as np

from calib_pin import prepare
from calib_pin.estimators import ekf as ekf_module
from calib_pin.estimators.ekf import EKF, row_blocks
from calib_pin.estimators.problem import RowProblem


def test_row_blocks_double_up_to_the_cap_and_cover_every_row_once(monkeypatch):
    assert row_blocks(0) == []
    assert row_blocks(10) == [(0, 1), (1, 3), (3, 7), (7, 10)]
    monkeypatch.setattr(ekf_module, "BLOCK_ROWS", 4)
    blocks = row_blocks(30)
    assert [e - f for f, e in blocks] == [1, 2, 4, 4, 4, 4, 4, 4, 3]
    assert np.array_equal(np.concatenate([np.arange(f, e) for f, e in blocks]), np.arange(30))


class Linear(RowProblem):
    """r(x) = A x - b, one value per row."""

    values_per_row = 1

    def __init__(self, a, b):
        self.a, self.b = a, b
        self.n_rows, self.n_params = a.shape
        self.n_values = len(b)
        self.scale = np.ones(self.n_params)

    def residual(self, x):
        return self.a @ x - self.b

    def jacobian(self, x):
        return self.a.copy()

    def row_residual_with_jacobian(self, x, row):
        return self.residual(x)[row : row + 1], self.a[row : row + 1]

    def subset(self, rows):
        return Linear(self.a[rows], self.b[rows])


def test_blocks_give_the_row_by_row_filter_on_a_linear_problem(monkeypatch):
    """For a linear model the first-order carry is exact: the blocked filter is the
    row-by-row one up to rounding, and both find the least-squares solution's neighbourhood."""
    rng = np.random.default_rng(3)
    a = rng.standard_normal((200, 5))
    truth = rng.standard_normal(5)
    problem = Linear(a, a @ truth + 1e-3 * rng.standard_normal(200))
    blocked = EKF(prior=10.0)(problem, np.zeros(5), noise=1e-3)
    monkeypatch.setattr(ekf_module, "BLOCK_ROWS", 1)
    rowwise = EKF(prior=10.0)(problem, np.zeros(5), noise=1e-3)
    # Two orders of the same sums over 200 updates of O(1) values: a few thousand ulps, with the
    # BLAS kernel's own rounding (1.1e-12 with OpenBLAS's Haswell kernels); a wrong carry is off by > 1e-6.
    np.testing.assert_allclose(blocked.x, rowwise.x, rtol=0, atol=1e-10)
    np.testing.assert_allclose(blocked.covariance, rowwise.covariance, rtol=0, atol=1e-6 * np.abs(rowwise.covariance).max())
    assert np.max(np.abs(blocked.x - truth)) < 1e-3


def test_blocks_match_the_row_by_row_filter_on_a_calibration(session, fresh, monkeypatch):
    """On the seeded IRB120 session (nonlinear model) the blocked linearisation moves the
    estimate's predictions by far less than the noise (0.05 mm), and both reach the truth."""
    data, _ = session
    setup = prepare("irb120", data)
    rows = np.arange(96)
    problem = setup.problem_on(rows).subset(rows)
    x0 = np.zeros(problem.n_params)
    blocked = EKF()(problem, x0)
    monkeypatch.setattr(ekf_module, "BLOCK_ROWS", 1)
    rowwise = EKF()(problem, x0)
    assert row_blocks(96)[-1] == (95, 96)  # the patch made every block one row
    moved = np.abs(problem.residual(blocked.x) - problem.residual(rowwise.x))
    assert np.max(moved) < 5e-6 and np.sqrt(np.mean(moved**2)) < 1e-6  # [m]: a tenth of the noise at most
    assert not np.array_equal(blocked.x, rowwise.x)  # really two linearisations
    q, true_readings = fresh
    for result in (blocked, rowwise):
        assert np.sqrt(np.mean((problem.model.predict(result.x, q) - true_readings) ** 2)) * 1e3 < 0.06
