"""The identifiability report names what one cable can and cannot see."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.analysis.identifiability import analyze
from calib_pin.sensors import setup_record

ROOT = Path(__file__).resolve().parent.parent


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


# --- issue 20: rank deficiency is normal; only a set that cannot calibrate anything is refused


def _calibrate_cli(tmp_path, capfd, name: str, text: str, *args: str):
    import json

    from calib_pin.cli.calibrate import calibrate_main

    data, out = tmp_path / name, tmp_path / "o"
    data.write_text(text)
    code = calibrate_main([*args, "--data", str(data), "--method", "lm", "--no-html", "--out", str(out)])
    printed = capfd.readouterr()
    report = json.loads((out / "report.json").read_text())
    return code, printed, report, out


@pytest.mark.parametrize(("robot", "maker", "args", "rank", "unknowns"), [
    ("irb120", "small_wrist_cable", ("--estimate", "anchor,offset"), 10, 28),
    ("ur5", "ur5_grid", ("--model", "placement"), 25, 51),
], ids=["cable-small-wrist", "ur5-placement"])
def test_rank_deficient_sets_calibrate_near_the_noise_floor(tmp_path, capfd, robot, maker, args, rank, unknowns):
    """The two sets the old "half the unknowns" rule refused: the identifiable subspace is
    fitted, one warning line names the rank, every output is written and the held-out error
    is within 1.5x the sensor noise."""
    import simulated_sets

    code, printed, report, out = _calibrate_cli(tmp_path, capfd, "d.csv", getattr(simulated_sets, maker)(),
                                                robot, *args)
    assert code == 0, printed.err
    warning = [line for line in printed.err.splitlines() if "identify only" in line]  # a warning: on stderr
    assert warning == [f"warning: the training poses identify only {rank} of {unknowns} directions: "
                       "the blind directions stay at zero (--analyze lists them)"]
    assert report["identifiability"]["rank"] == rank and report["identifiability"]["unknowns"] == unknowns
    assert (out / f"{robot}_calibrated.urdf").is_file() and (out / f"{robot}_calibration.json").is_file()
    noise = simulated_sets.NOISE_MM * (np.sqrt(3) if robot == "ur5" else 1.0)  # a position's error has 3 axes
    assert report["test"]["after"]["rmse_mm"] < 1.5 * noise
    assert report["test"]["before"]["rmse_mm"] > 20 * noise


def test_support_error_refuses_only_what_cannot_calibrate():
    """One distinct pose cannot calibrate anything; two distinct poses calibrate two directions;
    a sensor that takes every direction the poses give leaves the robot none."""
    from calib_pin.analysis.identifiability import support_error

    setup = cp.prepare("irb120")
    same = setup.problem.subset(np.zeros(50, dtype=int))
    assert "1 distinct pose" in support_error(same)
    assert support_error(setup.problem.subset(np.array([0, 1] * 20))) is None
    sensor = cp.prepare("irb120", setup=setup_record(estimate=("anchor", "offset"))).problem.subset(np.arange(3))
    assert "the sensor's own unknowns" in support_error(sensor)


@pytest.mark.parametrize("method", ["ekf-qibas", "rbf", "pso"])
def test_a_set_that_calibrates_nothing_is_refused_by_the_library_before_any_estimate(method):
    """Identical poses: every method, through the library, refuses before it estimates (the
    search methods used to divide by the zero cost of a perfect fit; rbf returned a result)."""
    import calib_pin as cp

    data = cp.read_measurements(ROOT / "robots" / "irb120_default.csv")
    same = dataclasses.replace(data, q=np.repeat(data.q[:1], len(data), axis=0), values=np.repeat(data.values[:1], len(data)))
    with pytest.raises(cp.CalibPinError, match="1 distinct pose"):
        cp.calibrate("irb120", same, method=method)


def _as_fields(ident):
    """An Identifiability as comparable values (arrays as bytes)."""
    return {f.name: (v.tobytes() if isinstance(v, np.ndarray) else v)
            for f in dataclasses.fields(ident) for v in [getattr(ident, f.name)]}


def test_the_shared_jacobian_and_svd_give_the_analysis_made_afresh():
    """The support check and the report's analysis share one Jacobian and SVD (issue 24):
    the analysis after the check is the one made with nothing kept, to the bit; another
    set's analysis is its own."""
    from calib_pin.analysis import identifiability as ident

    setup = cp.prepare("irb120")
    training = setup.problem.subset(np.arange(0, len(setup.data), 2))
    ident._LAST_JACOBIAN.clear()
    ident._LAST_SVD.clear()
    fresh = _as_fields(analyze(training))
    ident._LAST_JACOBIAN.clear()
    ident._LAST_SVD.clear()
    assert ident.support_error(training) is None
    again = analyze(setup.problem.subset(np.arange(0, len(setup.data), 2)))  # another object, the same rows
    assert _as_fields(again) == fresh
    other = analyze(setup.problem.subset(np.arange(1, len(setup.data), 2)))
    assert other.singular_values.tobytes() != again.singular_values.tobytes()
    ident._LAST_JACOBIAN.clear()
    ident._LAST_SVD.clear()
    assert _as_fields(analyze(setup.problem.subset(np.arange(1, len(setup.data), 2)))) == _as_fields(other)
    held = analyze(training, fixed=("theta_6",))  # columns left out: the SVD of the kept ones
    assert "theta_6" not in held.names and held.rank == fresh["rank"]


def test_an_analysis_from_the_kept_svd_is_the_callers_own():
    """An analysis made from the kept Jacobian and SVD gives writable arrays of its own
    (review of issue 24: a repeat analysis handed back the memo's read-only arrays)."""
    setup = cp.prepare("irb120")
    first = analyze(setup.problem)
    again = analyze(setup.problem)
    assert again.singular_values.tobytes() == first.singular_values.tobytes()
    again.singular_values[:] = 0.0  # the caller's own array
    assert analyze(setup.problem).singular_values.tobytes() == first.singular_values.tobytes()


def _terms(line: str) -> dict[str, float]:
    """``{'d_2': 1.0, 'd_3': -1.0}`` of a combination line ``d_2 +1 mm with d_3 -1 mm``."""
    return {name: float(value) for name, value, _ in (term.split() for term in line.split(" with "))}


#: The problems :func:`_start_case` makes: shipped robots and sets, UR5 sets simulated.
START_CASES = ("irb120 shipped", "irb120 wu2015", "irb120 contact", "ur5 cable", "ur5 position")


def _start_case(name: str):
    """(problem, a start near zero) of ``name``: the IRB120's shipped drawstring set, the
    real Wu set and the contact example, each at a seeded draw of half the typical
    deviations; a UR5 drawstring and position set simulated, at their true deviations."""
    robot, kind = name.split()
    if robot == "irb120":
        data = {"shipped": None, "wu2015": ROOT / "robots" / "irb120_wu2015.csv",
                "contact": ROOT / "robots" / "irb120_contact_example.csv"}[kind]
        problem = cp.prepare(robot, data).problem
        n = problem.model.n_robot
        x = np.zeros(problem.n_params)
        x[:n] = 0.5 * np.random.default_rng(7).standard_normal(n) * problem.model.scale[:n]
        return problem, x
    chain = cp.load_chain("ur5")
    data, truth = (cp.simulate if kind == "cable" else cp.simulate_positions)(chain, cp.parameter_model(chain), 40,
                                                                                seed=3)
    problem = cp.prepare("ur5", data).problem
    x = np.zeros(problem.n_params)
    x[:problem.model.n_robot] = truth.x
    return problem, x


@pytest.mark.parametrize("name", START_CASES)
def test_combinations_at_a_start_near_zero_are_those_at_zero(name):
    """At a start near zero (a --nominal calibration) an exact degeneracy of zero deviations
    is only slightly broken: the combinations read the same (the same parameters, the same
    coefficients to the printed digits or nearly), none with the huge coefficients an RREF
    pivoting on such a sliver printed (theta_6 -6e16 mrad); a parameter blind at zero (a
    zero column) stays among the parameters not identifiable."""
    problem, x = _start_case(name)
    at_zero, at_start = analyze(problem), analyze(problem, x)
    assert at_start.rank == at_zero.rank
    zero, start = [_terms(c) for c in at_zero.combinations], [_terms(c) for c in at_start.combinations]
    assert len(start) == len(zero) + len(at_zero.unidentifiable) - len(at_start.unidentifiable)
    for line in zero + start:
        assert max(abs(v) for v in line.values()) <= 1 / 0.05 * 2 + 1e-9, line  # below 1/tol typical sizes
    for line in zero:
        match = next((s for s in start if set(s) == set(line)), None)
        assert match is not None, (line, at_start.combinations)
        for k, v in line.items():
            assert match[k] == pytest.approx(v, rel=0.1, abs=0.02), (line, match)
    blind = [s for s in start if not any(set(s) == set(z) for z in zero)]
    assert all(len(s) == 1 and next(iter(s)) in at_zero.unidentifiable for s in blind), blind
    # A parameter blind at zero (a zero column) stays named blind at the start, where its
    # column is a sliver: a null direction of its own, not a "combination" of one.
    assert at_start.unidentifiable == at_zero.unidentifiable
    assert all(len(line) > 1 for line in zero + start)


def test_analyze_nominal_analyses_at_the_start_and_says_so(tmp_path, capsys):
    """calibrate --analyze --nominal FILE analyses the data's poses at that start (the
    start's deviations, the sensor fitted there), and the printout says where; without
    --nominal at zero deviations, as before."""
    from calib_pin.cli import main
    from calib_pin.cli.calibrate import analysis_point

    assert main(["calibrate", "irb120", "--method", "lm", "--no-html", "--out", str(tmp_path)]) == 0
    start = tmp_path / "irb120_calibration.json"
    capsys.readouterr()
    assert main(["calibrate", "irb120", "--analyze", "--nominal", str(start)]) == 0
    out = capsys.readouterr().out
    assert "analysed at the start irb120_calibration.json (calib-pin calibration file)" in out
    setup = cp.prepare("irb120", nominal=str(start))
    x, _ = analysis_point(setup)
    assert np.array_equal(x[:setup.problem.model.n_robot], setup.start.robot_x) and np.any(x != 0)
    assert analyze(setup.problem, x).report() in out
    assert analyze(setup.problem).report() not in out  # not the analysis at zero
    assert "d_2 +1 mm with d_3 -1 mm" in out and "e+" not in out
    assert main(["calibrate", "irb120", "--analyze"]) == 0
    out = capsys.readouterr().out
    assert "analysed at zero deviations" in out and analyze(setup.problem).report() in out
