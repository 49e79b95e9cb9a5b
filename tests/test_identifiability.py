"""The identifiability report names what one cable can and cannot see."""

import numpy as np

import calib_pin as cp
from calib_pin.identifiability import analyze


def test_shipped_set_report():
    """On the shipped IRB120 set: rank 20 of 24, theta_6 blind, three readable combinations."""
    setup = cp.prepare("irb120")
    result = analyze(setup.problem)
    assert result.rank == 20 and len(result.base) == 20
    assert result.unidentifiable == ("theta_6",)
    assert "d_2 +1 mm with d_3 -1 mm" in result.combinations
    assert any(c.startswith("a_5 +1 mm with theta_5") for c in result.combinations)
    assert len(result.combinations) == 3
    assert result.o3 == result.singular_values[19] and result.condition > 1
    assert result.o1 > 0 and result.o3 > result.o4 > 0
    text = result.report()
    assert "rank 20 of 24" in text and "not identifiable (no effect on the readings): theta_6" in text


def test_combinations_are_invisible(chain, params):
    """Each reported combination really moves no reading (to first order)."""
    setup = cp.prepare("irb120")
    jac = setup.problem.jacobian(np.zeros(24))
    names = list(params.names)
    step = np.zeros(24)
    step[names.index("d_2")], step[names.index("d_3")] = 1e-3, -1e-3
    assert np.abs(jac @ step).max() < 1e-12


def test_few_poses_lower_the_rank():
    setup = cp.prepare("irb120")
    assert analyze(setup.problem.subset(np.arange(8))).rank == 8
