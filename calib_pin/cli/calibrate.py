"""``calibrate``: a measurement set in; report.json, report.html and the corrected robot out.

The corrected robot goes out in the formats ``--export`` names (default ``urdf``):
``urdf`` (the input URDF with corrected joint origins), ``yaml`` (the corrected joint
origins for a xacro's ``xacro.load_yaml``; for ``ur*`` robots also ur_description's
``default_kinematics.yaml`` layout) and ``dh`` (the corrected DH table, dh and hayati
models). report.html is drawn from the report dict alone; without a working matplotlib
(the ``plots`` extra; a bad ``MPLBACKEND`` is replaced by Agg) a warning line on stderr
says so and the run writes everything else.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..analysis.metrics import Metrics
from ..estimators import DEFAULT_METHOD, ESTIMATORS
from ..report.build import accuracy_lines, noise_parts_line
from ..report.bundle import EXPORTS, check_exportable, write_outputs
from ..robot.description import MAX_LIMIT_MARGIN_DEG, robot_inputs
from ..sensors.setup import xyz_mm
from . import parse_args
from .common import (
    ROBOT_GROUP,
    add_compliance_arguments,
    add_loss_argument,
    add_model_argument,
    add_robot_arguments,
    add_test_fraction_argument,
    add_unknowns_arguments,
    compliance_options,
    count,
    fail,
    group,
    positive_float,
    run,
    unknowns_options,
    warn,
)
from .process import collecting


def export_formats(text: str) -> tuple[str, ...]:
    """Comma-separated export formats (``urdf,yaml,dh``)."""
    names = tuple(dict.fromkeys(n.strip() for n in text.split(",") if n.strip()))
    unknown = [n for n in names if n not in EXPORTS]
    if unknown or not names:
        raise argparse.ArgumentTypeError(
            f"unknown export format '{unknown[0] if unknown else text}' (valid: {', '.join(EXPORTS)}, comma-separated)")
    return names


def limit_margin(text: str) -> float:
    """``--limit-margin-deg``: a number of degrees in [0, 30]."""
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not 0.0 <= value <= MAX_LIMIT_MARGIN_DEG:
        raise argparse.ArgumentTypeError(f"expected a number of degrees in [0, {MAX_LIMIT_MARGIN_DEG:g}], got "
                                         f"'{text[:40]}'")
    return value + 0.0


def assumed_noise(text: str) -> float:
    """The sensor sigma the Kalman filters assume, [mm], in (0, 100]; 0 is refused with the reason.

    A filter that trusts a reading exactly divides by it; ``simulate --noise-mm 0`` makes a
    noise-free set, which calibrates with the default sigma.
    """
    try:
        if float(text) == 0:
            raise argparse.ArgumentTypeError(
                "0 is not a sensor sigma the Kalman filters can assume (they weigh each reading by 1/sigma^2): "
                "give the sensor's noise, e.g. 0.01, or leave it out for the file's (else estimated from the data)")
    except ValueError:
        pass
    return positive_float(100.0)(text)


def calibrate_parser() -> argparse.ArgumentParser:
    """The ``calib-pin calibrate`` subparser of the one parser (:func:`calib_pin.cli.parser`)."""
    from . import command_parser, parser

    return command_parser(parser(), "calibrate")


def add_calibrate_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """calibrate's arguments, added to its subparser ``p``; the shared groups from :mod:`.common`."""
    p.description = ("Calibrate a robot's kinematics from drawstring readings or marker positions and "
                     "write the corrected URDF and a JSON report.")
    add_robot_arguments(p, "default: the file's", "default: the file's")
    group(p, ROBOT_GROUP).add_argument(
        "--limit-margin-deg", type=limit_margin, metavar="DEG",
        help="accept measured angles up to DEG beyond each revolute joint's URDF limits (a controller that allows "
        f"more than its URDF says), in [0, {MAX_LIMIT_MARGIN_DEG:g}]; default 0: a row beyond them is refused")
    keys = ", ".join(f"{key} ({words})" for key, (_, words) in data_keys().items())
    p.add_argument("--data", action="append",
                   help="measurement set CSV (default: the robot's shipped set); repeat it to fit several sets "
                   "(sessions, anchors, tracker stations) with one robot: each file's own set-up metadata "
                   "(# anchor_mm, # tool_mm, # length_offset_mm, # noise_mm, # noise_deg) is used for its rows, "
                   f"unless its argument overrides it: FILE:key=value[:key=value...] with keys {keys}; "
                   "e.g. s2.csv:anchor_mm=600,200,-100:noise_mm=0.3")
    p.add_argument("--test-data", help="a separate validation session CSV: train on all of --data, test on this; "
                   "FILE (or FILE:same=LABEL): measured with the training set's sensor set-up (checked); "
                   "FILE:register=K: a new set-up (tracker moved, cable re-anchored), re-registered on K of its "
                   "poses (its first K; of a contact or marker file, one of each fixture or point in turn) with the "
                   "calibrated robot fixed, the other poses scored; FILE:register=role: on its rows whose role "
                   "column says 'register'")
    p.add_argument("--method", default=DEFAULT_METHOD, help=f"estimator: {', '.join(ESTIMATORS)} (default {DEFAULT_METHOD})")
    add_test_fraction_argument(p)
    p.add_argument("--out", default="out", help="output folder (default ./out)")
    p.add_argument("--noise-mm", type=assumed_noise,
                   help="sensor noise (1 sigma) for the Kalman filters, mm, > 0 (default: the file's, else estimated "
                   "from the residual of a first LM fit, printed and in report.json's noise_mm)")
    add_loss_argument(p)
    add_model_argument(p)
    add_compliance_arguments(p)
    add_unknowns_arguments(p, "; deviations are still written from the URDF")
    p.add_argument("--export", type=export_formats, default=("urdf",),
                   help="formats of the corrected robot, comma-separated: urdf (default), yaml (joint origins for "
                   "xacro.load_yaml; ur_description's default_kinematics.yaml too for ur* robots), dh (DH table TOML, "
                   "dh and hayati models)")
    p.add_argument("--tcp-mm", action="append", type=xyz_mm, metavar="X,Y,Z",
                   help="a point of the end frame you work with (a tool centre point), mm; repeat it for several: "
                   "the predicted accuracy is given there (default: the measured points, the end frame's origin "
                   "and a tool the data gives)")
    p.add_argument("--no-html", action="store_true", help="do not write DIR/report.html")
    p.add_argument("--cv", type=count(1000, lower=2), metavar="K",
                   help="also K-fold cross-validate the model on the training poses (split by pose): its held-out "
                   "error in the report and the printout")
    p.add_argument("--analyze", action="store_true",
                   help="only print the identifiability report of the data's poses, estimate nothing")
    return p


def calibrate_main(argv: Sequence[str] | None = None) -> int:
    """``calibrate.py ROBOT [--data CSV] [--method NAME] [--seed N] [--test-fraction F] [--out DIR]``."""
    args = parse_args("calibrate", argv)
    typed = list(sys.argv[1:] if argv is None else argv)
    if not any(a == "--test-fraction" or a.startswith("--test-fraction=") for a in typed):
        args.test_fraction = None  # the default share, or none beside --test-data (a share given there is refused)
    return run(lambda: _per_set_named(args, _analyze if args.analyze else _calibrate))


def _per_set_named(args: argparse.Namespace, action: Any) -> int:
    """``action(args)``, a refused per-set option named by its ``--data`` argument and key.

    A per-set option (``--data FILE:key=value``) that the library checks later (a value its
    record refuses, a key the file's sensor does not take, a role for the only set) is
    named by that argument and key, as the parse of :func:`data_argument` does, rather
    than the global flag (``--noise-deg``) or the library's argument (``noise_deg``) the
    user never typed.

    Raises:
        CalibPinError: ``action``'s, reworded for a per-set key given in one ``--data``.
    """
    from ..exceptions import ArgumentError, CalibPinError, DataError

    try:
        return action(args)
    except CalibPinError as e:
        try:
            typed = [(text, path, key) for text in args.data or () for path, options in [data_argument(text)]
                     for key in options]
        except CalibPinError:  # refused before its --data was read: the first error stands
            raise e from None
        for text, path, key in typed:
            if getattr(args, key, None) is not None:
                continue  # the global flag was given too: the library's message may be about it
            if (isinstance(e, ArgumentError) and e.argument == key) or \
                    (isinstance(e, DataError) and e.field == key and e.line is None and Path(e.path) == Path(path)):
                reason = e.reason
            elif isinstance(e, ArgumentError) and e.argument == "setup" and e.reason.startswith(f"{key} is for ") \
                    and f"{path} holds " in e.reason:
                reason = e.reason[len(key) + 1:]
            else:
                continue
            raise CalibPinError(f"--data '{text}': {key}: {reason}") from None
        raise


#: The keys a ``--data`` argument may carry besides its sensor's set-up fields.
SET_KEYS = ("noise_mm", "role", "label")


def data_keys() -> dict[str, tuple[Any, str]]:
    """Every key a ``--data`` argument takes, in order, with its value's parser and its help.

    The parser None: checked by :func:`data_argument` itself; the words for ``--help``:
    unit, the sensors whose sets take it. The keys are the sensors' set-up fields (every
    registered sensor's, but ``estimate``, a choice for every set), then :data:`SET_KEYS`.
    The one table both the parse and the help read.
    """
    from ..calibration.sets import ROLES
    from ..sensors import setup_types

    types = setup_types()
    keys: dict[str, tuple[Any, str]] = {}
    for t in types:
        for f in dataclasses.fields(t):
            if f.name == "estimate" or f.name in keys or "help" not in f.metadata:
                continue
            shape = "'x,y,z' " if "'x,y,z'" in f.metadata["help"] else ""
            takers = " and ".join(other.title for other in types if f.name in other.field_names())
            unit = f"{f.metadata['unit']}; " if f.metadata["unit"] else ""
            keys[f.name] = (f.metadata.get("parser"), f"{shape}{unit}{takers} sets")
    keys.update(noise_mm=(assumed_noise, "mm, in (0, 100]: the sensor sigma of the Kalman filters"),
                role=(None, ", ".join(ROLES)), label=(None, "a name for the printout and report.json"))
    return keys


def _file_options(text: str, flag: str, no_file: str, not_pair: str,
                  keys: Sequence[str] | None = None) -> tuple[str, list[tuple[str, str]]]:
    """Split ``FILE[:key=value[:key=value ...]]`` into the file and its (key, value) items.

    The whole argument when it is an existing file, else split at the first ':' whose left
    part is one. ``keys``: the valid keys (None: any; an unknown key is then named with the
    valid ones by the caller), each at most once.

    Raises:
        CalibPinError: naming ``flag``, the argument and the item (no file, not key=value,
            a key not in ``keys``, a key twice).
    """
    from ..exceptions import CalibPinError

    if ":" not in text or Path(text).is_file():
        return text, []
    cut = next((i for i, c in enumerate(text) if c == ":" and Path(text[:i]).is_file()), None)
    if cut is None:
        head, _, rest = text.partition(":")
        if "=" in rest.split(":")[0]:
            raise CalibPinError(f"{flag} '{text}': no file '{head}' ({no_file})")
        return text, []
    items: list[tuple[str, str]] = []
    for item in text[cut + 1:].split(":"):
        key, eq, value = (part.strip() for part in item.partition("="))
        if not eq or not key or (keys is not None and key not in keys):
            raise CalibPinError(f"{flag} '{text}': '{item}' is not {not_pair}")
        if key in dict(items):
            raise CalibPinError(f"{flag} '{text}': key '{key}' given twice")
        items.append((key, value))
    return text[:cut], items


def data_argument(text: str) -> tuple[str, dict[str, Any]]:
    """A ``--data`` argument ``FILE[:key=value[:key=value ...]]`` as (file, options).

    Split by :func:`_file_options`. Keys: :func:`data_keys` (the sensors' set-up fields,
    ``anchor_mm=600,200,-100``, then ``noise_mm``, ``role`` and ``label``); each value
    parsed as its flag's.

    Args:
        text: The argument as typed (lengths in [mm]).

    Raises:
        CalibPinError: naming the argument and the key (unknown, twice, bad value).
    """
    from ..calibration.sets import ROLES
    from ..exceptions import CalibPinError

    path, items = _file_options(text, "--data", "per-set options follow an existing file: FILE:key=value:key=value",
                                "key=value (FILE:key=value:key=value)")
    parsers = {key: parser for key, (parser, _) in data_keys().items()}
    options: dict[str, Any] = {}
    for key, value in items:
        if key not in parsers:
            raise CalibPinError(f"--data '{text}': unknown key '{key}' (valid: {', '.join(parsers)})")
        try:
            if key == "role" and value not in ROLES:
                raise argparse.ArgumentTypeError(f"expected one of {', '.join(ROLES)}, got '{value[:40]}'")
            if key == "label" and not value:
                raise argparse.ArgumentTypeError("an empty label")
            options[key] = parsers[key](value) if parsers[key] else value
        except argparse.ArgumentTypeError as e:
            raise CalibPinError(f"--data '{text}': {key}: {e}") from None
    return path, options


def validation_argument(text: str | None) -> Any:
    """A ``--test-data`` argument ``FILE[:register=K|role][:same=LABEL]`` as the library's test_data.

    The file, or a :class:`~calib_pin.calibration.validation.TestSet` with its choice
    (split by :func:`_file_options`).

    Args:
        text: The argument as typed, or None (not given).

    Raises:
        CalibPinError: naming the argument and the key (unknown, twice, bad value).
    """
    from ..calibration.holdout import TestSet
    from ..exceptions import CalibPinError

    if text is None:
        return None
    path, items = _file_options(text, "--test-data", "its choice follows an existing file: FILE:register=K",
                                "register=K, register=role or same=LABEL", keys=("register", "same"))
    if not items:
        return path
    options: dict[str, Any] = {}
    for key, value in items:
        if key == "register" and value != "role":
            if not value.isdigit() or int(value) < 1:
                raise CalibPinError(f"--test-data '{text}': register: expected a number of poses >= 1 or 'role', "
                                    f"got '{value[:40]}'")
            options[key] = int(value)
        else:
            if not value:
                raise CalibPinError(f"--test-data '{text}': {key}: an empty value")
            options[key] = value
    if "register" in options and "same" in options:
        raise CalibPinError(f"--test-data '{text}': register (a new set-up) or same (the training set's), not both")
    return TestSet(path, **options)


def _fit_set(path: str, options: dict[str, Any]) -> Any:
    from ..calibration.sets import FitSet
    from ..sensors import setup_record

    fields = {k: v for k, v in options.items() if k not in SET_KEYS}
    return FitSet(path, label=options.get("label", ""), role=options.get("role", "split"),
                  noise_mm=options.get("noise_mm"), setup=setup_record(**fields) if fields else None)


def _data(args: argparse.Namespace) -> Any:
    """``--data`` as ``prepare`` takes it: None, one file, or a list of several.

    Several are FitSets with the per-set options of ``FILE:key=value``.

    Raises:
        CalibPinError: a drawstring set-up option given once for several sets, a bad
            per-set option.
    """
    parsed = [data_argument(d) for d in args.data or ()]
    if len(parsed) == 1 and not parsed[0][1]:
        return parsed[0][0]
    if not parsed:
        return None
    from ..exceptions import CalibPinError
    from ..sensors import setup_from_args
    from ..sensors.setup import flag_of

    shared = {**setup_from_args(args), "noise_mm": args.noise_mm}
    for name, value in shared.items():
        if len(parsed) > 1 and name not in ("estimate", "noise_mm") and value is not None:  # each set has its own
            raise CalibPinError(f"{flag_of(name)} with several --data files: put each set's in its file "
                                f"('# {name}: ...') or its --data argument (FILE:{name}=...)")
    for text, (path, options) in zip(args.data, parsed, strict=True):
        both = [name for name in options if shared.get(name) is not None]
        if both:  # one would be dropped without a word
            raise CalibPinError(f"--data '{text}' and {flag_of(both[0])} both give {both[0]} of {path}: give one")
    return [_fit_set(path, options) for path, options in parsed]


def _data_files(args: argparse.Namespace) -> list[Any]:
    """The files of ``--data`` (without their per-set options); [None] without it."""
    return [data_argument(d)[0] for d in args.data] if args.data else [None]


def _setup_options(args: argparse.Namespace) -> dict[str, Any]:
    from ..sensors import setup_from_args, setup_record

    return {"end_frame": args.end_frame, "setup": setup_record(**setup_from_args(args)), "noise_mm": args.noise_mm,
            "parameters": args.model, "limit_margin_deg": args.limit_margin_deg, **compliance_options(args),
            **unknowns_options(args), **({"tcp_mm": args.tcp_mm} if getattr(args, "tcp_mm", None) else {})}


def _analyze(args: argparse.Namespace) -> int:
    from ..analysis.identifiability import analyze
    from ..calibration.prepare import prepare

    calibration = prepare(args.robot, _data(args), **_setup_options(args))
    _notes_of_sets(calibration, args)
    data = calibration.data
    print(f"{calibration.chain.name}: {data.describe_rows()} from {data.source}, "
          f"{calibration.params.name} model, {calibration.problem.model.describe()}")
    x, where = analysis_point(calibration)
    print(f"analysed at {where}")
    print(analyze(calibration.problem, x, fixed=calibration.fixed).report())
    print(determined_line(calibration, x))
    print("a calibration keeps the robot at "
          f"{'the start' if calibration.start is not None else 'zero'} along the blind directions above (and along "
          "those it sees less than the noise); the sensor's unknowns take the rest (docs: accuracy.md)")
    return 0


def determined_line(calibration: Any, x: Any) -> str:
    """What the poses determine of the robot's deviations at x, with the stated (or default)
    noise and the prior: the printout's ``deviations:`` line before any fit."""
    import numpy as np

    from ..analysis.determined import determined
    from ..analysis.uncertainty import estimate_uncertainty

    problem = calibration.problem
    held = [problem.model.names.index(n) for n in calibration.fixed]
    free = np.setdiff1d(np.arange(problem.n_params), held)
    split = determined(problem, x, free, calibration.prior, calibration.noise)
    u = estimate_uncertainty(problem, x, split, held=tuple(held))
    robot = range(problem.model.sensor_start)
    status = [u.status[i] for i in robot]
    unseen = [u.names[i] for i in robot if u.status[i] == "not determined"]
    combos = "; ".join(c.text for c in u.combinations) or "none"
    unit = problem.model.first.value_unit  # the first set's noise, in its unit (a camera's: px)
    return (f"at {calibration.noise * 1e3:.3g} {unit} noise (stated, else the default) and the prior "
            f"{calibration.prior.describe()}: {status.count('identified')} of {len(status)} deviations determined "
            f"alone; only in combination: {combos}; not determined: {', '.join(unseen) or 'none'}")


def _notes_of_sets(calibration: Any, args: argparse.Namespace, ignored: bool = True) -> None:
    """Warn of what was read of each set but is not as its file says: its ignored columns
    (``ignored``), the rows --limit-margin-deg accepted beyond the URDF's joint limits."""
    from ..measurements.checks import beyond_urdf_limits

    for s in calibration.sets:
        note = s.data.ignored_note() if ignored else None
        if note:
            warn(note)
        rows = beyond_urdf_limits(calibration.chain, s.data)
        if rows:
            shown = "; ".join(rows[:5]) + (f"; and {len(rows) - 5} more" if len(rows) > 5 else "")
            warn(f"{len(rows)} row(s) of {Path(s.data.source or s.label).name} beyond the URDF's joint limits, "
                 f"accepted by --limit-margin-deg {args.limit_margin_deg:g}: {shown}", "note")


def analysis_point(calibration: Any) -> tuple[Any, str]:
    """Where ``--analyze`` analyses the data's poses, SI units (n_params,), and its words.

    Zero deviations (the catalogue URDF), or with ``--nominal`` the start a calibration
    would take (:meth:`~calib_pin.calibration.start.Start.x0`, the sensor's geometry fitted
    to every row with the robot held there).
    """
    import numpy as np

    problem, start = calibration.problem, calibration.start
    if start is None:
        return np.zeros(problem.n_params), "zero deviations (the catalogue URDF; --nominal analyses at a start)"
    return start.x0(problem, problem), (f"the start {start.describe()}: its robot deviations, the sensor geometry "
                                        "fitted to every row with the robot held there")


def table(metrics: dict[str, dict[str, Metrics]], unit: str = "mm") -> str:
    """The before/after metrics as a fixed-width table, in ``unit`` (the row errors', mm)."""
    lines = [f"{'':14s}{'RMSE ' + unit:>10s}{'mean ' + unit:>10s}{'max ' + unit:>10s}"]
    for split, stages in metrics.items():
        for stage, m in stages.items():
            lines.append(f"{split + ' ' + stage:14s}{m.rmse_mm:10.4f}{m.mean_mm:10.4f}{m.max_mm:10.4f}")
    return "\n".join(lines)


def _check_dh_export(args: argparse.Namespace) -> None:
    """Refuse ``--export dh`` for the placement model before any work is done."""
    if "dh" not in args.export:
        return
    from ..exceptions import CalibPinError
    from ..robot.description import resolve_robot

    model = args.model or ("dh" if resolve_robot(args.robot).dh is not None else "placement")
    if model == "placement":
        raise CalibPinError("the placement model has no DH table: --export dh needs --model dh or hayati "
                            "and a robot with a DH table (urdf and yaml work for every model)")


def _calibrate(args: argparse.Namespace) -> int:
    from ..calibration.holdout import Folds, Fraction, as_holdout
    from ..calibration.prepare import prepare
    from ..calibration.solve import method_record, solve
    from ..calibration.start import start_file
    from ..exceptions import CalibPinError

    _check_dh_export(args)
    method = method_record(args.method, args.loss)  # a bad method or loss before the data is read
    holdout = as_holdout(args.test_fraction, validation_argument(args.test_data))
    calibration = prepare(args.robot, _data(args), **_setup_options(args))
    check_exportable(args.export, calibration.chain, method.kinematic)  # where the end frame entered, not after the fit
    _notes_of_sets(calibration, args, ignored=False)  # the ignored columns: with the result's warnings
    if args.cv:
        if not isinstance(holdout, Fraction):
            raise CalibPinError("--cv cross-validates the training poses of a split: leave --test-data out")
        holdout = Folds(args.cv, holdout.test_fraction)
    _announce(calibration)
    result = solve(calibration, method, holdout=holdout, seed=args.seed, loss=args.loss)
    data = _data_files(args)  # --data may be given once per set
    sets = {"--data": data[0]} if len(data) == 1 else {f"--data #{k}": d for k, d in enumerate(data, 1)}
    test_file = validation_argument(args.test_data)
    inputs = {**robot_inputs(args.robot), **sets, "--test-data": getattr(test_file, "data", test_file),
              "--nominal": start_file(args.nominal) if args.nominal is not None else None,  # a folder's file
              **_lens_files(args)}
    # an input in --out is never replaced, nor removed as stale; all files together or none
    # report.html draws figures per set, which only the collector frees: on for several sets
    # (one set's take bounded memory, and the collector's passes over matplotlib take time)
    with collecting() if len(result.sets) > 1 else contextlib.nullcontext():
        done = write_outputs(result, Path(args.out), args.export, html=not args.no_html, inputs=inputs,
                             silence="--no-html silences this")
    report = done.report
    _summary(result, report)  # a refused fit still shows what was computed, then the refusal
    if done.removed:  # an earlier run's exports would pass for this fit's
        names = ", ".join(str(p) for p in done.removed[:4]) + (", ..." if len(done.removed) > 4 else "")
        warn(f"removed {len(done.removed)} file(s) an earlier run wrote in {done.folder}, which this fit does not "
             f"write: {names}", "note")
    if done.refused:
        return fail(f"{done.refused} (report: {done.folder / 'report.json'})")
    for note in done.notes:
        warn(note, "note")
    for path in done.files:
        print(f"wrote {path}")
    return 0


def _lens_files(args: argparse.Namespace) -> dict[str, str]:
    """The lens files read (``--intrinsics FILE.yaml``, ``--data FILE:intrinsics=FILE.yaml``), by label: inputs."""
    given: list[tuple[str, Any]] = [("--intrinsics", getattr(args, "intrinsics", None))]
    given += [(f"--data '{text}'", data_argument(text)[1].get("intrinsics")) for text in args.data or ()]
    sources = [(label, getattr(k, "source", None)) for label, k in given]
    return {label: source.path for label, source in sources if source is not None}


#: Rows from which a calibration is announced on stderr before it starts (it may take minutes).
LONG_ROWS = 5000


def _announce(calibration: Any) -> None:
    rows = len(calibration.data)
    if rows >= LONG_ROWS:
        print(f"calibrating {rows} rows with {calibration.problem.n_params} unknowns; "
              "this can take minutes (Ctrl-C stops, writing nothing)", file=sys.stderr, flush=True)


#: A stiffness beyond this [Nm/rad] (a compliance below 0.001 urad/Nm) prints as rigid.
RIGID_NM_PER_RAD = 1e9


def compliance_cells(soft: dict[str, Any]) -> str:
    """The compliances of report.json's ``compliance`` section for people: [urad/Nm] and [Nm/rad].

    The stiffness is in Nm/rad; a joint at zero is rigid (its stiffness is infinite, JSON null).
    """
    if soft.get("compliance_model") == "basis":
        return basis_cells(soft)
    bounded = set(soft.get("bounded_at_zero", ()))
    cells = []
    for joint, c in soft["compliance_rad_per_Nm"].items():
        k = soft["stiffness_Nm_per_rad"].get(joint)
        stiff = f"stiffness {k:.3g} Nm/rad" if k is not None and k < RIGID_NM_PER_RAD else "rigid"
        cells.append(f"{joint} {c * 1e6:.1f} urad/Nm ({stiff}{', bounded at zero' if joint in bounded else ''}"
                     f"{_effect(soft, joint)})")
    return ", ".join(cells)


def _effect(soft: dict[str, Any], joint: str) -> str:
    """``; peak 512 urad, 0.31 mm at the end frame`` of a joint over the data."""
    peak, moved = soft.get("peak_deflection_urad", {}), soft.get("end_frame_effect_mm", {})
    if joint not in peak:
        return ""
    return f"; peak {peak[joint]:.0f} urad, {moved[joint]:.3f} mm at the end frame"


def basis_cells(soft: dict[str, Any]) -> str:
    """The gravity basis model's joints for people: terms, peak deflection and end-frame effect."""
    cells = []
    for joint, n in soft["basis_terms"].items():
        lifted = ", against gravity" if joint in soft.get("against_gravity", ()) else ""
        cells.append(f"{joint} {n} terms{lifted}{_effect(soft, joint)}")
    return "gravity basis model (no inertias): " + ", ".join(cells)


def part_table(errors_by_part: dict[str, dict[str, dict[str, dict[str, float]]]]) -> str:
    """Each part of a row in its own unit, side by side (``errors_by_part`` of a report)."""
    first = next(iter(errors_by_part.values()))
    parts = [key.rsplit("_", 1) for key in next(iter(first.values()))]  # (name, unit) each
    lines = [f"{'':14s}" + "".join(f"{name + ' RMSE ' + unit:>26s}{'max ' + unit:>10s}" for name, unit in parts)]
    for split, stages in errors_by_part.items():
        for stage, by_part in stages.items():
            cells = [by_part[f"{name}_{unit}"] for name, unit in parts]
            lines.append(f"{split + ' ' + stage:14s}" + "".join(
                f"{c['rmse_' + unit]:26.4f}{c['max_' + unit]:10.4f}" for c, (_, unit) in zip(cells, parts, strict=True)))
    return "\n".join(lines)


def _header(result: Any, report: dict[str, Any]) -> None:
    """The run in one line, what a row's error is, and the tables.

    Each set's table with several sets, then every set's rows together (of one set: its own).
    """
    from ..analysis.metrics import pooled_unit, units_words

    several = len(result.sets) > 1
    if several:
        split = (f"{len(result.train)} train rows (every row of every set), test rows from {result.test_source}"
                 if result.test_source else f"{len(result.train)} train and {len(result.test)} test rows "
                 f"(split per set by pose, seed {result.seed})")
        print(f"{result.chain.name}: {len(result.sets)} sets, {split}, {result.model_name} model, "
              f"method {result.method}")
    else:
        test = f"test rows from {result.test_source}" if result.test_source else f"{len(result.test)} test rows"
        print(f"{result.chain.name}: {result.data.describe_rows()} from {result.data.source} "
              f"({len(result.train)} train, {test}, seed {result.seed}), {result.model_name} model, "
              f"method {result.method}")
    parts = report.get("errors_by_part") if not several else None
    print("error per row: each part in its own unit (position of the measured body, orientation)" if parts
          else f"error per row: {result.problem.model.error_name}")
    for s, doc in zip(result.sets, report["sets"], strict=True) if several else ():
        rows = len(s.train) + len(s.test)
        print(f"set {s.label}: {rows} rows from {s.source or 'memory'} ({len(s.train)} train, {len(s.test)} test, "
              f"role {s.role}), noise {s.sigma * 1e3:.4f} {s.unit} ({s.sigma_origin}){_override_note(s)}")
        print(part_table(doc["errors_by_part"]) if "errors_by_part" in doc else table(s.metrics, s.unit))
    info = result.test_registration or {}
    if not several:
        if info.get("setup") == "new":
            print(_registration_line(info, several, value_unit_of(result, info)))
        print(part_table(parts) if parts else table(result.metrics, result.sets[0].unit))
        return
    unit = pooled_unit(result.sets)
    pooled = {split: stages for split, stages in result.metrics.items() if split != "test" or not result.test_source}
    if unit is None:
        print(f"all sets: no table, {units_words(result.sets)}")
    elif pooled:
        print(f"all sets ({units_words(result.sets)}):")
        print(table(pooled, unit))
    if result.test_source:  # a separate validation session, scored apart from the sets
        how = (f"the set-up of set {info['same_as']} (as calibrated; nothing fitted on it)"
               if info.get("setup") == "same" else _registration_line(info, several, value_unit_of(result, info)))
        print(f"validation session {result.test_source}: {how}")
        print(table({"test": result.metrics["test"]}, value_unit_of(result, info)))


def _registration_line(info: dict[str, Any], several: bool, unit: str = "mm") -> str:
    """How a validation session on a new set-up was re-registered and scored (its errors in ``unit``)."""
    if several:
        return (f"a new set-up, {len(info['registered_rows'])} rows re-registered it ({info['registered_on']}; "
                f"fitted {', '.join(info['fitted'])} with the calibrated robot fixed, RMS "
                f"{info['registration_rmse_mm']:.4f} {unit}); the other {len(info['scored_rows'])} rows scored")
    lines = info["registered_lines"]
    where = f" (file lines {lines[0]}-{lines[-1]})" if lines and info["registered_on"][0] == "f" else ""
    return (f"validation on a new set-up: {len(info['registered_rows'])} rows{where} re-registered it "
            f"({info['registered_on']}; fitted {', '.join(info['fitted'])} with the calibrated robot "
            f"fixed, RMS {info['registration_rmse_mm']:.4f} {unit}); the other "
            f"{len(info['scored_rows'])} rows are the test rows (rows in report.json)")


def value_unit_of(result: Any, info: dict[str, Any]) -> str:
    """The unit of a validation session's errors: the set's whose sensor scored it."""
    label = info.get("same_as") or info.get("sensor_model_of")
    return next((s.unit for s in result.sets if s.label == label), "mm")


def _override_note(s: Any) -> str:
    """``, anchor_mm from the command line (over the file's)`` of a set with per-set options."""
    if not s.overrides:
        return ""
    over = " (over the file's)"
    return "".join(f", {n} from the command line{over if n in s.overridden else ''}" for n in s.overrides)


def _summary(result: Any, report: dict[str, Any]) -> None:
    _header(result, report)
    if "noise_by_part" in report:  # each part's own sigma (stated, or estimated from the residual)
        print(noise_parts_line(report["noise_by_part"]))
    shown = ", ".join(f"{k} {v:+.3f}" for k, v in result.sensor_corrections.items() if not k.startswith("marker"))
    if result.sensor_corrections:
        print(f"sensor geometry estimated: {shown or 'marker points'} (corrections; all in report.json)")
    for note in dict.fromkeys(s["gauge_note"] for s in report["sets"] if "gauge_note" in s):  # a hand-eye's gauge
        print(f"gauge: {note}")
    named = len(result.sets) > 1
    prefits = [(f"set {s['label']}: " if named else "", s["setup_prefit"]) for s in report["sets"] if "setup_prefit" in s]
    for where, prefit in prefits:
        print(f"sensor set-up: {where}{prefit['summary']} ({prefit['how']}); then estimated with the "
              "robot (report.json)")
    soft = report.get("compliance")
    if soft:
        print(f"joint compliance ({soft.get('compliance_model', 'cad')} model): {compliance_cells(soft)}; "
              "deflection is not in the URDF")
    if result.noise_from.startswith("estimated") and len(result.sets) == 1:  # the Kalman filters got the data's
        print(f"noise for {result.method}: {result.noise * 1e3:.4f} mm per value, {result.noise_from}")
    cv = report.get("cross_validation")
    if cv:
        cells = ", ".join(f"{k.removesuffix('_mm')} {cv[k]['mean']:.4f} ± {cv[k]['sd']:.4f}"
                          for k in ("rmse_mm", "mean_mm", "max_mm"))
        print(f"{cv['folds']}-fold cross-validation on the training poses (held-out mm): {cells}")
    est = result.estimate
    print(f"estimation: {est.time_s:.3f} s, {est.iterations} iterations ({est.message})")
    if report.get("accuracy"):
        print("\n".join(accuracy_lines(report["accuracy"])))
    u = report["uncertainty"]
    if u:
        robot = [k for k in report["deviations"]] + [k for k in report.get("compliances", {})]
        status = [u["parameters"][k]["status"] for k in robot if k in u["parameters"]]
        unseen = [k.rsplit("_", 1)[0] for k in robot if u["parameters"].get(k, {}).get("status") == "not determined"]
        start = "the start" if result.start is not None else "zero"
        print(f"deviations: {status.count('identified')} of {len(status)} determined by the data, "
              f"{status.count('combination')} only in {len(u['combinations'])} combination(s) (report.json), "
              f"not determined (held at {start}): {', '.join(unseen) or 'none'}")
    if result.start is not None:
        print(f"start: {result.start.describe()}; 'before' is the start's error, the deviations "
              "(report.json) are from the catalogue URDF, deviations_from_start from the start")
    if report.get("fixed"):
        print(f"fixed (held at their nominal value, --fix/--free): {', '.join(report['fixed'])}")
    if result.loss != "linear":
        print(f"outliers ({result.loss} loss): {len(result.outlier_rows)} training rows, {_outlier_lines(report)}")
    after, before = (result.metrics["train"][stage] if "train" in result.metrics else None
                     for stage in ("after", "before"))
    if after is not None and before is not None and after.rmse_mm > before.rmse_mm:
        warn("the calibrated model fits the training poses worse than the nominal one")
    for warning in report["warnings"]:  # the result's own, and the report's (rank, bounded compliances)
        warn(warning)
    if not result.kinematic:
        print(f"no URDF written: {result.method} learns a correction of the measured values, which a URDF cannot hold")


def _outlier_lines(report: dict[str, Any]) -> str:
    """Where the outliers are: ``file lines 16, 19``, or with several sets each set's.

    With several sets: ``mix_1 line 16; mix_2 lines 19, 20``; a line number alone does not
    name its file.
    """
    lines, sets = report["outlier_lines"], report.get("outlier_sets")
    if not lines:
        return "file lines none"
    if not sets:
        return "file lines " + ", ".join(str(line) for line in lines)
    by_set: dict[str, list[int]] = {}
    for label, line in zip(sets, lines, strict=True):
        by_set.setdefault(label, []).append(line)
    return "; ".join(f"{label} line{'s' if len(found) > 1 else ''} {', '.join(map(str, found))}"
                     for label, found in by_set.items())
