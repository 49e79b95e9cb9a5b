"""The paper's Fig. 2 (residuals before/after per method) and Fig. 3 (convergence, time).

Drawn with matplotlib's object API on the Agg canvas (no screen, no global pyplot
state) from a :class:`calib_pin.studies.comparison.Comparison`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..util.optional import require

require("matplotlib")
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

if TYPE_CHECKING:
    from .comparison import Comparison


def _save(fig: Figure, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=120, format="png")  # by content, whatever the name (a temporary one)
    return path


def residual_figure(comparison: Comparison, path: str | Path) -> Path:
    """Fig. 2: absolute test residuals [mm] of the nominal model and of each method.

    One box per item (all trials pooled; box = quartiles, whiskers = 5th-95th
    percentile, points beyond them shown), log scale, the test RMSE marked by a diamond.
    """
    labels = ["Before"] + [f"{comparison.trials[0].runs[m].label}\n{m}" for m in comparison.methods]
    data = [np.concatenate([np.abs(t.before_residual_mm) for t in comparison.trials])]
    for m in comparison.methods:
        data.append(np.concatenate([np.abs(t.runs[m].test_residual_mm) for t in comparison.trials]))
    fig = Figure(figsize=(11, 5), layout="constrained")
    ax = fig.add_subplot()
    ax.boxplot(data, tick_labels=labels, whis=(5, 95), widths=0.6,
               flierprops={"markersize": 3, "alpha": 0.5})
    rmse = [np.sqrt(np.mean(d**2)) for d in data]
    ax.plot(np.arange(1, len(data) + 1), rmse, "D", color="tab:red", label="RMSE")
    ax.set_yscale("log")
    ax.set_ylabel("|test residual| [mm] (log scale)")
    ax.set_title(f"Fig. 2: calibration error, {comparison.robot}: {comparison.data}", fontsize=10)
    ax.grid(True, axis="y", which="both", alpha=0.3)
    ax.legend(loc="upper right")
    return _save(fig, path)


def convergence_figure(comparison: Comparison, path: str | Path) -> Path:
    """Fig. 3: training RMSE [mm] against iterations and evaluations, and wall time per method.

    The RMSE for each iterative method (trial 0); the wall time as the median over trials,
    with the range as error bar.
    """
    trial = comparison.trials[0]
    fig = Figure(figsize=(16, 5), layout="constrained")
    by_iter, by_eval, times = fig.subplots(1, 3)
    styles = ["-", "--", "-.", ":", (0, (6, 2, 1, 2, 1, 2))]
    for i, m in enumerate(comparison.methods):
        run = trial.runs[m]
        if run.iterations == 1:  # not iterative (rbf)
            continue
        h = np.asarray(run.history_mm)
        style = {"label": f"{run.label} {m}", "linestyle": styles[i % len(styles)], "linewidth": 1.6}
        if run.iterations == 0:  # started at the optimum: its one point, marked, so it is in the legend
            style.update(label=f"{run.label} {m} (0 iterations)", marker="o")
        by_iter.plot(np.arange(len(h)), h, **style)
        by_eval.plot(run.history_evaluations, h, **style)
    for ax, xlabel, linear_below in (
        (by_iter, "iteration (each method's own unit, symlog scale)", 1.0),
        (by_eval, "evaluations of the training residual (symlog scale)", 0.1),
    ):
        ax.set_xscale("symlog", linthresh=linear_below)
        ax.set_yscale("log")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("training RMSE [mm] (log scale)")
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
        else:  # no iterative method (only rbf): say so instead of an empty legend
            ax.text(0.5, 0.5, "no iterative method", transform=ax.transAxes, ha="center", va="center")
    by_iter.set_title("(a) convergence per iteration", fontsize=10)
    by_eval.set_title("(b) convergence per evaluation", fontsize=10)
    names = comparison.methods
    t = np.array([[tr.runs[m].time_s for tr in comparison.trials] for m in names])
    median = np.median(t, axis=1)
    err = np.vstack([median - t.min(axis=1), t.max(axis=1) - median])
    times.bar(np.arange(len(names)), median, yerr=err, color="tab:blue", capsize=3)
    times.set_xticks(np.arange(len(names)),
                     [f"{trial.runs[m].label}\n{m}" for m in names], fontsize=8)
    times.set_yscale("log")
    times.set_ylabel("wall time of the estimate [s] (log scale)")
    times.set_title(f"(c) time per method (median of {len(comparison.trials)} trial(s))", fontsize=10)
    times.grid(True, axis="y", which="both", alpha=0.3)
    fig.suptitle(f"Fig. 3: training curves and time, {comparison.robot}: {comparison.data}", fontsize=11)
    return _save(fig, path)
