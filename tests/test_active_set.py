"""A compliance is >= 0 for every estimator: negative ones are fixed at zero and the fit is
repeated (:mod:`calib_pin.estimators.active_set`); nothing negative reaches a file."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.calibration.record import write_calibration
from calib_pin.cli.calibrate import calibrate_main
from calib_pin.estimators import run_estimator
from calib_pin.estimators.active_set import Fixed
from calib_pin.report.build import build_report

ROOT = Path(__file__).resolve().parent.parent
WU = ROOT / "robots" / "irb120_wu2015.csv"
KINEMATIC = [m for m in cp.ESTIMATORS if m not in ("rbf", "lm+rbf")]


@dataclasses.dataclass
class Linear:
    """A small linear least-squares problem A x = b whose unknown ``nonnegative[0]`` comes out
    negative unconstrained; 40 rows of one value, scale 1e-3 (the size of a deviation)."""


    a: np.ndarray
    b: np.ndarray
    nonnegative: tuple[int, ...] = (2,)
    values_per_row: int = 1

    @property
    def scale(self) -> np.ndarray:
        return np.full(self.a.shape[1], 1e-3)

    @property
    def n_rows(self) -> int:
        return len(self.b)

    n_values = n_rows

    @property
    def n_params(self) -> int:
        return self.a.shape[1]

    def residual(self, x):
        return self.a @ x - self.b

    def jacobian(self, x):
        return self.a

    def row_residual_with_jacobian(self, x, row):
        return self.residual(x)[row : row + 1], self.a[row : row + 1]

    def cost(self, x):
        r = self.residual(x)
        return float(r @ r) / len(r)

    def subset(self, rows):
        return dataclasses.replace(self, a=self.a[rows], b=self.b[rows])

    def rows_of(self, values):
        return np.unique(np.asarray(values, dtype=int))


def _linear() -> tuple[Linear, np.ndarray]:
    rng = np.random.default_rng(5)
    a = rng.normal(size=(40, 4))
    a[:, 2] = a[:, 0] + 0.3 * a[:, 2]  # correlated with unknown 0: clipping it at zero is 10x worse
    truth = np.array([1.0, -0.5, -0.8, 0.3]) * 1e-3
    problem = Linear(a, a @ truth + rng.normal(size=40) * 1e-6)
    free = [0, 1, 3]
    expected = np.zeros(4)
    expected[free] = np.linalg.lstsq(a[:, free], problem.b, rcond=None)[0]
    assert np.linalg.lstsq(a, problem.b, rcond=None)[0][2] < 0  # unconstrained: negative
    return problem, expected


@pytest.mark.parametrize("method", KINEMATIC)
def test_every_method_fixes_a_negative_bounded_unknown_at_zero(method):
    """Every parameter method, on a problem whose bounded unknown fits negative, returns it
    at exactly zero and the others at (the searches: near) the least-squares solution with
    it held there (an estimate merely clipped at zero costs 10 times more)."""
    problem, expected = _linear()
    result = run_estimator(method, problem, np.zeros(4), seed=0, noise=1e-6)
    assert result.x[2] == 0.0 and result.bounded == (2,)
    assert problem.cost(result.x) <= 1.25 * problem.cost(expected)
    if method in ("lm", "ekf", "ukf", "ekf-qibas"):
        assert np.allclose(result.x, expected, atol=1e-8), (result.x, expected)


def test_fixed_problem_drops_columns():
    """The reduced problem: its residual is the full one's with the fixed unknowns held, its
    Jacobian the full one's free columns; subsets keep the fixed values."""
    problem, _ = _linear()
    x_full = np.array([0.0, 0.0, 7e-4, 0.0])
    fixed = Fixed(problem, np.array([0, 1, 3]), x_full)
    z = np.array([1e-3, 2e-3, 3e-3])
    assert np.allclose(fixed.residual(z), problem.residual(np.array([1e-3, 2e-3, 7e-4, 3e-3])))
    assert np.array_equal(fixed.jacobian(z), problem.a[:, [0, 1, 3]])
    assert fixed.n_params == 3 and np.array_equal(fixed.scale, problem.scale[[0, 1, 3]])
    assert fixed.subset(np.arange(5)).n_rows == 5
    assert np.array_equal(fixed.expand(z), [1e-3, 2e-3, 7e-4, 3e-3])


@pytest.mark.parametrize("method", ["lm", "ekf", "lm+rbf"])
def test_compliance_all_on_the_wu_set_is_never_negative(method):
    """--compliance all on the real IRB120 set: joint 5 fits negative unbounded; with the
    bound it is exactly zero, named, and the fit is as good as before (the bound costs no
    accuracy worth having)."""
    result = cp.calibrate("irb120", WU, method=method, compliance="all")
    c = result.problem.model.compliance(result.x)
    assert np.all(c >= 0) and result.bounded_compliance == ("joint_5",)
    assert c[result.problem.model.deflection.spec.joints.index("joint_5")] == 0.0
    assert result.metrics["test"]["after"].rmse_mm < 0.21
    assert build_report(result)["compliance"]["bounded_at_zero"] == ["joint_5"]


def test_calibrate_cli_compliance_all_writes_no_negative_compliance(tmp_path, capfd):
    """The README's example: exit 0, the bounded joints printed, report.json names them, and
    the calibration file holds no negative compliance."""
    out = tmp_path / "o"
    assert calibrate_main(["irb120", "--data", str(WU), "--method", "lm", "--compliance", "all",
                           "--no-html", "--out", str(out)]) == 0
    printed = capfd.readouterr()
    assert "Traceback" not in printed.err
    assert "warning: compliance bounded at zero: joint_5" in printed.err
    report = json.loads((out / "report.json").read_text())
    assert report["compliance"]["bounded_at_zero"] == ["joint_5"]
    stored = json.loads((out / "irb120_calibration.json").read_text())["compliance"]["compliance_rad_per_Nm"]
    assert min(stored.values()) >= 0 and stored["joint_5"] == 0
    assert (out / "irb120_calibrated.urdf").is_file()


def test_a_negative_compliance_is_never_written(tmp_path):
    """A result that somehow holds a negative compliance: no calibration file, no URDF
    (sanity_error names the joint)."""
    result = cp.calibrate("irb120", WU, method="lm", compliance="joint_2,joint_3")
    x = result.x.copy()
    x[result.problem.model.n_robot + 1] = -1e-5
    bad = dataclasses.replace(result, x=x)
    assert "compliance_joint_3" in (bad.sanity_error() or "")
    with pytest.raises(cp.CalibPinError, match="compliance_joint_3 .* negative"):
        write_calibration(bad, tmp_path / "c.json")
    assert not (tmp_path / "c.json").exists()
    with pytest.raises(cp.CalibPinError, match="negative"):
        bad.to_urdf(tmp_path / "x.urdf")
