"""Models compared on held-out data: which to trust, by its error on poses it was not fitted on.

:func:`compare_models` fits each model (the geometry alone, the geometry plus the
compliance of some joints, another parameter model) with one method on the same splits:
trial i holds out the same poses (split by pose, seed ``seed + i``) for every model. Per
model it gives the held-out RMSE, mean and max, mean ± sd over the trials, and the paired
difference of the held-out mean to the first model's: the mean over trials of
(model - first) and its standard error sd / sqrt(trials), which is what decides whether
a model is better (the splits' own spread cancels in the pairs).

A model is written ``geometric`` (the default parameter model, rigid), ``dh``,
``hayati`` or ``placement`` (that parameter model, rigid), or ``compliance:J+J`` (the
default parameter model with the compliance of joints J; ``compliance:all`` every joint),
optionally ``compliance:J+J:cad`` or ``:basis`` for the deflection model
(:mod:`calib_pin.robot.deflection`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis.metrics import Metrics
from ..calibration.prepare import deprecated_records, prepare
from ..calibration.solve import check_method, method_record
from ..exceptions import ArgumentError, CalibPinError
from ..parameters import MODELS as PARAMETER_MODELS
from ..robot.deflection import MODELS as DEFLECTION_MODELS
from ..robot.deflection import Compliance
from ..sensors import SensorSetup
from .comparison import run_trial
from .parallel import parallel_map


@dataclass(frozen=True)
class ModelChoice:
    """One model of a comparison.

    Attributes:
        name: As the user wrote it (``compliance:joint_2+joint_3``).
        parameters: Parameter model name, or None (the robot's default).
        compliance: The compliant joints and their deflection model, or None (rigid).
    """

    name: str
    parameters: str | None
    compliance: Compliance | None


def parse_model(text: str, parameters: str | None = None) -> ModelChoice:
    """A :class:`ModelChoice` from a model as written.

    Args:
        text: ``geometric``, ``dh|hayati|placement`` or ``compliance:J+J[:cad|basis]``.
        parameters: The parameter model of ``geometric`` and ``compliance:...`` (None: the
            robot's default).

    Raises:
        ArgumentError: ``models``: an unknown model, no joints, or an unknown deflection model.
    """
    text = str(text).strip()
    if text == "geometric":
        return ModelChoice(text, parameters, None)
    if text in PARAMETER_MODELS:
        return ModelChoice(text, text, None)
    kind, _, rest = text.partition(":")
    if kind != "compliance" or not rest:
        raise ArgumentError("models", f"{text!r} is not a model (geometric, {', '.join(PARAMETER_MODELS)}, "
                                      "compliance:JOINT+JOINT[:cad|basis] or compliance:all)")
    joints, _, deflection = rest.partition(":")
    if deflection and deflection not in DEFLECTION_MODELS:
        raise ArgumentError("models", f"{text!r}: the deflection model is one of {', '.join(DEFLECTION_MODELS)}")
    names = [j for j in joints.split("+") if j]
    if not names:
        raise ArgumentError("models", f"{text!r} names no joint (compliance:joint_2+joint_3 or compliance:all)")
    return ModelChoice(text, parameters, Compliance(",".join(names), model=deflection or None))


def parse_models(text: str | list[str], parameters: str | None = None) -> list[ModelChoice]:
    """Comma-separated models (or a list of them) as :class:`ModelChoice`, at least one, each once."""
    items = [t.strip() for t in text.split(",")] if isinstance(text, str) else [str(t).strip() for t in text]
    if not items or not all(items):
        raise ArgumentError("models", "give comma-separated models, e.g. geometric,compliance:joint_2+joint_3")
    if len(set(items)) != len(items):
        raise ArgumentError("models", "a model is named twice")
    return [parse_model(t, parameters) for t in items]


@dataclass
class ModelComparison:
    """Held-out metrics of each model over the same splits.

    Attributes:
        robot, method: The robot and the method every model was fitted with.
        models: The model names, first the reference of the paired differences.
        test: Per model, per trial, the held-out metrics [mm].
        described: Per model, what it fits, in words (parameter model, deflection model).
        data: What the trials ran on, in words.
    """

    robot: str
    method: str
    models: list[str]
    test: dict[str, list[Metrics]]
    described: dict[str, str]
    data: str

    def rows(self) -> list[dict[str, Any]]:
        """Per model: the held-out metrics as (mean, sd) over trials, and the paired difference.

        ``rmse_mm``, ``mean_mm``, ``max_mm`` as (mean, sd) over trials; ``paired_mean_mm``
        (mean difference of the held-out mean to the first model, its standard error) and
        ``paired_percent`` (that mean difference in % of the first's).
        """
        first = np.array([m.mean_mm for m in self.test[self.models[0]]])
        out = []
        for name in self.models:
            runs = self.test[name]
            row: dict[str, Any] = {"model": name, "fits": self.described[name], "trials": len(runs)}
            for key in ("rmse_mm", "mean_mm", "max_mm"):
                values = np.array([getattr(m, key) for m in runs])
                row[key] = (float(np.mean(values)), float(np.std(values)))
            diff = np.array([m.mean_mm for m in runs]) - first
            se = float(np.std(diff, ddof=1) / np.sqrt(len(diff))) if len(diff) > 1 else float("nan")
            row["paired_mean_mm"] = (float(np.mean(diff)), se)
            row["paired_percent"] = float(100.0 * np.mean(diff) / np.mean(first))
            out.append(row)
        return out

    def format_table(self) -> str:
        """The models side by side as fixed-width text."""
        lines = [f"{self.robot}, method {self.method}: {self.data}",
                 f"{'model':34s}{'RMSE mm':>18s}{'mean mm':>18s}{'max mm':>18s}  paired diff. of the mean to "
                 f"{self.models[0]} (± standard error)"]
        for row in self.rows():
            cells = "".join(f"{row[k][0]:>9.3f} ± {row[k][1]:.3f}" for k in ("rmse_mm", "mean_mm", "max_mm"))
            d, se = row["paired_mean_mm"]
            paired = "(reference)" if row["model"] == self.models[0] else \
                f"{d:+.3f} ± {se:.3f} mm ({row['paired_percent']:+.1f} %)"
            lines.append(f"{row['model']:34s}{cells}  {paired}")
        lines.append("fits: " + "; ".join(f"{m}: {self.described[m]}" for m in self.models))
        return "\n".join(lines)

    def write_markdown(self, path: str | Path, command: str = "") -> Path:
        """``models.md``: the table with the paired differences."""
        lines = [f"Models compared on held-out poses, {self.robot}, method {self.method}: {self.data}.", ""]
        if command:
            lines += [f"Command: `{command}`", ""]
        lines += ["| model | fits | held-out RMSE mm | held-out mean mm | held-out max mm | "
                  f"paired diff. of the mean to {self.models[0]} mm (± SE) |", "|---|---|---:|---:|---:|---:|"]
        for row in self.rows():
            cells = [f"{row[k][0]:.3f} ± {row[k][1]:.3f}" for k in ("rmse_mm", "mean_mm", "max_mm")]
            d, se = row["paired_mean_mm"]
            paired = "-" if row["model"] == self.models[0] else f"{d:+.3f} ± {se:.3f} ({row['paired_percent']:+.1f} %)"
            lines.append(f"| {row['model']} | {row['fits']} | " + " | ".join(cells) + f" | {paired} |")
        Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")
        return Path(path)

    def write_csv(self, path: str | Path) -> Path:
        """``models.csv``: one row per model and trial, the held-out metrics [mm]."""
        lines = ["model,trial,rmse_mm,mean_mm,max_mm"]
        for name in self.models:
            for k, m in enumerate(self.test[name]):
                lines.append(f"{name},{k},{m.rmse_mm:.6g},{m.mean_mm:.6g},{m.max_mm:.6g}")
        Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")
        return Path(path)


def _describe(calibration: Any) -> str:
    """What a prepared calibration fits, in words."""
    spec = calibration.compliance
    soft = "rigid" if spec is None else f"compliance of {', '.join(spec.joints)} ({spec.model} model)"
    return f"{calibration.params.name}, {soft}"


def compare_models(robot: str, data: Any = None, *, models: str | list[str], method: str = "lm",
                   trials: int = 10, seed: int = 0, test_fraction: float = 0.2, parameters: str | None = None,
                   setup: SensorSetup | None = None, fix: Any = None, free: Any = None, nominal: Any = None,
                   prior: Any = None, jobs: int = 1, scheduler: str | None = None, **loads: Any) -> ModelComparison:
    """Fit each model on the same splits by pose and score it on the held-out poses.

    Args:
        robot: Robot name or URDF path.
        data: Measurement sets as :func:`calib_pin.calibrate` takes them (None: the robot's shipped set).
        models: Comma-separated models (see the module), the first the reference.
        method: The estimator every model is fitted with (default ``lm``).
        trials: Splits of seeds ``seed`` .. ``seed + trials - 1``.
        test_fraction: Share of each set's poses held out.
        parameters: Parameter model of ``geometric`` and ``compliance:`` models.
        setup, fix, free, nominal, prior: As :func:`calib_pin.calibrate`'s, for every model.
        jobs, scheduler: Where the trials run (:func:`calib_pin.studies.parallel.parallel_map`).
        loads: ``payload_kg``, ``payload_com_mm``, ``cable_tension_n`` of the compliance models
            (and the deprecated ``estimate``: give ``setup``).

    Raises:
        CalibPinError: a bad model, method, robot, data or setting.
    """
    choices = parse_models(models, parameters)
    record = method_record(method, "linear")
    if not record.kinematic:
        raise CalibPinError(f"method '{method}' learns a correction of the values: compare models with a "
                            "parameter method (lm, ekf-qibas, ...)")
    if trials < 1:
        raise CalibPinError(f"trials must be at least 1, got {trials}")
    estimate = loads.pop("estimate", None)
    setup, _ = deprecated_records({"estimate": estimate} if estimate else {}, setup, None)
    loads = {k: v for k, v in loads.items() if v is not None}
    test: dict[str, list[Metrics]] = {}
    described: dict[str, str] = {}
    what = ""
    for choice in choices:
        compliance = None if choice.compliance is None else Compliance(choice.compliance.joints, **loads,
                                                                       model=choice.compliance.model)
        calibration = prepare(robot, data, parameters=choice.parameters, setup=setup, compliance=compliance,
                              fix=fix, free=free, nominal=nominal, prior=prior)
        check_method(record, calibration)
        one = partial(run_trial, calibration, None, [record], test_fraction=test_fraction)
        runs = parallel_map(one, range(seed, seed + trials), jobs, scheduler)
        test[choice.name] = [t.runs[record.name].test for t in runs]
        described[choice.name] = _describe(calibration)
        rows = calibration.data
        what = (f"{rows.describe_rows()} from {Path(rows.source).name if rows.source else 'memory'}"
                f", {trials} split(s) by pose of seeds {seed}..{seed + trials - 1}, {test_fraction:.0%} held out")
    return ModelComparison(robot=str(robot), method=method, models=[c.name for c in choices], test=test,
                           described=described, data=what)


__all__ = ["ModelChoice", "ModelComparison", "compare_models", "parse_model", "parse_models"]

