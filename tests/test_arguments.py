"""Every public entry point refuses a bad argument with a CalibPinError that names it.

Each case calls one entry point with one kind of bad argument (a wrong type, a wrong
shape, NaN, degrees given as radians, text where numbers or names are expected, a value
out of range) and asserts the error is a CalibPinError whose message names the argument;
an ArgumentError also carries the name as ``.argument``.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.calibration.record import write_calibration
from calib_pin.exceptions import ArgumentError
from calib_pin.export.calibration_file import calibration_path
from calib_pin.robot.chain import as_angles_rad
from calib_pin.robot.deflection import ComplianceSpec
from calib_pin.robot.poses import random_poses
from calib_pin.sensors import Drawstring
from calib_pin.util.arguments import as_array, as_names, as_xyz_mm

NAN3 = (float("nan"), 0.0, 0.0)


@pytest.fixture(scope="module")
def small(chain, params):
    """A simulated drawstring set of 30 poses."""
    return cp.simulate(chain, params, 30, seed=1)[0]


@pytest.fixture(scope="module")
def other(chain, params):
    """Another drawstring session of the same set-up: a validation session."""
    return cp.simulate(chain, params, 30, seed=2)[0]


@pytest.fixture(scope="module")
def positions(chain, params):
    """A simulated tracker set of 20 poses."""
    return cp.simulate_positions(chain, params, 20, seed=3)[0]


@pytest.fixture(scope="module")
def two(small, other):
    """An LM fit on two drawstring sets."""
    return cp.calibrate("irb120", [small, other], method="lm")


@pytest.fixture(scope="module")
def setup(small):
    return cp.prepare("irb120", small)


@pytest.fixture(scope="module")
def arm(chain, params):
    return cp.CalibratedRobot(chain, params, np.zeros(len(params.names)), ComplianceSpec(("joint_2",)), [2e-5])


@pytest.fixture(scope="module")
def fit(small):
    """An LM fit on the small set."""
    return cp.calibrate("irb120", small, method="lm")


@pytest.fixture(scope="module")
def calibration(fit, tmp_path_factory):
    """A calibration file of an LM fit on the small set."""
    folder = tmp_path_factory.mktemp("cal")
    return write_calibration(fit, calibration_path(folder, "irb120"))


def q_deg(chain):
    """Poses in degrees: what a caller who forgot np.deg2rad passes."""
    return np.rad2deg(random_poses(chain, 4, np.random.default_rng(0)))


#: (entry point, argument named, call): the call is made with the fixtures below.
CASES = [
    # check_measurements: what calibrate and prepare call on any set
    ("check_measurements", "chain", lambda f: cp.check_measurements("irb120", f.small)),
    ("check_measurements", "data", lambda f: cp.check_measurements(f.chain, [[0.0] * 6])),
    # calibrate / prepare
    ("calibrate", "robot", lambda f: cp.calibrate(123, f.small)),
    ("calibrate", "data", lambda f: cp.calibrate("irb120", 42)),
    ("calibrate", "test_data", lambda f: cp.calibrate("irb120", f.small, test_data=3.5)),
    ("calibrate", "method", lambda f: cp.calibrate("irb120", f.small, method=["lm"])),
    ("calibrate", "method", lambda f: cp.calibrate("irb120", f.small, method="nope")),
    ("calibrate", "seed", lambda f: cp.calibrate("irb120", f.small, seed=-1)),
    ("calibrate", "seed", lambda f: cp.calibrate("irb120", f.small, seed=1.5)),
    ("calibrate", "seed", lambda f: cp.calibrate("irb120", f.small, seed="3")),
    ("calibrate", "test_fraction", lambda f: cp.calibrate("irb120", f.small, test_fraction=1.5)),
    ("calibrate", "test_fraction", lambda f: cp.calibrate("irb120", f.small, test_fraction="0.2")),
    ("calibrate", "loss", lambda f: cp.calibrate("irb120", f.small, loss=None)),
    ("calibrate", "end_frame", lambda f: cp.calibrate("irb120", f.small, end_frame=5)),
    ("calibrate", "anchor_mm", lambda f: cp.calibrate("irb120", f.small, setup=cp.CableSetup(anchor_mm="600,200,-100"))),
    ("calibrate", "anchor_mm", lambda f: cp.calibrate("irb120", f.small, setup=cp.CableSetup(anchor_mm=(600, 200)))),
    ("calibrate", "anchor_mm", lambda f: cp.calibrate("irb120", f.small, setup=cp.CableSetup(anchor_mm=NAN3))),
    ("calibrate", "tool_mm", lambda f: cp.calibrate("irb120", f.small, setup=cp.CableSetup(tool_mm=[0, 0, "x"]))),
    ("calibrate", "tool_mm", lambda f: cp.calibrate("irb120", f.small, setup=cp.CableSetup(tool_mm=(0, 0, 5e7)))),
    ("calibrate", "length_offset_mm", lambda f: cp.calibrate("irb120", f.small, setup=cp.CableSetup(length_offset_mm="3"))),
    ("calibrate", "length_offset_mm", lambda f: cp.calibrate("irb120", f.small, setup=cp.CableSetup(length_offset_mm=float("nan")))),
    ("calibrate", "noise_mm", lambda f: cp.calibrate("irb120", f.small, noise_mm=0)),
    ("calibrate", "noise_mm", lambda f: cp.calibrate("irb120", f.small, noise_mm="0.1")),
    ("calibrate", "parameters", lambda f: cp.calibrate("irb120", f.small, parameters="poe")),
    ("calibrate", "estimate", lambda f: cp.calibrate("irb120", f.small, setup=cp.CableSetup(estimate="moon"))),
    ("calibrate", "estimate", lambda f: cp.calibrate("irb120", f.small, setup=cp.CableSetup(estimate=5))),
    ("calibrate", "estimate", lambda f: cp.calibrate("irb120", f.small, setup=cp.CableSetup(estimate=("anchor", 3)))),
    ("calibrate", "compliance", lambda f: cp.calibrate("irb120", f.small, compliance=7)),
    ("calibrate", "compliance", lambda f: cp.calibrate("irb120", f.small, compliance={"joints": "joint_2"})),
    ("calibrate", "payload_kg", lambda f: cp.calibrate("irb120", f.small, compliance=cp.Compliance("joint_2"),
                                                       payload_kg=1.0)),  # a loose alias beside the record
    # Compliance: each field checked once, when the record is made
    ("Compliance", "joints", lambda f: cp.Compliance(7)),
    ("Compliance", "joints", lambda f: cp.Compliance("joint_2,joint_2")),
    ("Compliance", "joints", lambda f: cp.Compliance(("joint_2", 3))),
    ("Compliance", "payload_kg", lambda f: cp.Compliance("joint_2", payload_kg=-1)),
    ("Compliance", "payload_kg", lambda f: cp.Compliance("joint_2", payload_kg="1.5")),
    ("Compliance", "payload_kg", lambda f: cp.Compliance(payload_kg=1.5)),  # a load without compliant joints
    ("Compliance", "payload_com_mm", lambda f: cp.Compliance("joint_2", payload_com_mm=(1, 2))),
    ("Compliance", "payload_com_mm", lambda f: cp.Compliance("joint_2", payload_com_mm=NAN3)),
    ("Compliance", "cable_tension_n", lambda f: cp.Compliance("joint_2", cable_tension_n=float("inf"))),
    ("Compliance", "cable_tension_n", lambda f: cp.Compliance("joint_2", cable_tension_n=-2.0)),
    ("Compliance", "cable_tension_n", lambda f: cp.Compliance((), cable_tension_n=2.0)),
    ("calibrate", "progress", lambda f: cp.calibrate("irb120", f.small, progress="yes")),
    ("prepare", "robot", lambda f: cp.prepare(None, f.small)),
    ("prepare", "anchor_mm", lambda f: cp.prepare("irb120", f.small, setup=cp.CableSetup(anchor_mm=[[1, 2, 3]]))),
    ("prepare", "anchor_mm", lambda f: cp.prepare("irb120", f.small, anchor_mm=(1, 2))),  # the deprecated shorthand
    ("prepare", "noise_mm", lambda f: cp.prepare("irb120", f.small, noise_mm=-1)),
    # solve, and how rows are held out
    ("solve", "calibration", lambda f: cp.solve("irb120", "lm")),
    ("solve", "method", lambda f: cp.solve(f.setup, 3)),
    ("solve", "seed", lambda f: cp.solve(f.setup, "lm", seed=-2)),
    ("solve", "holdout", lambda f: cp.solve(f.setup, "lm", holdout=2.0)),
    ("solve", "holdout", lambda f: cp.solve(f.setup, "lm", holdout=1.5)),
    ("solve", "loss", lambda f: cp.solve(f.setup, "lm", loss=["huber"])),
    ("solve", "holdout", lambda f: cp.solve(f.setup, "lm", holdout="a.csv")),
    ("solve", "history", lambda f: cp.solve(f.setup, "lm", history="no")),
    ("Fraction", "test_fraction", lambda f: cp.Fraction(-0.1)),
    ("Prior", "prior length_mm", lambda f: cp.Prior(length_mm=0.0)),
    ("Prior", "prior angle_deg", lambda f: cp.Prior(angle_deg=float("nan"))),
    ("prepare", "prior", lambda f: cp.prepare("irb120", prior=(1.0, 0.1))),
    ("prepare", "tcp_mm", lambda f: cp.prepare("irb120", tcp_mm=(1.0, 2.0))),
    ("Folds", "k", lambda f: cp.Folds(1)),
    ("solve", "holdout", lambda f: cp.solve(f.setup, "lm", holdout=cp.Folds(500))),
    ("solve", "method", lambda f: cp.solve(f.setup, "ekf_qibas")),
    ("calibrate", "holdout", lambda f: cp.calibrate("irb120", f.small, holdout=cp.Fraction(0.3))),
    ("calibrate", "test_fraction", lambda f: cp.calibrate("irb120", f.small, method="lm", test_data=f.other,
                                                          test_fraction=0.5)),  # the session is the test
    ("calibrate", "test_data", lambda f: cp.calibrate("irb120", [f.small, cp.FitSet(f.other, role="test")],
                                                      method="lm", test_data=f.other)),
    ("calibrate", "anchor_mm", lambda f: cp.calibrate("irb120", f.small, setup=cp.CableSetup(anchor_mm=(0, 0, 0)),
                                                      anchor_mm=(600, 200, -100))),  # the shorthand beside the record
    ("calibrate", "setup", lambda f: cp.calibrate("irb120", f.positions, method="lm",
                                                  setup=cp.CableSetup(anchor_mm=(600, 200, -100)))),
    ("calibrate", "setup", lambda f: cp.calibrate("irb120", f.positions, method="lm",
                                                  setup=cp.CableSetup(estimate="anchor"))),
    ("calibrate", "data", lambda f: cp.calibrate("ur5", method="lm")),  # no shipped set
    ("CalibrationResult.predict", "q", lambda f: f.fit.predict(np.zeros((2, 5)))),
    ("CalibrationResult.predict", "q", lambda f: f.fit.predict("0,0,0,0,0,0")),
    ("CalibrationResult.predict", "set", lambda f: f.fit.predict(np.zeros(6), set="nope")),
    ("CalibrationResult.predict", "set", lambda f: f.two.predict(np.zeros(6))),  # several sets: name one
    ("CalibrationResult.predict", "point_ids", lambda f: f.fit.predict(np.zeros(6), point_ids=[1, 2])),
    ("TestSet", "test_data", lambda f: cp.TestSet(12)),
    ("TestSet", "register", lambda f: cp.TestSet("a.csv", register=0)),
    ("TestSet", "same", lambda f: cp.TestSet("a.csv", same=3)),
    # simulate / simulate_positions
    ("simulate", "chain", lambda f: cp.simulate("irb120", f.params, 10, 0)),
    ("simulate", "params", lambda f: cp.simulate(f.chain, "dh", 10, 0)),
    ("simulate", "n_poses", lambda f: cp.simulate(f.chain, f.params, 0, 0)),
    ("simulate", "n_poses", lambda f: cp.simulate(f.chain, f.params, 2.5, 0)),
    ("simulate", "seed", lambda f: cp.simulate(f.chain, f.params, 10, -1)),
    ("simulate", "noise_mm", lambda f: cp.simulate(f.chain, f.params, 10, 0, noise_mm=float("nan"))),
    ("simulate", "noise_mm", lambda f: cp.simulate(f.chain, f.params, 10, 0, noise_mm=-0.1)),
    ("simulate", "nominal_rmse_mm", lambda f: cp.simulate(f.chain, f.params, 10, 0, nominal_rmse_mm=-1)),
    ("simulate", "anchor_mm", lambda f: cp.simulate(f.chain, f.params, 10, 0, anchor_mm=(1, 2))),
    ("simulate", "tool_mm", lambda f: cp.simulate(f.chain, f.params, 10, 0, tool_mm="0,0,50")),
    ("simulate", "length_offset_mm", lambda f: cp.simulate(f.chain, f.params, 10, 0, length_offset_mm=np.inf)),
    ("simulate", "noise_kind", lambda f: cp.simulate(f.chain, f.params, 10, 0, noise_kind="pink")),
    ("simulate", "poses", lambda f: cp.simulate(f.chain, f.params, 10, 0, poses=q_deg(f.chain))),
    ("simulate", "poses", lambda f: cp.simulate(f.chain, f.params, 10, 0, poses=np.zeros((4, 5)))),
    ("simulate", "compliance", lambda f: cp.simulate(f.chain, f.params, 10, 0, compliance=7,
                                                     true_compliance=[1e-5])),
    ("simulate", "true_compliance", lambda f: cp.simulate(f.chain, f.params, 10, 0, compliance="joint_2",
                                                          true_compliance=[1e-5, 2e-5])),
    ("simulate", "true_compliance", lambda f: cp.simulate(f.chain, f.params, 10, 0, compliance=ComplianceSpec(("joint_2",)),
                                                          true_compliance=[-1e-5])),
    ("simulate_sessions", "sessions", lambda f: cp.simulate_sessions(f.chain, f.params, 10, 0, sessions=0)),
    ("simulate_sessions", "kind", lambda f: cp.simulate_sessions(f.chain, f.params, 10, 0, kind="laser")),
    ("simulate_sessions", "anchors_mm", lambda f: cp.simulate_sessions(f.chain, f.params, 10, 0, 2,
                                                                       anchors_mm=[[1, 2, 3]])),
    ("simulate_sessions", "devices", lambda f: cp.simulate_sessions(f.chain, f.params, 10, 0, 2, kind="position",
                                                                    devices=np.eye(4))),
    ("simulate_sessions", "poses", lambda f: cp.simulate_sessions(f.chain, f.params, 10, 0, 2, kind="position",
                                                                  poses=np.full((3, 6), 10.0))),  # rad, past the limits
    ("simulate_sessions", "kinds", lambda f: cp.simulate_sessions(f.chain, f.params, 10, 0, 3, kinds=["cable", "position"])),
    ("simulate_sessions", "noise_mm", lambda f: cp.simulate_sessions(f.chain, f.params, 10, 0, 2, noise_mm=[0.1])),
    ("simulate_sessions", "geometries", lambda f: cp.simulate_sessions(f.chain, f.params, 10, 0, 2,
                                                                       geometries=[None, "anchor"])),
    ("simulate_positions", "markers_mm", lambda f: cp.simulate_positions(f.chain, f.params, 10, 0, markers_mm=(1, 2, 3))),
    ("simulate_positions", "device", lambda f: cp.simulate_positions(f.chain, f.params, 10, 0, device=np.eye(4))),
    ("simulate_positions", "n_poses", lambda f: cp.simulate_positions(f.chain, f.params, "10", 0)),
    # analyze
    ("analyze", "problem", lambda f: cp.analyze("irb120")),
    ("analyze", "x", lambda f: cp.analyze(f.setup.problem, np.zeros(3))),
    ("analyze", "x", lambda f: cp.analyze(f.setup.problem, np.full(f.setup.problem.n_params, np.nan))),
    ("analyze", "rcond", lambda f: cp.analyze(f.setup.problem, rcond=-1.0)),
    # load_calibration
    ("load_calibration", "path", lambda f: cp.load_calibration(3)),
    ("load_calibration", "robot", lambda f: cp.load_calibration(f.calibration, robot=5)),
    ("load_calibration", "cable", lambda f: cp.load_calibration(f.calibration, cable="yes")),
    # compensation: CalibratedRobot
    ("CalibratedRobot", "chain", lambda f: cp.CalibratedRobot("irb120", f.params, np.zeros(24))),
    ("CalibratedRobot", "deviations", lambda f: cp.CalibratedRobot(f.chain, f.params, np.zeros(23))),
    ("CalibratedRobot", "deviations", lambda f: cp.CalibratedRobot(f.chain, f.params, np.full(24, np.nan))),
    ("CalibratedRobot", "compliance_values", lambda f: cp.CalibratedRobot(
        f.chain, f.params, np.zeros(24), ComplianceSpec(("joint_2",)), [-1e-5])),
    ("CalibratedRobot.forward", "q", lambda f: f.arm.forward(q_deg(f.chain))),
    ("CalibratedRobot.forward", "q", lambda f: f.arm.forward(np.zeros(5))),
    ("CalibratedRobot.forward", "q", lambda f: f.arm.forward("0,0,0,0,0,0")),
    ("CalibratedRobot.nominal", "q", lambda f: f.arm.nominal(np.full(6, np.nan))),
    ("CalibratedRobot.joint_angles", "q", lambda f: f.arm.joint_angles(np.zeros((2, 7)))),
    ("CalibratedRobot.compensate", "q_nominal", lambda f: f.arm.compensate(q_deg(f.chain))),
    ("CalibratedRobot.compensate", "q_nominal", lambda f: f.arm.compensate([[0, 0, 0, 0, 0, None]])),
    ("CalibratedRobot.solve", "max_iterations", lambda f: f.arm.solve(np.zeros(6), max_iterations=0)),
    ("CalibratedRobot.compensate", "position_only", lambda f: f.arm.compensate(np.zeros(6), position_only="yes")),
    ("CalibratedRobot.set_reference", "deviations", lambda f: f.arm.set_reference(np.zeros(3))),
    ("run_estimator", "fixed", lambda f: cp.run_estimator("lm", f.setup.problem, np.zeros(f.setup.problem.n_params),
                                                          fixed=(10**6,))),
    # run_estimator
    ("run_estimator", "name", lambda f: cp.run_estimator(5, f.setup.problem, np.zeros(f.setup.problem.n_params))),
    ("run_estimator", "problem", lambda f: cp.run_estimator("lm", "problem", np.zeros(3))),
    ("run_estimator", "x0", lambda f: cp.run_estimator("lm", f.setup.problem, np.zeros(3))),
    ("run_estimator", "x0", lambda f: cp.run_estimator("lm", f.setup.problem, "zeros")),
    ("run_estimator", "seed", lambda f: cp.run_estimator("lm", f.setup.problem, np.zeros(f.setup.problem.n_params), seed=-1)),
    ("run_estimator", "noise", lambda f: cp.run_estimator("lm", f.setup.problem, np.zeros(f.setup.problem.n_params),
                                                          noise=0.0)),
    ("run_estimator", "loss", lambda f: cp.run_estimator("lm", f.setup.problem, np.zeros(f.setup.problem.n_params),
                                                         loss="wobbly")),
    ("run_estimator", "history", lambda f: cp.run_estimator("lm", f.setup.problem, np.zeros(f.setup.problem.n_params),
                                                            history="no")),
    # Kinematics
    ("Kinematics", "chain", lambda f: cp.Kinematics("irb120")),
    ("Kinematics.points", "q", lambda f: cp.Kinematics(f.chain).points(np.zeros((3, 5)), np.zeros(3))),
    ("Kinematics.points", "q", lambda f: cp.Kinematics(f.chain).points(np.full((3, 6), np.nan), np.zeros(3))),
    ("Kinematics.points", "point", lambda f: cp.Kinematics(f.chain).points(np.zeros((3, 6)), (1, 2))),
    ("Kinematics.points", "point", lambda f: cp.Kinematics(f.chain).points(np.zeros((3, 6)), NAN3, jacobian=True)),
    ("Kinematics.frames", "q", lambda f: cp.Kinematics(f.chain).frames(np.zeros(4))),
    ("Kinematics.set_perturbation", "deltas", lambda f: cp.Kinematics(f.chain).set_perturbation(np.zeros((6, 4, 4)))),
    # load_chain, parameter_model, the sensor models
    ("load_chain", "robot", lambda f: cp.load_chain(3)),
    ("load_chain", "end_frame", lambda f: cp.load_chain("irb120", end_frame=7)),
    ("parameter_model", "chain", lambda f: cp.parameter_model("irb120")),
    ("parameter_model", "name", lambda f: cp.parameter_model(f.chain, 3)),
    ("CableModel", "sensor", lambda f: cp.CableModel(f.chain, f.params, (1, 2, 3))),
    ("CableModel", "params", lambda f: cp.CableModel(f.chain, None, Drawstring(np.zeros(3), np.zeros(3)))),
    ("CableModel", "estimate", lambda f: cp.CableModel(f.chain, f.params, Drawstring(np.zeros(3), np.zeros(3)),
                                                       estimate="moon")),
    ("PositionModel", "device", lambda f: cp.PositionModel(f.chain, f.params, "tracker")),
    # several sets (calib_pin.calibration.sets): each FitSet's fields, checked by calibrate/prepare
    ("FitSet", "role", lambda f: cp.calibrate("irb120", [cp.FitSet(f.small, role="held"), f.small], method="lm")),
    ("FitSet", "label", lambda f: cp.calibrate("irb120", [cp.FitSet(f.small, label=3), f.small], method="lm")),
    ("FitSet", "noise_mm", lambda f: cp.calibrate("irb120", [cp.FitSet(f.small, noise_mm=-1), f.small], method="lm")),
    ("calibrate", "data", lambda f: cp.calibrate("irb120", [], method="lm")),
    ("calibrate", "noise_mm", lambda f: cp.calibrate("irb120", [f.small, f.small], noise_mm=[0.1], method="lm")),
    ("calibrate", "compliance", lambda f: cp.calibrate("irb120", f.small, method="lm", compliance=("joint_2", "joint_2"))),
    # reading and writing sets, a drawstring's geometry (were numpy's or Python's own errors)
    ("read_measurements", "path", lambda f: cp.read_measurements(3)),
    ("read_measurements", "chain", lambda f: cp.read_measurements(Path(__file__).parent.parent / "robots" / "irb120_default.csv", "irb120")),
    ("write_measurements", "data", lambda f: cp.write_measurements("never.csv", "the set")),
    ("write_measurements", "path", lambda f: cp.write_measurements(None, f.small)),
    ("Drawstring", "anchor", lambda f: cp.Drawstring("600,200,-100", np.zeros(3))),
    ("Drawstring", "tool", lambda f: cp.Drawstring(np.zeros(3), NAN3)),
    ("Drawstring", "length_offset", lambda f: cp.Drawstring(np.zeros(3), np.zeros(3), "0")),
    # write_outputs: checked before anything is made or written
    ("write_outputs", "result", lambda f: cp.write_outputs(f.setup, "never")),
    ("write_outputs", "folder", lambda f: cp.write_outputs(f.fit, None)),
    ("write_outputs", "formats", lambda f: cp.write_outputs(f.fit, "never", "urdf,stl")),
    ("write_outputs", "formats", lambda f: cp.write_outputs(f.fit, "never", 3)),
    ("write_outputs", "html", lambda f: cp.write_outputs(f.fit, "never", html="no")),
    ("write_outputs", "inputs", lambda f: cp.write_outputs(f.fit, "never", inputs=["a.csv"])),
    ("write_outputs", "notes", lambda f: cp.write_outputs(f.fit, "never", notes="x")),
    # a sensor's set-up record, checked once when made
    ("CableSetup", "anchor_mm", lambda f: cp.CableSetup(anchor_mm=(1, 2))),
    ("CableSetup", "tool_mm", lambda f: cp.CableSetup(tool_mm=NAN3)),
    ("CableSetup", "length_offset_mm", lambda f: cp.CableSetup(length_offset_mm="0")),
    ("CableSetup", "estimate", lambda f: cp.CableSetup(estimate="device")),
    ("PositionSetup", "estimate", lambda f: cp.PositionSetup(estimate=3)),
    ("PoseSetup", "noise_deg", lambda f: cp.PoseSetup(noise_deg=-1)),
    ("ContactSetup", "tool_mm", lambda f: cp.ContactSetup(tool_mm=(1, 2))),
    ("PoseModel", "rig", lambda f: cp.PoseModel(f.chain, f.params, "tracker")),
    ("ContactModel", "fixtures", lambda f: cp.ContactModel(f.chain, f.params, "cube")),
    ("calibrate", "setup", lambda f: cp.calibrate("irb120", f.small, method="lm", setup={"anchor_mm": (1, 2, 3)})),
]


class Fixtures:
    """The fixtures a case may use, as attributes."""

    def __init__(self, **kw):
        self.__dict__.update(kw)


@pytest.mark.parametrize(("entry", "argument", "call"), CASES,
                         ids=[f"{c[0]}-{c[1]}-{k}" for k, c in enumerate(CASES)])
def test_a_bad_argument_is_named(entry, argument, call, request):
    """The message names the argument, in one line, with no command-line flag (``--cv``)."""
    names = ("chain", "params", "small", "other", "positions", "two", "setup", "arm", "calibration", "fit")
    fixtures = Fixtures(**{name: request.getfixturevalue(name) for name in names if name in call.__code__.co_names})
    with pytest.raises(cp.CalibPinError) as caught:
        call(fixtures)
    message = str(caught.value)
    assert argument in message, message
    assert len(message.splitlines()) == 1, message
    assert not re.search(r"(?<![\w-])--[a-z]", message), message
    if isinstance(caught.value, ArgumentError):
        assert caught.value.argument == argument


def test_every_public_function_is_covered():
    """Each public callable of calib_pin.__all__ that takes arguments has a case (the
    error classes and plain records excepted; compare's own module is another slice's)."""
    exempt = {"ArgumentError", "CalibPinError", "DataError", "EstimatorError", "RobotError", "ESTIMATORS", "EstimateResult",
              "MeasurementSet", "Truth", "CalibrationResult", "Comparison", "Chain", "SetResult", "OutputError",
              "WrittenOutputs", "DHModel", "HayatiModel", "PlacementModel", "PositionDevice", "compare", "__version__"}
    exempt |= {"PoseRig", "Fixtures"}  # plain geometry records, as PositionDevice
    exempt |= {"Calibration", "Problem", "SetProblem"}  # made by prepare (checked there) and by the sensors
    covered = {c[0].split(".")[0] for c in CASES}
    assert set(cp.__all__) - exempt - covered == set()


def test_degrees_get_a_hint(chain, arm):
    with pytest.raises(ArgumentError, match="looks like degrees"):
        arm.forward(q_deg(chain))
    with pytest.raises(ArgumentError, match="looks like degrees"):
        as_angles_rad(np.full(6, 30.0), "q", chain)
    with pytest.raises(ArgumentError) as caught:  # just beyond a limit: refused, no hint
        as_angles_rad(np.r_[chain.upper[0] + 0.01, np.zeros(5)], "q", chain)
    assert "looks like degrees" not in str(caught.value) and "joint_1" in str(caught.value)


def test_valid_arguments_pass(chain, small):
    """What the validators accept: names as text or sequences, numbers as lists, radians."""
    assert as_names("anchor, offset", "estimate") == ("anchor", "offset")
    assert as_names(["anchor"], "estimate") == ("anchor",) and as_names(None, "estimate") == ()
    assert as_xyz_mm([1, 2, 3], "anchor_mm").tolist() == [1.0, 2.0, 3.0]
    assert as_array(np.arange(6, dtype=np.int32), "x", (6,)).dtype == float
    q = random_poses(chain, 3, np.random.default_rng(1))
    assert as_angles_rad(q, "q", chain) is not q and as_angles_rad(q[0], "q", chain).shape == (6,)
    result = cp.calibrate("irb120", small, method="lm", setup=cp.CableSetup(estimate="anchor"), seed=np.int64(2),
                          test_fraction=0)
    assert "anchor_x_mm" in result.sensor_corrections


def test_argument_error_carries_the_name():
    error = ArgumentError("q", "bad")
    assert error.argument == "q" and error.reason == "bad" and isinstance(error, cp.CalibPinError)
    assert str(error) == "argument q: bad"
    assert Path(cp.__file__).name == "__init__.py"


def test_a_negative_zero_is_zero(chain, params):
    """-0.0 passes 'noise >= 0' but numpy's normal() refused it (ValueError 'scale < 0'):
    a checked number is returned as +0.0."""
    from calib_pin.util.arguments import as_float

    assert str(as_float(-0.0, "noise_mm", 0.0)) == "0.0"
    data, _ = cp.simulate(chain, params, 5, seed=0, noise_mm=-0.0)
    assert len(data) == 5


@pytest.mark.parametrize("text", ["", ",,", " , "])
def test_names_that_name_nothing_are_refused(text):
    """Text given for names but naming none is a mistake (an empty shell variable, a
    stray comma), never "no names": --free '' meant every unknown free."""
    with pytest.raises(ArgumentError, match="names nothing"):
        as_names(text, "free")


IRB120 = cp.load_chain("irb120")


@pytest.mark.parametrize(("make", "arg", "says"), [
    (lambda: cp.CableSetup(tool_mm=(0, 0, -5000)), "tool_mm", "0,0,-5000 mm is 5000 mm from the end frame, beyond "
     "the 2000 mm a point may be (a unit mistake?)"),
    (lambda: cp.CableSetup(anchor_mm=(90000, 0, 0)), "anchor_mm", "90000,0,0 mm is 90000 mm from the base, beyond "
     "the 20000 mm"),
    (lambda: cp.ContactSetup(tool_mm=(0, 3000, 0)), "tool_mm", "3000 mm from the end frame"),
    (lambda: cp.Compliance("joint_2", payload_kg=1.0, payload_com_mm=(0, 0, 5000)), "payload_com_mm", "5000 mm"),
    (lambda: cp.simulate(IRB120, cp.parameter_model(IRB120), 5, 0, tool_mm=(0, 0, -5000)), "tool_mm", "5000 mm"),
])
def test_a_point_beyond_reach_is_refused_with_its_bound(make, arg, says):
    """A tool point (or a payload's centre of mass) over 2 m from the end frame, or an anchor
    over 20 m from the base, is a unit mistake: refused where it enters, naming the bound."""
    with pytest.raises(ArgumentError, match=re.escape(says)) as caught:
        make()
    assert caught.value.argument == arg
    assert cp.CableSetup(tool_mm=(0, 0, 1999), anchor_mm=(19000, 0, 0)).tool_mm.tolist() == [0, 0, 1999]


def test_an_argument_error_says_what_was_meant(small, setup, fit):
    """A whole number of folds given as ``holdout`` names Folds; a method's typo its nearest
    name; a set-up option given in both forms names both; calibrate's holdout sends to solve."""
    with pytest.raises(ArgumentError, match=r"calib_pin\.Folds\(5\)") as caught:
        cp.solve(setup, "lm", holdout=5)
    assert caught.value.argument == "holdout"
    with pytest.raises(ArgumentError, match="did you mean ekf-qibas") as caught:
        cp.calibrate("irb120", small, method="ekf_qibas")
    assert caught.value.argument == "method"
    with pytest.raises(ArgumentError, match=r"beside setup=CableSetup\(\.\.\.\)") as caught:
        cp.prepare("irb120", small, setup=cp.CableSetup(anchor_mm=(0, 0, 0)), anchor_mm=(600, 200, -100))
    assert caught.value.argument == "anchor_mm"
    with pytest.raises(ArgumentError, match=r"call calib_pin\.prepare, then calib_pin\.solve"):
        cp.calibrate("irb120", small, holdout=cp.Fraction(0.3))
    with pytest.raises(ArgumentError, match="500 folds for 30 training poses: give 2 to 30"):
        cp.solve(setup, "lm", holdout=cp.Folds(500))
    with pytest.raises(ArgumentError, match="looks like degrees"):
        fit.predict(np.full((2, 6), 30.0))
