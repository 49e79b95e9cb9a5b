"""Figures of the calibration report, drawn from the report dict alone.

Every function takes the report dict (:func:`calib_pin.report.build.build_report`, what
report.json holds) and returns a PNG as bytes. Drawn with
matplotlib's object API on the Agg canvas (no pyplot, no screen), each in one draw with
a fixed layout (margins in inches, room for the labels each figure has): a constrained layout
would measure every tick and label twice more before drawing. Units as the keys say: [mm]
and [deg].
"""

from __future__ import annotations

import io

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.font_manager import FontProperties

TRAIN, TEST, BAD = "tab:blue", "tab:orange", "tab:red"

#: Most data rows a per-row figure draws: above it every k-th row is drawn (outliers always),
#: and the figure and its caption say so. A figure of 3000 points reads like one of 100 000
#: and draws in a fraction of the time.
MAX_DRAWN_ROWS = 3000


def drawn_rows(n_rows: int, keep: np.ndarray | None = None) -> np.ndarray:
    """Indices of the rows a per-row figure draws: all up to :data:`MAX_DRAWN_ROWS`, else a spread.

    Else every k-th (evenly spread, k = ceil(n_rows / MAX_DRAWN_ROWS)) and the rows in
    ``keep`` (a boolean mask, e.g. the outliers).
    """
    step = -(-n_rows // MAX_DRAWN_ROWS)
    if step <= 1:
        return np.arange(n_rows)
    chosen = np.zeros(n_rows, dtype=bool)
    chosen[::step] = True
    if keep is not None:
        chosen |= keep
    return np.flatnonzero(chosen)


def decimation_note(n_rows: int) -> str:
    """How a per-row figure of ``n_rows`` rows is thinned (empty when it draws them all)."""
    step = -(-n_rows // MAX_DRAWN_ROWS)
    return "" if step <= 1 else f"1 in {step} of {n_rows} rows drawn, outliers always"


DPI = 100


def _figure(width: float, height: float) -> Figure:
    """A figure of ``width`` x ``height`` inches at :data:`DPI` on its Agg canvas."""
    fig = Figure(figsize=(width, height), dpi=DPI)
    FigureCanvasAgg(fig)
    return fig


def _row(fig: Figure, ratios: list[float], gaps: list[float], left: float, right: float, bottom: float,
         top: float) -> list[Axes]:
    """Axes side by side with fixed margins and gaps [inch]: the width left over is split by ``ratios``.

    Args:
        gaps: Space between neighbours [inch], ``len(ratios) - 1`` of them (for the right one's labels).
        left, right, bottom, top: Margins of the figure [inch] (tick labels, axis labels, titles).
    """
    width, height = fig.get_size_inches()
    free = width - left - right - sum(gaps)
    x, axes = left, []
    for k, ratio in enumerate(ratios):
        w = free * ratio / sum(ratios)
        axes.append(fig.add_axes((x / width, bottom / height, w / width, (height - bottom - top) / height)))
        x += w + (gaps[k] if k < len(gaps) else 0.0)
    return axes


def _text_width(fig: Figure, texts: list[str], size: float) -> float:
    """Widest of ``texts`` at font ``size`` [pt], in inches (to leave room for tick labels)."""
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    prop = FontProperties(size=size)
    return max((renderer.get_text_width_height_descent(t, prop, ismath=False)[0] for t in texts), default=0.0) / fig.dpi


def _fit_y_labels(fig: Figure, axes: list[Axes], gaps: list[float], right: float) -> None:
    """Move a row of axes sideways so each one's y tick labels and y label just fit on its left.

    The one size a fixed layout cannot know beforehand: a log axis spanning less than a decade
    labels its minor ticks (``6x10^-1``, wide). Measures the y axes only (their ticks depend on
    the axes' height, which stays), not every label as a constrained layout would, twice.

    Args:
        gaps: Space [inch] between one axes' right edge and the next one's labels.
        right: Margin [inch] right of the last axes.
    """
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    width = fig.get_size_inches()[0]
    boxes = [ax.yaxis.get_tightbbox(renderer) for ax in axes]
    room = [(ax.bbox.x0 - (box.x0 if box is not None else ax.bbox.x0)) / fig.dpi + 0.08
            for ax, box in zip(axes, boxes, strict=True)]
    shares = [ax.get_position().width for ax in axes]
    free = width - right - sum(room) - sum(gaps)
    x = 0.0
    for k, ax in enumerate(axes):
        x += room[k]
        w = free * shares[k] / sum(shares)
        position = ax.get_position()
        ax.set_position((x / width, position.y0, w / width, position.height))
        x += w + (gaps[k] if k < len(gaps) else 0.0)


def png(fig: Figure) -> bytes:
    """The figure as PNG bytes at :data:`DPI` (no metadata, so no URLs inside).

    Drawn once on the Agg canvas (``savefig`` would draw a figure with a layout engine twice)."""
    fig.set_dpi(DPI)
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    buffer = io.BytesIO()
    canvas.print_png(buffer, metadata={"Software": None})
    return buffer.getvalue()


def residuals(r: dict) -> bytes:
    """Per data row |error| before and after (train/test, outliers ringed) and their spread."""
    res = r["residuals"]
    rows = np.asarray(res["rows"])
    before, after = np.asarray(res["before_mm"]), np.asarray(res["after_mm"])
    test = np.asarray(res["split"]) == "test"
    outlier = np.asarray(res["outlier"], dtype=bool)
    fig = _figure(12, 4.2)
    per_row, spread = _row(fig, [3, 1], [0.55], left=0.75, right=0.1, bottom=0.65, top=0.5)
    shown = np.zeros(len(rows), dtype=bool)
    shown[drawn_rows(len(rows), outlier)] = True  # the box plot keeps every row
    for mask, colour, label in ((~test & shown, TRAIN, "train"), (test & shown, TEST, "test")):
        per_row.scatter(rows[mask], before[mask], s=14, marker="^", facecolors="none",
                        edgecolors=colour, alpha=0.6, label=f"{label}, before")
        per_row.scatter(rows[mask], after[mask], s=16, color=colour, label=f"{label}, after")
    if outlier.any():
        per_row.scatter(rows[outlier], after[outlier], s=90, facecolors="none", edgecolors=BAD,
                        linewidths=1.5, label="outlier (robust loss)")
    per_row.set_yscale("log")
    per_row.set_xlabel("data row (0-based)")
    per_row.set_ylabel(f"{res['meaning']} [mm] (log)")
    per_row.grid(True, which="both", alpha=0.3)
    per_row.legend(fontsize=8, ncol=3, loc="lower left")
    note = decimation_note(len(rows))
    per_row.set_title("error per data row: triangles before, dots after calibration"
                      + (f" ({note})" if note else ""), fontsize=10)
    groups = [("train\nbefore", before[~test]), ("train\nafter", after[~test]),
              ("test\nbefore", before[test]), ("test\nafter", after[test])]
    groups = [(name, values) for name, values in groups if len(values)]
    box = spread.boxplot([v for _, v in groups], tick_labels=[n for n, _ in groups], whis=(5, 95),
                         widths=0.6, patch_artist=True, flierprops={"markersize": 3, "alpha": 0.5})
    for patch, (name, _) in zip(box["boxes"], groups, strict=True):
        patch.set_facecolor(TRAIN if name.startswith("train") else TEST)
        patch.set_alpha(0.35 if "before" in name else 0.8)
    spread.set_yscale("log")
    spread.set_title("distribution (box: quartiles,\nwhiskers: 5-95 %)", fontsize=10)
    spread.grid(True, axis="y", which="both", alpha=0.3)
    _fit_y_labels(fig, [per_row, spread], [0.2], right=0.1)
    return png(fig)


def deviations(r: dict, rows: list[dict]) -> bytes:
    """Each robot deviation with its 95 % interval, lengths and angles side by side.

    Args:
        rows: :func:`calib_pin.report.html.deviation_rows` (robot parameters only).
    """
    groups = [[row for row in rows if row["unit"] == unit] for unit in ("mm", "deg")]
    start = "the start" if r.get("start") else "0"
    groups = [g for g in groups if g]
    height = max(2.5, 0.22 * max(len(g) for g in groups) + 1.2)
    fig = _figure(12, height)
    names = [_text_width(fig, [row["name"] for row in group], 8) + 0.15 for group in groups]
    axes = _row(fig, [1] * len(groups), [0.25 + w for w in names[1:]], left=names[0] + 0.05, right=0.15,
                bottom=0.5, top=0.35)
    for ax, group in zip(axes, groups, strict=True):
        y = np.arange(len(group))[::-1]
        status = np.array([row["status"] for row in group])
        value = np.array([row["value"] for row in group], dtype=float)
        held = np.isin(status, ("not determined", "held"))
        if held.any():  # one artist per kind of row, not one per row
            ax.plot(value[held], y[held], "s", mfc="white", mec="grey", ms=7, linestyle="none")
        mixed = status == "combination"
        if mixed.any():
            ax.plot(value[mixed], y[mixed], "D", mfc="white", mec="tab:purple", ms=6, linestyle="none")
        alone = status == "identified"
        if alone.any():
            low, high = (np.array([row[k] for row, a in zip(group, alone, strict=True) if a], dtype=float)
                         for k in ("low", "high"))
            ax.errorbar(value[alone], y[alone], xerr=[value[alone] - low, high - value[alone]],
                        fmt="o", color="tab:blue", ms=4, capsize=3)
        ax.axvline(0.0, color="black", linewidth=0.8)
        ax.set_yticks(y, [row["name"] for row in group], fontsize=8)
        ax.set_xlabel(f"deviation [{group[0]['unit']}], bar = 95 % interval")
        ax.grid(True, axis="x", alpha=0.3)
    fig.suptitle(f"estimated deviations: blue determined by the data (95 % bar), purple only combined, white held at "
                 f"{start}", fontsize=10)
    return png(fig)


def spectrum(r: dict) -> bytes:
    """Singular values of the scaled identification Jacobian, the rank cut marked."""
    spec = r["identifiability_spectrum"]
    s = np.asarray(spec["singular_values"])
    kept = s > spec["cut"]
    fig = _figure(6, 3.6)
    (ax,) = _row(fig, [1], [], left=0.8, right=0.1, bottom=0.5, top=0.3)
    index = np.arange(1, len(s) + 1)
    floor = max(spec["cut"] * 1e-3, s[s > 0].min() if (s > 0).any() else 1e-16)
    shown = np.maximum(s, floor)
    ax.semilogy(index[kept], shown[kept], "o", color="tab:blue", label=f"identifiable ({kept.sum()})")
    ax.semilogy(index[~kept], shown[~kept], "x", color=BAD, label=f"blind ({(~kept).sum()}; drawn at the floor)")
    ax.axhline(spec["cut"], color="grey", linestyle="--", label=f"cut {spec['rcond']:g} x largest")
    ax.set_xlabel("direction (sorted)")
    ax.set_ylabel("singular value [m per typical deviation]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("identifiability spectrum (training poses)", fontsize=10)
    _fit_y_labels(fig, [ax], [], right=0.1)
    return png(fig)


def workspace(r: dict) -> bytes:
    """Predicted RMS position error of the first named point over workspace poses, two views."""
    ws = r["workspace_uncertainty"]
    p = np.asarray(ws["points_mm"])
    sigma = np.asarray(ws["error_mm"])
    what = f"predicted error of the {ws['point']} [mm]"  # RMS at each pose
    order = np.argsort(sigma)
    fig = _figure(12, 4.4)
    top, side, bar, hist = _row(fig, [1, 1, 0.05, 0.8], [0.75, 0.1, 1.45], left=0.75, right=0.1, bottom=0.5, top=0.3)
    # The colour scale spans the sigmas' own range, so the spread over the workspace shows.
    vmin, vmax = (float(sigma.min()), float(sigma.max())) if len(sigma) else (0.0, 1.0)
    vmax = max(vmax, vmin * (1 + 1e-9) + 1e-12)  # a non-empty range when every sigma is equal
    for ax, (i, j), title in ((top, (0, 1), "top view"), (side, (0, 2), "side view")):
        art = ax.scatter(p[order, i], p[order, j], c=sigma[order], cmap="viridis", vmin=vmin, vmax=vmax, s=12)
        ax.plot([0], [0], "k+", ms=12)
        ax.set_xlabel(f"{'xyz'[i]} [mm] (base frame)")
        ax.set_ylabel(f"{'xyz'[j]} [mm]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(title, fontsize=10)
        ax.grid(True, alpha=0.3)
    fig.colorbar(art, cax=bar, label=what)
    hist.hist(sigma, bins=30, color="tab:green")
    hist.set_xlabel(what)
    hist.set_ylabel("poses")
    hist.set_title(f"{len(sigma)} random poses", fontsize=10)
    return png(fig)


def convergence(r: dict) -> bytes:
    """Training RMSE per iteration of the estimator, at the iterations the history holds.

    At most a hundred of a Kalman filter's row updates, see
    :data:`calib_pin.estimators.base.HISTORY_POINTS`.
    """
    h = np.asarray(r["train_rmse_history_mm"])
    iterations = np.asarray(r.get("history_iterations") or np.arange(len(h)))
    fig = _figure(6, 3.6)
    (ax,) = _row(fig, [1], [], left=0.75, right=0.15, bottom=0.5, top=0.3)
    ax.semilogy(iterations, h, "o-", color="tab:blue", ms=4)
    ax.set_xlabel("iteration")
    ax.set_ylabel("training RMSE per residual value [mm]")
    ax.grid(True, which="both", alpha=0.3)
    ax.set_title(f"convergence ({r['method']}, {r['iterations']} iterations)", fontsize=10)
    _fit_y_labels(fig, [ax], [], right=0.15)
    return png(fig)


def _axes_arrows(ax, origin, rotation, i, j, length, label):
    for k, colour in enumerate(("tab:red", "tab:green", "tab:blue")):
        tip = origin + length * rotation[:, k]
        ax.annotate("", xy=(tip[i], tip[j]), xytext=(origin[i], origin[j]),
                    arrowprops={"arrowstyle": "->", "color": colour, "lw": 1.5})
    ax.annotate(label, (origin[i], origin[j]), textcoords="offset points", xytext=(6, -12), fontsize=8)


def sensor(r: dict, device_rotation: np.ndarray | None = None) -> bytes:
    """The sensor's geometry: device frame and markers (positions) or anchor (cable).

    Args:
        device_rotation: Rotation matrix of the device frame (from the report's rpy),
            or None for a cable sensor.
    """
    ws = np.asarray(r["workspace_uncertainty"]["points_mm"]) if r.get("workspace_uncertainty") else np.zeros((0, 3))
    fig = _figure(12, 4.4)
    top, side, tool = _row(fig, [1, 1, 1], [1.0, 1.0], left=0.75, right=0.1, bottom=0.5, top=0.3)
    size = float(np.abs(ws).max()) * 0.25 if len(ws) else 150.0
    for ax, (i, j) in ((top, (0, 1)), (side, (0, 2))):
        ax.scatter(ws[:, i], ws[:, j], s=4, color="lightgrey", label="workspace poses")
        _axes_arrows(ax, np.zeros(3), np.eye(3), i, j, size, "robot base")
        if device_rotation is not None:
            frame = r["device_frame"]
            rotation = device_rotation
            origin = -rotation.T @ np.asarray(frame["translation_mm"])  # device origin in base
            ax.plot(origin[i], origin[j], "s", color="black", label="device origin")
            _axes_arrows(ax, origin, rotation.T, i, j, size, "device")
        else:
            anchor = np.asarray(r["anchor_mm"])
            ax.plot(anchor[i], anchor[j], "D", color="tab:purple", label="cable anchor")
        ax.set_xlabel(f"{'xyz'[i]} [mm] (base frame)")
        ax.set_ylabel(f"{'xyz'[j]} [mm]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    top.set_title("top view (arrows: x red, y green, z blue)", fontsize=10)
    side.set_title("side view", fontsize=10)
    points = ({label: np.asarray(m) for label, m in r["markers_mm"].items()} if device_rotation is not None
              else {"hook": np.asarray(r["tool_mm"])})
    for label, m in points.items():
        tool.plot(m[0], m[1], "o", color="tab:orange")
        tool.annotate(f"{label} (z {m[2]:.1f})", (m[0], m[1]), textcoords="offset points", xytext=(5, 5), fontsize=8)
    tool.plot([0], [0], "k+", ms=12)
    tool.annotate("end frame origin", (0, 0), textcoords="offset points", xytext=(6, -12), fontsize=8)
    # At least +-50 mm around the origin: a point at (0, 0) alone would get a micrometre-wide axis.
    reach = max(50.0, 1.3 * max(float(np.abs(m[:2]).max()) for m in points.values()))
    tool.set_xlim(-reach, reach)
    tool.set_ylim(-reach, reach)
    tool.set_xlabel("x [mm] (end frame)")
    tool.set_ylabel("y [mm] (end frame)")
    tool.set_aspect("equal", adjustable="box")
    tool.grid(True, alpha=0.3)
    tool.set_title("points on the end frame" if device_rotation is not None else "hook on the end frame", fontsize=10)
    return png(fig)
