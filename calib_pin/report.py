"""The report of a calibration: one JSON-ready dict, the one source of every number
that ``report.json``, the console summary and the HTML report show."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from .result import CalibrationResult


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
    }


def _outliers(result: CalibrationResult) -> dict[str, Any]:
    lines = result.data.lines
    rows = result.outlier_rows
    return {"outlier_rows": rows, "outlier_lines": [int(lines[r]) for r in rows] if lines is not None else []}


def build_report(result: CalibrationResult) -> dict[str, Any]:
    """JSON-ready summary of a calibration: what was calibrated with what, the metrics
    before and after [mm], the estimate's run, the deviations with their uncertainty, the
    identifiability, the sensor geometry, the split and any warnings."""
    kinematic = result.kinematic
    uncertainty = result.uncertainty
    report: dict[str, Any] = {
        "robot": result.chain.name,
        "end_frame": result.chain.end_frame,
        "data": result.data.source,
        "test_data": result.test_source or None,
        "data_kind": result.data.kind,
        "error": result.problem.model.error_name,
        "model": result.model_name,
        "method": result.method,
        "seed": result.seed,
        **_metrics(result),
        **_estimate(result),
        "kinematic_parameters": kinematic,
        "deviations": result.deviations if kinematic else {},
        "sensor_corrections": result.sensor_corrections if kinematic else {},
        "uncertainty": uncertainty.as_dict() if uncertainty is not None else None,
        "identifiability": result.identifiability.as_dict(),
        **result.problem.model.geometry_report(result.x),
        "noise_mm": result.noise * 1e3,
        "loss": result.loss,
        **_outliers(result),
        "split": {"train": result.train.tolist(), "test": result.test.tolist()},
        "warnings": list(result.warnings),
    }
    spec = result.problem.model.compliance_spec
    if spec is not None:
        from .robot.deflection import compliance_report

        report["compliance"] = compliance_report(spec, result.problem.model.compliance(result.x))
    return _finite(report)


def _finite(value: Any) -> Any:
    """The report with every non-finite float replaced by None (JSON has no NaN)."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    if isinstance(value, float | np.floating) and not np.isfinite(value):
        return None
    return value
