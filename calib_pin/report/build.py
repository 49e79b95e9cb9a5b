"""The report of a calibration: one JSON-ready dict, the one source of every number shown.

The numbers are those ``report.json``, the console summary and the HTML report show.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ..estimators.subspace import RCOND

if TYPE_CHECKING:
    from ..calibration.result import CalibrationResult


def _metrics(result: CalibrationResult) -> dict[str, Any]:
    return {split: {stage: m.as_dict() for stage, m in stages.items()} for split, stages in result.metrics.items()}


def _estimate(result: CalibrationResult) -> dict[str, Any]:
    est = result.estimate
    return {
        "time_s": est.time_s,
        "iterations": est.iterations,
        "stages": est.stages,
        "evaluations": est.nfev,
        "success": est.success,
        "stop_reason": est.message,
        "train_rmse_history_mm": [h * 1e3 for h in est.history],
        "history_evaluations": list(est.evaluations),
        # the iteration each history entry follows (a Kalman filter records at most a hundred updates)
        "history_iterations": [est.iteration_of(k) for k in range(len(est.history))],
    }


def _outliers(result: CalibrationResult) -> dict[str, Any]:
    """The rows a robust fit marked (0-based, of ``result.data``) and their file lines.

    With several sets, also the label of the set (file) each belongs to.
    """
    lines = result.data.lines
    rows = result.outlier_rows
    out: dict[str, Any] = {"outlier_rows": rows,
                           "outlier_lines": [int(lines[r]) for r in rows] if lines is not None else []}
    if len(result.sets) > 1:  # several files: a line number alone does not say whose
        owner = {int(r): part.label for part in result.sets for r in part.rows}
        out["outlier_sets"] = [owner[int(r)] for r in rows]
    return out


def _residuals(result: CalibrationResult) -> dict[str, Any]:
    """Per data row error before and after [mm], computed as the metrics are.

    So their RMSE is the report's; with 0-based ``rows``, ``split`` train/test, ``outlier``.
    """
    problem, x0 = result.problem, np.zeros(result.problem.n_params)
    rows: list[int] = []
    split: list[str] = []
    before: list[float] = []
    after: list[float] = []
    for name, part_rows in (("train", result.train), ("test", result.test)):
        if len(part_rows):
            part = problem.subset(part_rows)
            rows += [int(r) for r in part_rows]
            split += [name] * len(part_rows)
            data = getattr(part, "data_rows", slice(None))  # a contact set's distance rows are no data row
            before += (part.row_errors(part.residual(x0))[data] * 1e3).tolist()
            after += (part.row_errors(result.estimate.residual(part))[data] * 1e3).tolist()
    outliers = set(result.outlier_rows)
    return {"rows": rows, "split": split, "outlier": [r in outliers for r in rows],
            "before_mm": before, "after_mm": after, "meaning": problem.model.error_name}


def _spectrum(result: CalibrationResult) -> dict[str, Any]:
    """Singular values of the scaled training Jacobian and the rank cut (RCOND x largest)."""
    ident = result.identifiability
    s = np.asarray(ident.singular_values, dtype=float)
    return {"singular_values": s.tolist(), "rcond": RCOND, "cut": RCOND * float(s[0]) if len(s) else 0.0,
            "rank": int(ident.rank)}


def _workspace(result: CalibrationResult) -> dict[str, Any] | None:
    """The first named point [mm] and its predicted RMS position error [mm] at workspace poses.

    The point is the first of :attr:`~calib_pin.calibration.result.CalibrationResult.named_points`,
    at each random workspace pose of the accuracy analysis; None without kinematic parameters.
    """
    accuracy = result.accuracy
    if accuracy is None:
        return None
    error = (accuracy.workspace_error * 1e3).tolist()
    return {"point": accuracy.points[0].name, "points_mm": (accuracy.workspace_points * 1e3).tolist(),
            "error_mm": error, "sigma_mm": error}  # sigma_mm: the previous version's name, kept one release


def _uncertainty(result: CalibrationResult) -> dict[str, Any] | None:
    """The intervals, with the previous version's keys kept one release.

    The intervals (:meth:`~calib_pin.analysis.uncertainty.Uncertainty.as_dict`), with the
    previous version's ``noise_estimate_mm`` and ``flange_position_1sigma_mm`` kept one release:
    the noise the intervals assume, and the predicted RMS error of the end frame's origin.
    """
    uncertainty, accuracy = result.uncertainty, result.accuracy
    if uncertainty is None or accuracy is None:
        return None
    out = uncertainty.as_dict()
    origin = next((p for p in accuracy.points if not p.point.any()), None)
    flange = {} if origin is None else {"rms": origin.rms * 1e3, "max": origin.p95 * 1e3, "poses": accuracy.poses}
    return {**out, "noise_estimate_mm": out["noise_mm"], "flange_position_1sigma_mm": flange,
            "deprecated": "noise_estimate_mm (now noise_mm) and flange_position_1sigma_mm (now accuracy.points: "
                          "the predicted error at each named point, max now the 95th percentile) go in 0.4"}


def accuracy_lines(accuracy: dict[str, Any]) -> list[str]:
    """The console table of a report's ``accuracy``.

    The console table of a report's ``accuracy``: each named point's predicted position
    error over the workspace and its three parts, then where each part comes from.
    """
    points = accuracy["points"]
    names = [f"{p['name']} ({', '.join(f'{round(v, 1) + 0:g}' for v in p['point_mm'])})" for p in points]
    width = max(len(n) for n in [*names, 'point (end frame, mm)']) + 2
    lines = [f"accuracy where the robot works: predicted position error over {accuracy['poses']} workspace poses, "
             "base frame, mm",
             f"  {'point (end frame, mm)':{width}s}{'RMS':>8s}{'p95':>8s}{'noise':>8s}{'model':>8s}{'blind':>8s}"
             f"{'registered':>12s}"]
    for name, p in zip(names, points, strict=True):
        flag = "" if p["determined"] else "  not determined by the data: mostly the prior"
        lines.append(f"  {name:{width}s}{p['rms_mm']:8.3f}{p['p95_mm']:8.3f}{p['noise_mm']:8.3f}"
                     f"{p['model_mm']:8.3f}{p['blind_mm']:8.3f}{p['registered_rms_mm']:12.3f}{flag}")
    prior = accuracy["prior"]
    lines.append(f"  blind: what the data does not determine (the robot stays at its start there), bounded by the "
                 f"prior {prior['length_mm']:g} mm, {prior['angle_deg']:g} deg per deviation (--prior-mm, "
                 "--prior-deg); registered: after the best rigid motion (the robot registered in its cell)")
    for s in accuracy["sets"]:
        rep = s["repeatability"]
        name = f"{s['label']}: " if len(accuracy["sets"]) > 1 else ""
        if rep["sigma_mm"] is None:
            words = (f"the residual {s['residual_mm']:.4f} mm per value ({s['source']}); the sensor's repeatability "
                     f"is unknown ({rep['source'].removeprefix('unknown: ')}), so the model part is not counted: "
                     f"it may be up to {s['unexplained_bound_mm']:.4f} mm per coordinate")
        else:
            words = (f"the residual {s['residual_mm']:.4f} mm per value ({s['source']}) against the sensor's "
                     f"repeatability {rep['sigma_mm']:.4f} mm ({rep['source']}): "
                     + (f"{s['unexplained_mm']:.4f} mm per coordinate unexplained" if s["unexplained_mm"] > 0
                        else "nothing significant unexplained"))
        lines.append(f"  model: {name}{words}")
    return lines


def _in_unit(values: np.ndarray, unit: str) -> dict[str, float]:
    """RMS, mean and max of row errors already in ``unit``, the unit in the keys."""
    v = np.asarray(values, dtype=float)
    if not len(v):
        return {f"rmse_{unit}": float("nan"), f"mean_{unit}": float("nan"), f"max_{unit}": float("nan")}
    return {f"rmse_{unit}": float(np.sqrt(np.mean(v**2))), f"mean_{unit}": float(np.mean(v)),
            f"max_{unit}": float(np.max(v))}


def part_report(problem: Any, x: np.ndarray | None, splits: dict[str, np.ndarray]) -> dict[str, Any]:
    """The errors and noise per part of a set whose rows have parts in units of their own.

    Parts such as a 6-D pose's position and orientation
    (:meth:`~calib_pin.sensors.base.MeasurementModel.errors_by_part`). The report holds
    ``errors_by_part`` (split -> stage -> part -> RMS/mean/max in the part's unit, nominal
    before, ``x`` after) and ``noise_by_part`` (part -> the sigma its entries were weighted
    by, in its unit, and where it came from); {} for any other set. ``problem``: the set's.
    """
    model = problem.model
    out: dict[str, Any] = {}
    errors: dict[str, Any] = {}
    for split, rows in splits.items():
        if len(rows):
            part = problem.subset(np.asarray(rows, dtype=int))
            stages = {stage: model.errors_by_part(at, part.q, part.readings) for stage, at in (("before", None),
                                                                                                ("after", x))}
            if stages["after"]:
                errors[split] = {stage: {key: _in_unit(v, key.rsplit("_", 1)[1]) for key, v in by.items()}
                                 for stage, by in stages.items()}
    if errors:
        out["errors_by_part"] = errors
    if model.noise_parts():
        out["noise_by_part"] = {p.name: p.as_dict() for p in model.noise_parts()}
    return out


def noise_parts_line(noise_by_part: dict[str, dict[str, Any]]) -> str:
    """One line of a report's ``noise_by_part``.

    For example ``noise per part (1 sigma): position 0.05 mm (file), orientation 0.01 deg
    (estimate)``.
    """
    cells = []
    for name, doc in noise_by_part.items():
        key = next(k for k in doc if k != "noise_from")
        cells.append(f"{name} {doc[key]:.4g} {key.removeprefix('noise_')} ({doc['noise_from']})")
    return "noise per part (1 sigma): " + ", ".join(cells)


def _set_reports(result: CalibrationResult) -> list[dict[str, Any]]:
    """Each set's table and set-up (:meth:`~calib_pin.calibration.result.SetResult.as_dict`).

    With its errors and noise per part when its rows have parts (scored on its own rows:
    not with a learnt correction, nor beside a separate validation session).
    """
    own = result.estimate.correction is None and not result.test_source
    return [{**s.as_dict(), **(part_report(s.problem, s.x, {"train": s.train, "test": s.test}) if own else {}),
             **(_per_pose(result, s) if own else {})} for s in result.sets]


def _per_pose(result: CalibrationResult, s: Any) -> dict[str, Any]:
    """A set's error per pose (an image's corners, a pose's markers), in its unit: ``{"per_pose": [...]}``.

    Each pose's label (``id``), split, rows and RMS row error before and after, and what its
    sensor calls a pose and a row (``pose_name``: ``image``; ``row_name``: ``corners``); empty for a set of one
    row a pose (its per-row residuals say it all) or without pose labels.
    """
    pose_ids = result.data.pose_ids
    problem = s.problem
    if pose_ids is None or problem is None or problem.n_rows != len(s.rows):
        return {}
    labels = [str(v) for v in np.asarray(pose_ids, dtype=object)[s.rows]]
    order = dict.fromkeys(labels)  # the poses in file order
    if len(order) == len(labels):
        return {}
    index = {label: k for k, label in enumerate(order)}
    pose = np.array([index[label] for label in labels])
    rows = np.bincount(pose)

    def rms(residual: np.ndarray) -> np.ndarray:
        return np.sqrt(np.bincount(pose, weights=(problem.row_errors(residual) * 1e3) ** 2) / rows)

    before, after = rms(problem.residual(np.zeros(len(s.x)))), rms(problem.residual(s.x))
    tested = np.zeros(len(order), dtype=bool)
    tested[pose[s.test]] = True
    out = [{"id": int(label) if label.lstrip("+-").isdigit() else label, "split": "test" if tested[k] else "train",
            "rows": int(rows[k]), f"rms_before_{s.unit}": float(before[k]), f"rms_after_{s.unit}": float(after[k])}
           for k, label in enumerate(order)]
    return {"per_pose": out, "pose_name": s.model.pose_name, "row_name": s.model.row_name}


def build_report(result: CalibrationResult) -> dict[str, Any]:
    """JSON-ready summary of a calibration, and the arrays the HTML report draws.

    What was calibrated with what, the metrics before and after [mm], the estimate's run,
    the deviations with their uncertainty, the identifiability, the sensor geometry, the
    split, each set's table and any warnings; and the arrays the HTML report draws:
    ``residuals`` (per data row),
    ``identifiability_spectrum`` and ``workspace_uncertainty`` (per random workspace pose).
    The keys of a calibration of one set are those of that set (its geometry, its errors
    per part).
    """
    from ..analysis.metrics import units_words

    kinematic = result.kinematic
    model = result.problem.model
    geometry = model.geometry_report(result.x)
    sets = _set_reports(result)
    unit = result.sets[0].unit
    one = {k: v for k, v in sets[0].items() if k in ("errors_by_part", "noise_by_part")} if len(sets) == 1 else {}
    report: dict[str, Any] = {
        "robot": result.chain.name,
        "end_frame": result.chain.end_frame,
        "data": result.data.source,
        "test_data": result.test_source or None,
        "data_kind": result.data.kind,
        "error": model.error_name,
        "sensor": model.describe(),
        "model": result.model_name,
        "method": result.method,
        "seed": result.seed,
        **_metrics(result),
        **_estimate(result),
        "kinematic_parameters": kinematic,
        "deviations": result.deviations if kinematic else {},
        "sensor_corrections": result.sensor_corrections if kinematic else {},
        "uncertainty": _uncertainty(result),
        "accuracy": result.accuracy.as_dict() if result.accuracy is not None else None,
        "identifiability": result.identifiability.as_dict(),
        **geometry,
        "sensor_geometry": geometry,
        f"noise_{unit}": result.noise * 1e3,  # the first set's unit: its rows weigh 1
        "noise_unit": unit,
        "noise_from": result.noise_from,
        **one,
        "loss": result.loss,
        **_outliers(result),
        "split": {"train": result.train.tolist(), "test": result.test.tolist()},
        "warnings": list(result.warnings),
        "ignored_columns": list(result.data.extra),  # the data's extra columns, read and kept, not used
        "residuals": _residuals(result),
        "identifiability_spectrum": _spectrum(result),
        "workspace_uncertainty": _workspace(result),
        "sets": sets,
        "metrics_pooled": units_words(result.sets),
    }
    if result.test_registration is not None:  # a validation session on a new set-up: which rows did what
        report["test_registration"] = result.test_registration
    if result.fixed:  # unknowns held at their start (--fix/--free)
        report["fixed"] = list(result.fixed)
    if result.start is not None:  # --nominal: where the estimate started
        report["start"] = result.start.as_dict(result.params, result.problem.model.robot(result.x))
    if result.cross_validation is not None:
        report["cross_validation"] = result.cross_validation
    spec = model.compliance_spec
    if spec is not None:
        from ..robot.deflection import against_gravity_warning, compliance_report, deflection_effects

        rigid = np.array(result.x, dtype=float)
        rigid[model.n_robot:model.sensor_start] = 0.0  # the calibrated geometry without deflection
        effects = deflection_effects(model.deflection, lambda q: model.end_frames(rigid, q)[1], result.data.q,
                                     model.compliance(result.x))
        report["compliance"] = compliance_report(spec, model.compliance(result.x), result.bounded_compliance,
                                                 effects)
        if result.bounded_compliance:
            report["warnings"].append(bounded_warning(result.bounded_compliance))
        if effects.get("against_gravity"):
            report["warnings"].append(against_gravity_warning(effects["against_gravity"]))
        if spec.model == "basis" and spec.payload is not None:
            report["warnings"].append("the payload given is not used: the gravity basis already holds any load the "
                                      "end frame carries (its mass and centre of mass are fitted with the links')")
    if result.accuracy is not None:
        report["warnings"] += result.accuracy.warnings()
    ident = report["identifiability"]
    if kinematic and 2 * ident["rank"] < ident["unknowns"]:  # normal, but more varied poses would see more
        report["warnings"].append(rank_warning(ident["rank"], ident["unknowns"]))
    return _finite(report)


def rank_warning(rank: int, unknowns: int) -> str:
    """The one line a calibration gets whose poses identify fewer than half its unknowns.

    Normal in calibration, so not refused: the blind directions stay at zero.
    """
    return (f"the training poses identify only {rank} of {unknowns} directions: the blind directions stay "
            "at zero (--analyze lists them)")


def bounded_warning(joints: tuple[str, ...]) -> str:
    """The one line for compliances that fitted negative and were fixed at zero."""
    return (f"compliance bounded at zero: {', '.join(joints)} (fitted negative; a compliance is >= 0, so "
            "these joints are taken as rigid and the others fitted again)")


def _finite(value: Any) -> Any:
    """The report with every non-finite float replaced by None (JSON has no NaN)."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        if all(type(v) is float for v in value):  # a list of numbers: one pass, no call per item
            return [v if math.isfinite(v) else None for v in value]
        return [_finite(v) for v in value]
    if isinstance(value, float | np.floating) and not math.isfinite(value):
        return None
    return value
