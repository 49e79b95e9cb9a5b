"""The HTML report: self-contained, every number from the report dict, figures displayed."""

import base64
import re
import shutil
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest

import calib_pin
from calib_pin.analysis.metrics import Metrics
from calib_pin.report.build import build_report
from calib_pin.report.html import deviation_rows, fmt, write_html_report
from calib_pin.robot.description import ROBOTS_DIR

IMG = re.compile(r'<img [^>]*src="data:image/png;base64,([A-Za-z0-9+/=]+)"')
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def _render(tmp_path_factory, data: str):
    result = calib_pin.calibrate("irb120", ROBOTS_DIR / data, method="lm")
    report = build_report(result)
    path = write_html_report(report, tmp_path_factory.mktemp("report") / "report.html")
    return result, report, path, path.read_text(encoding="utf-8")


@pytest.fixture(scope="module", params=["irb120_default.csv", "irb120_wu2015.csv"], ids=["cable", "position"])
def rendered(request, tmp_path_factory):
    return _render(tmp_path_factory, request.param)


def test_summary_numbers_come_from_the_report(rendered):
    _, r, _, page = rendered
    for split in ("train", "test"):
        for stage in ("before", "after"):
            for key in ("rmse_mm", "mean_mm", "max_mm"):
                assert f"<td>{fmt(r[split][stage][key])}</td>" in page
    for text in (r["robot"], r["method"], r["model"], str(r["data"]), f"{fmt(r['time_s'])} s",
                 f"{r['iterations']} ({fmt(r['evaluations'])} evaluations"):
        assert text in page
    for p in r["accuracy"]["points"]:
        assert f"predicted accuracy at {p['name']}" in page
        assert f"RMS {fmt(p['rms_mm'])} mm, p95 {fmt(p['p95_mm'])} mm" in page


def test_every_deviation_with_its_interval(rendered):
    _, r, _, page = rendered
    rows = deviation_rows(r)
    assert [row["key"] for row in rows] == list(r["deviations"])
    for row in rows:
        p = r["uncertainty"]["parameters"][row["key"]]
        assert f"<td>{fmt(p['value'])}</td>" in page
        if row["status"] == "identified":  # an interval of its own only when the data determines it alone
            assert f"[{fmt(p['ci95'][0])}, {fmt(p['ci95'][1])}]" in page
        else:
            assert p["ci95"] is None and row["low"] is None
    for c in r["uncertainty"]["combinations"]:
        assert f"<li>{c['combination']} = {fmt(c['value'])} {c['unit']}, 95 % [{fmt(c['ci95'][0])}, " in page
    for key in r["sensor_corrections"]:
        assert f"<td>{fmt(r['uncertainty']['parameters'][key]['value'])}</td>" in page


def test_arrays_agree_with_the_report_metrics(rendered):
    """One source: the per-row errors give exactly the report's metrics and the workspace
    errors exactly the first named point's predicted RMS."""
    _result, r, _, _ = rendered
    res = r["residuals"]
    split = np.asarray(res["split"])
    assert sorted(res["rows"]) == sorted([*r["split"]["train"], *r["split"]["test"]])
    for name in ("train", "test"):
        for stage in ("before", "after"):
            m = Metrics.of(np.asarray(res[f"{stage}_mm"])[split == name] * 1e-3).as_dict()
            for key, value in m.items():
                assert value == pytest.approx(r[name][stage][key], rel=1e-12)
    error = np.asarray(r["workspace_uncertainty"]["error_mm"])
    first = r["accuracy"]["points"][0]
    assert r["workspace_uncertainty"]["point"] == first["name"]
    assert np.sqrt(np.mean(error**2)) == pytest.approx(first["rms_mm"], rel=1e-12)
    spec = r["identifiability_spectrum"]
    assert int(np.sum(np.asarray(spec["singular_values"]) > spec["cut"])) == r["identifiability"]["rank"]
    assert len(r["workspace_uncertainty"]["points_mm"]) == r["accuracy"]["poses"]


def test_self_contained_with_valid_pngs(rendered):
    _, r, _, page = rendered
    images = IMG.findall(page)
    assert len(images) == page.count("<img ") == 6
    for data in images:
        raw = base64.b64decode(data, validate=True)
        assert raw[:8] == b"\x89PNG\r\n\x1a\n" and raw[12:16] == b"IHDR"
        width, height = struct.unpack(">II", raw[16:24])
        assert width > 300 and height > 200
    text = IMG.sub("", page)
    assert not re.search(r"https?://", text)
    assert "<link" not in text and "src=" not in text  # no stylesheet, script or image to fetch
    kind = "device frame" if "device_frame" in r else "Cable anchor"
    assert kind in page


def test_outlier_rows_are_marked(tmp_path):
    result = calib_pin.calibrate("irb120", ROBOTS_DIR / "irb120_default.csv", method="lm", loss="cauchy")
    report = build_report(result)
    res = report["residuals"]
    marked = [row for row, bad in zip(res["rows"], res["outlier"], strict=True) if bad]
    assert marked == sorted(result.outlier_rows) and marked
    page = write_html_report(report, tmp_path / "r.html").read_text()
    listed = ", ".join(str(v) for v in result.outlier_rows) or "none"
    assert f"(data rows {listed})" in page


@pytest.mark.skipif(CHROMIUM is None, reason="no chromium installed (Debian package 'chromium')")
def test_browser_displays_every_figure(rendered, tmp_path):
    _, _, path, page = rendered
    flags = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             f"--user-data-dir={tmp_path / 'profile'}", "--window-size=1200,4000"]
    url = path.resolve().as_uri()
    dom = subprocess.run([CHROMIUM, *flags, "--dump-dom", url], check=True, capture_output=True, text=True, timeout=120).stdout
    n = page.count("<img ")
    assert f'data-images-ok="{n}/{n}"' in dom  # set on load: every image decoded (naturalWidth > 0)
    shot = tmp_path / "shot.png"
    subprocess.run([CHROMIUM, *flags, f"--screenshot={shot}", url], check=True, capture_output=True, timeout=120)
    raw = Path(shot).read_bytes()
    assert raw[:8] == b"\x89PNG\r\n\x1a\n" and struct.unpack(">II", raw[16:24]) == (1200, 4000)


def test_write_figures_for_the_readme(rendered, tmp_path):
    from calib_pin.report.html import write_figures

    _, r, _, _ = rendered
    paths = write_figures(r, tmp_path / "figs")
    assert sorted(p.name for p in paths) == sorted(
        ["residuals.png", "spectrum.png", "convergence.png", "deviations.png", "workspace.png", "sensor.png"])
    for p in paths:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_per_row_figure_thins_large_sets_and_says_so():
    """Above MAX_DRAWN_ROWS the per-row figure draws 1 row in k evenly (and every outlier),
    and the note says how many; at or below it every row is drawn and nothing is said."""
    pytest.importorskip("matplotlib")
    from calib_pin.report import figures

    outliers = np.zeros(10_000, dtype=bool)
    outliers[[1, 4_999]] = True
    rows = figures.drawn_rows(10_000, outliers)
    assert np.array_equal(rows, np.union1d(np.arange(0, 10_000, 4), [1, 4_999]))
    assert figures.decimation_note(10_000) == "1 in 4 of 10000 rows drawn, outliers always"
    assert np.array_equal(figures.drawn_rows(3_000), np.arange(3_000)) and figures.decimation_note(3_000) == ""


def test_a_camera_set_beside_a_cable_set_is_drawn_with_its_noise_in_px(tmp_path):
    pytest.importorskip("cv2")
    result = calib_pin.calibrate("irb120", [ROBOTS_DIR / "irb120_camera_example.csv", ROBOTS_DIR / "irb120_default.csv"],
                                 method="lm")
    report = build_report(result)
    assert report["noise_unit"] == "px" and report["noise_px"] == pytest.approx(0.1) and "noise_mm" not in report
    page = write_html_report(report, tmp_path / "r.html").read_text()
    assert "sensor noise assumed</th><td>0.1 px" in page
    assert "<td>0.1 px (file)</td>" in page and " mm (estimate)</td>" in page


def test_a_camera_set_reports_its_error_per_image(tmp_path):
    """A camera set's report gives each image's corners and RMS reprojection error before and after, in px
    (report.json's per_pose, report.html's 'Error per image', the worst first); a cable set, one row a pose,
    has none."""
    pytest.importorskip("cv2")
    result = calib_pin.calibrate("irb120", [ROBOTS_DIR / "irb120_camera_example.csv", ROBOTS_DIR / "irb120_default.csv"],
                                 method="lm")
    report = build_report(result)
    camera, cable = report["sets"]
    assert "per_pose" not in cable
    images = camera["per_pose"]
    assert len(images) == 12 and sum(p["rows"] for p in images) == camera["train_rows"] + camera["test_rows"]
    assert {p["split"] for p in images} == {"train", "test"}
    assert all(p["rms_after_px"] < 0.5 < p["rms_before_px"] for p in images)
    pooled = np.sqrt(sum(p["rms_after_px"] ** 2 * p["rows"] for p in images if p["split"] == "test")
                     / sum(p["rows"] for p in images if p["split"] == "test"))
    assert pooled == pytest.approx(camera["test"]["after"]["rmse_mm"], rel=1e-6)  # the set's own RMSE, in px
    page = write_html_report(report, tmp_path / "r.html").read_text()
    assert "Error per image" in page and "12 images, the worst after the fit first" in page
    assert "<th>corners</th><th>RMS before (px)</th><th>RMS after (px)</th>" in page


def test_a_camera_calibration_of_the_lens_draws_its_report(tmp_path):
    """With the intrinsics estimated (unit-free k1 ... k3 beside fx [px]) report.html is drawn, and report.json's
    intervals are keyed as its sensor corrections are (k1, not k1_)."""
    pytest.importorskip("cv2")
    from calib_pin.sensors import CameraModel, CameraSetup
    from calib_pin.simulation import simulate_set

    chain = calib_pin.load_chain("irb120")
    data, _ = simulate_set(CameraModel, chain, calib_pin.parameter_model(chain), 16, 2,
                           setup={"camera_mount": "eye-in-hand", "noise_px": 0.1})
    result = calib_pin.calibrate("irb120", data, method="lm", setup=CameraSetup(estimate="intrinsics"))
    report = build_report(result)
    assert {"fx_px", "k1", "p2"} <= set(report["sensor_corrections"]) <= set(report["uncertainty"]["parameters"])
    page = write_html_report(report, tmp_path / "report.html").read_text(encoding="utf-8")
    assert "<td>k1</td>" in page and "<td>fx</td><td>px</td>" in page
