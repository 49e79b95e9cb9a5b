"""The report's figures: every series, label and caption drawn from the report dict, and the
fixed layout keeps every label inside the figure and out of its neighbours."""

import numpy as np
import pinocchio as pin
import pytest

import calib_pin
from calib_pin.report.build import build_report
from calib_pin.robot.description import ROBOTS_DIR

pytest.importorskip("matplotlib")
from calib_pin.report import figures  # noqa: E402
from calib_pin.report.html import deviation_rows  # noqa: E402


@pytest.fixture(scope="module", params=["irb120_default.csv", "irb120_wu2015.csv"], ids=["cable", "position"])
def report(request):
    return build_report(calib_pin.calibrate("irb120", ROBOTS_DIR / request.param, method="lm"))


def _drawn(monkeypatch, draw, *args):
    """The Figure ``draw(*args)`` made, and its PNG bytes."""
    made = []
    real = figures.png
    monkeypatch.setattr(figures, "png", lambda fig: made.append(fig) or real(fig))
    data = draw(*args)
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(made) == 1
    return made[0], data


def _inside_and_apart(fig):
    """Every axes with its labels, ticks, title and legend lies inside the figure, and no two overlap."""
    renderer = fig.canvas.get_renderer()
    width, height = fig.bbox.width, fig.bbox.height
    boxes = [ax.get_tightbbox(renderer) for ax in fig.axes]
    for ax, box in zip(fig.axes, boxes, strict=True):
        assert box.x0 >= -1 and box.y0 >= -1 and box.x1 <= width + 1 and box.y1 <= height + 1, (ax.get_title(), box)
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            overlap = min(boxes[i].x1, boxes[j].x1) - max(boxes[i].x0, boxes[j].x0)
            assert overlap <= 1, (fig.axes[i].get_title(), fig.axes[j].get_title(), overlap)
    for text in fig.texts:  # the suptitle
        box = text.get_window_extent(renderer)
        assert box.x0 >= 0 and box.x1 <= width and box.y1 <= height + 1


def _offsets(ax):
    return [c.get_offsets() for c in ax.collections if len(c.get_offsets())]


def test_residuals_every_series_and_row(monkeypatch, report):
    fig, _ = _drawn(monkeypatch, figures.residuals, report)
    per_row, spread = fig.axes
    res = report["residuals"]
    labels = [t.get_text() for t in per_row.get_legend().get_texts()]
    assert labels[:4] == ["train, before", "train, after", "test, before", "test, after"]
    points = np.vstack(_offsets(per_row))
    drawn = {(float(x), float(y)) for x, y in points}
    for row, before, after in zip(res["rows"], res["before_mm"], res["after_mm"], strict=True):
        assert (row, before) in drawn and (row, after) in drawn
    assert per_row.get_yscale() == "log" and per_row.get_xlabel() == "data row (0-based)"
    assert per_row.get_ylabel() == f"{res['meaning']} [mm] (log)"
    assert per_row.get_title().startswith("error per data row: triangles before, dots after calibration")
    assert [t.get_text() for t in spread.get_xticklabels()] == ["train\nbefore", "train\nafter", "test\nbefore", "test\nafter"]
    _inside_and_apart(fig)


def test_deviations_every_parameter_with_its_interval(monkeypatch, report):
    rows = deviation_rows(report)
    fig, _ = _drawn(monkeypatch, figures.deviations, report, rows)
    names = [t.get_text() for ax in fig.axes for t in ax.get_yticklabels()]
    assert sorted(names) == sorted(row["name"] for row in rows)
    assert [ax.get_xlabel() for ax in fig.axes] == ["deviation [mm], bar = 95 % interval", "deviation [deg], bar = 95 % interval"]
    values = np.concatenate([c.lines[0].get_xdata() for ax in fig.axes for c in ax.containers]
                            + [line.get_xdata() for ax in fig.axes for line in ax.lines if line.get_marker() in "sD"])
    estimated = [row["value"] for row in rows]
    assert np.allclose(np.sort(values), np.sort(estimated))
    bars = sum(len(c.lines[0].get_xdata()) for ax in fig.axes for c in ax.containers)
    assert bars == sum(row["status"] == "identified" for row in rows)  # an interval only for what is determined
    assert fig.texts[0].get_text().startswith("estimated deviations: blue determined by the data")
    _inside_and_apart(fig)


def test_spectrum_and_convergence(monkeypatch, report):
    fig, _ = _drawn(monkeypatch, figures.spectrum, report)
    (ax,) = fig.axes
    s = np.asarray(report["identifiability_spectrum"]["singular_values"])
    kept = s > report["identifiability_spectrum"]["cut"]
    identifiable, blind = ax.lines[0], ax.lines[1]
    assert np.allclose(identifiable.get_ydata(), s[kept]) and len(blind.get_xdata()) == (~kept).sum()
    assert [t.get_text() for t in ax.get_legend().get_texts()][0] == f"identifiable ({kept.sum()})"
    _inside_and_apart(fig)

    fig, _ = _drawn(monkeypatch, figures.convergence, report)
    (ax,) = fig.axes
    assert np.allclose(ax.lines[0].get_ydata(), report["train_rmse_history_mm"])
    assert ax.get_title() == f"convergence ({report['method']}, {report['iterations']} iterations)"
    assert ax.get_ylabel() == "training RMSE per residual value [mm]"
    _inside_and_apart(fig)


def test_workspace_and_sensor(monkeypatch, report):
    fig, _ = _drawn(monkeypatch, figures.workspace, report)
    top, side, bar, hist = fig.axes
    ws = report["workspace_uncertainty"]
    assert len(top.collections[0].get_offsets()) == len(ws["error_mm"]) == len(side.collections[0].get_offsets())
    assert np.allclose(np.sort(top.collections[0].get_array()), np.sort(ws["error_mm"]))
    assert bar.get_ylabel() == f"predicted error of the {ws['point']} [mm]"
    assert sum(p.get_height() for p in hist.patches) == len(ws["error_mm"])
    titles = [top.get_title(), side.get_title(), hist.get_title()]
    assert titles == ["top view", "side view", f"{len(ws['error_mm'])} random poses"]
    _inside_and_apart(fig)

    if "device_frame" in report:
        rotation = pin.rpy.rpyToMatrix(*np.deg2rad(report["device_frame"]["rpy_deg"]))
        fig, _ = _drawn(monkeypatch, figures.sensor, report, rotation)
        expected = ["workspace poses", "device origin"]
    else:
        fig, _ = _drawn(monkeypatch, figures.sensor, report)
        expected = ["workspace poses", "cable anchor"]
    top, side, tool = fig.axes
    assert [t.get_text() for t in top.get_legend().get_texts()] == expected
    assert top.get_title() == "top view (arrows: x red, y green, z blue)" and tool.get_xlabel() == "x [mm] (end frame)"
    _inside_and_apart(fig)
