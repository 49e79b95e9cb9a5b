"""The Compliance record: validated once when made, accepted by calibrate, prepare,
compare and simulate (joint names as shorthand), the loose keywords deprecated, and the
CLI building the record once."""

from __future__ import annotations

import argparse
import warnings

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.cli.common import compliance_options
from calib_pin.exceptions import ArgumentError, CalibPinError
from calib_pin.robot.deflection import Compliance, ComplianceSpec, Payload, as_compliance

JOINTS_23 = ("joint_2", "joint_3")
TRUE_C = np.array([2.5e-5, 4e-5])


def test_the_record_normalises_its_fields():
    record = Compliance("joint_2, joint_3", payload_kg=1, payload_com_mm=[10, -20, 60], cable_tension_n=np.float64(5))
    assert record.joints == JOINTS_23 and record.payload_kg == 1.0 and isinstance(record.payload_kg, float)
    assert record.payload_com_mm == (10.0, -20.0, 60.0) and record.cable_tension_n == 5.0
    assert record == Compliance(list(JOINTS_23), 1.0, (10, -20, 60), 5.0) and hash(record) == hash(
        Compliance(JOINTS_23, 1.0, (10, -20, 60), 5.0))
    assert not Compliance() and Compliance("all").joints == ("all",)
    with pytest.raises(AttributeError):
        record.payload_kg = 2.0  # type: ignore[misc]  # frozen


def test_the_record_resolves_against_the_robot(chain):
    spec = Compliance("joint_2,joint_3", payload_kg=1.5, payload_com_mm=(10, -20, 60), cable_tension_n=5.0).spec(chain)
    assert spec == ComplianceSpec(JOINTS_23, spec.payload, 5.0)
    assert isinstance(spec.payload, Payload) and np.allclose(spec.payload.com_m, [0.01, -0.02, 0.06])
    assert Compliance("all").spec(chain).joints == tuple(chain.joint_names)
    assert Compliance().spec(chain) is None
    with pytest.raises(CalibPinError, match="no chain joint 'joint_9'"):
        Compliance("joint_9").spec(chain)


def test_shorthand_and_deprecated_aliases():
    assert as_compliance(None) is None and as_compliance("joint_2") == Compliance(("joint_2",))
    record = Compliance("joint_2")
    assert as_compliance(record) is record
    with pytest.warns(DeprecationWarning, match="payload_kg"):
        assert as_compliance("joint_2", payload_kg=2.0) == Compliance("joint_2", payload_kg=2.0)
    with pytest.raises(ArgumentError, match="cable_tension_n.*give it once") as caught:
        as_compliance(record, cable_tension_n=2.0)
    assert caught.value.argument == "cable_tension_n"


def test_calibrate_with_the_record_equals_the_old_keywords(chain, params):
    """The same fit, bit for bit, from the record, the shorthand plus the deprecated loose
    keyword, and prepare + run; the record reaches the report."""
    data, _ = cp.simulate(chain, params, 60, seed=4, compliance=Compliance(JOINTS_23, cable_tension_n=5.0),
                          true_compliance=TRUE_C)
    new = cp.calibrate("irb120", data, method="lm", compliance=Compliance(JOINTS_23, cable_tension_n=5.0))
    with pytest.warns(DeprecationWarning, match="cable_tension_n"):
        old = cp.calibrate("irb120", data, method="lm", compliance="joint_2,joint_3", cable_tension_n=5.0)
    assert np.array_equal(new.x, old.x)
    spec = new.problem.model.compliance_spec
    assert spec.joints == JOINTS_23 and spec.cable_tension_n == 5.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the record itself warns of nothing
        setup = cp.prepare("irb120", data, compliance=Compliance(JOINTS_23, cable_tension_n=5.0))
    assert np.array_equal(cp.solve(setup, "lm").x, new.x)


def test_simulate_takes_the_record_or_the_shorthand(chain, params):
    a, ta = cp.simulate(chain, params, 20, seed=2, compliance=Compliance(JOINTS_23), true_compliance=TRUE_C)
    b, tb = cp.simulate(chain, params, 20, seed=2, compliance="joint_2,joint_3", true_compliance=TRUE_C)
    c, _ = cp.simulate(chain, params, 20, seed=2, compliance=ComplianceSpec(JOINTS_23), true_compliance=TRUE_C)
    assert np.array_equal(a.values, b.values) and np.array_equal(a.values, c.values)
    assert ta.compliance == tb.compliance == ComplianceSpec(JOINTS_23)


def test_compare_takes_the_record(tmp_path):
    table = cp.compare("irb120", methods=["lm"], simulate_noise="gauss", poses=40,
                       compliance=Compliance(JOINTS_23))
    assert "with the compliance of joint_2, joint_3" in table.data
    with pytest.raises(ArgumentError, match="compliance"):
        cp.compare("irb120", methods=["lm"], simulate_noise="gauss", poses=40, compliance=7)


def _args(**kw) -> argparse.Namespace:
    base = {"compliance": None, "payload_kg": None, "payload_com_mm": None, "cable_tension_n": None}
    return argparse.Namespace(**{**base, **kw})


def test_the_cli_builds_the_record_once():
    assert compliance_options(_args()) == {"compliance": None}
    got = compliance_options(_args(compliance=JOINTS_23, payload_kg=1.0, payload_com_mm=np.array([0.0, 0.0, 5.0])))
    assert got == {"compliance": Compliance(JOINTS_23, payload_kg=1.0, payload_com_mm=(0, 0, 5))}
    with pytest.raises(CalibPinError, match="--cable-tension-n needs compliant joints"):
        compliance_options(_args(cable_tension_n=3.0))
