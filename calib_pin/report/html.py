"""A calibration report a person reads in a browser: one self-contained HTML file.

One source: every number and figure comes from the report dict
(:func:`calib_pin.report.build.build_report`, what report.json holds, including the per-row
errors, the identifiability spectrum and the per-pose workspace uncertainty), so the
HTML and the JSON cannot disagree. Figures are PNGs embedded as base64 (no network,
opens from disk), drawn with matplotlib (the ``plots`` extra).
"""

from __future__ import annotations

import base64
import html
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pinocchio as pin

from ..util.atomic import write_text
from ..util.optional import require
from .build import accuracy_lines, noise_parts_line


def _fig() -> ModuleType:
    """The figure module (matplotlib, the ``plots`` extra).

    Raises:
        CalibPinError: matplotlib is not installed (the message names the pip command).
    """
    require("matplotlib")
    from . import figures

    return figures


def fmt(value: float | None) -> str:
    """How the report prints a number (4 significant digits; None as a dash)."""
    return "&mdash;" if value is None else f"{value:.4g}"


def deviation_rows(r: dict) -> list[dict]:
    """Robot deviations with their status and, when identified, their 95 % interval.

    Robot deviations with their status (:data:`calib_pin.analysis.uncertainty.STATUS`) and,
    for those the data determines alone, their 95 % interval (None otherwise), from the report.
    """
    params = (r.get("uncertainty") or {}).get("parameters", {})
    out = []
    for key in r["deviations"]:
        name, unit = key.rsplit("_", 1)
        p = params[key]
        low, high = p.get("ci95") or (None, None)
        out.append({"key": key, "name": name, "unit": unit, "value": p["value"], "std": p.get("std"),
                    "low": low, "high": high, "status": p["status"]})
    return out


def _img(data: bytes, alt: str) -> str:
    encoded = base64.b64encode(data).decode("ascii")
    return f'<img class="fig" alt="{html.escape(alt)}" src="data:image/png;base64,{encoded}">'


def _table(header: list[str], rows: list[list[str]], cls: str = "") -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows)
    return f'<table class="{cls}"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def _summary(r: dict) -> str:
    rows = []
    parts = r.get("errors_by_part")
    for split in ("train", "test"):
        if split in r:
            for stage in ("before", "after"):
                if parts:  # each part in its own unit, never one mixed number
                    rows.append([split, stage, *(fmt(m[k]) for m in parts[split][stage].values()
                                                 for k in m if k.startswith(("rmse_", "max_")))])
                    continue
                m = r[split][stage]
                rows.append([split, stage, fmt(m["rmse_mm"]), fmt(m["mean_mm"]), fmt(m["max_mm"])])
    n_train, n_test = len(r["split"]["train"]), len(r["split"]["test"])
    facts = [
        ("robot", f"{r['robot']} (end frame {r['end_frame']})"),
        ("data set", f"{r['data']} ({r['data_kind']}; {n_train} train, {n_test} test rows, seed {r['seed']})"),
        ("parameter model", r["model"]),
        ("method", f"{r['method']} (loss {r['loss']})"),
        ("time", f"{fmt(r['time_s'])} s"),
        ("iterations", f"{r['iterations']} ({fmt(r['evaluations'])} evaluations; {r['stop_reason']})"),
        ("sensor noise assumed", _noise(r)),
    ]
    if r.get("accuracy"):
        a = r["accuracy"]
        facts += [(f"predicted accuracy at {p['name']}", f"RMS {fmt(p['rms_mm'])} mm, p95 {fmt(p['p95_mm'])} mm over "
                   f"{a['poses']} workspace poses" + ("" if p["determined"] else " (not determined by the data: "
                                                      "mostly the prior)")) for p in a["points"]]
    dl = "".join(f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>" for k, v in facts)
    kind = r["error"]
    if parts:
        names = [k.rsplit("_", 1) for k in next(iter(next(iter(parts.values())).values()))]
        header = ["split", "stage", *(f"{name} {what} [{unit}]" for name, unit in names for what in ("RMSE", "max"))]
        title = "Errors, each part in its own unit"
    else:
        header, title = ["split", "stage", "RMSE", "mean", "max"], f"Errors [mm] ({kind})"
    return (f'<div class="row"><div><table class="facts">{dl}</table></div>'
            f'<div class="fit"><h3>{html.escape(title)}</h3>'
            + _table(header, rows, "num") + "</div></div>")


def _name_unit(key: str) -> tuple[str, str]:
    """A report key's name and unit: ``camera_x_mm`` -> (camera_x, mm); a unit-free one (a lens's ``k1``) -> (k1, "")."""
    from ..util.units import HUMAN_UNITS

    for _, suffix in HUMAN_UNITS.values():
        if suffix and key.endswith("_" + suffix):
            return key[: -len(suffix) - 1], suffix
    return key, ""


def _deviation_section(r: dict, rows: list[dict]) -> str:
    if not r.get("uncertainty"):
        return f"<p>Method {html.escape(r['method'])} estimates no kinematic parameters.</p>"
    start = "the start" if r.get("start") else "zero"
    label = {"identified": "determined by the data", "combination": "only in a combination (below)",
             "not determined": f"not determined: held at {start}", "held": "held (--fix/--free)"}
    css = {"identified": "identifiable", "combination": "combination", "not determined": "blind", "held": "blind"}
    body = [[html.escape(d["name"]), d["unit"], fmt(d["value"]),
             fmt(d["std"]) if d["std"] is not None else "&mdash;",
             f"[{fmt(d['low'])}, {fmt(d['high'])}]" if d["low"] is not None else "&mdash;",
             f'<span class="{css[d["status"]]}">{label[d["status"]]}</span>'] for d in rows]
    params = r["uncertainty"]["parameters"]
    sensor = [[html.escape(_name_unit(k)[0]), _name_unit(k)[1], fmt(params[k]["value"]),
               fmt(params[k].get("std")), f"[{fmt(params[k]['ci95'][0])}, {fmt(params[k]['ci95'][1])}]"
               if params[k].get("ci95") is not None else "&mdash;"] for k in r["sensor_corrections"]]
    ident = r["identifiability"]
    combos = "".join(f"<li>{html.escape(c['combination'])} = {fmt(c['value'])} {c['unit']}, 95 % "
                     f"[{fmt(c['ci95'][0])}, {fmt(c['ci95'][1])}]</li>"
                     for c in r["uncertainty"]["combinations"]) or "<li>none</li>"
    out = (_img(_fig().deviations(r, rows), "deviations with 95 % intervals")
           + '<div class="row"><div class="fit">'
           + _table(["parameter", "unit", "value", "std", "95 % interval", "status"], body, "num")
           + f"</div><div><p>Identifiable: {ident['rank']} of {ident['unknowns']} directions (condition "
           f"{fmt(ident['condition'])}). A deviation has an interval of its own only when the data determines it "
           f"alone; along what the data does not determine the robot stays at {start}, so the values of "
           "deviations determined only together are the start's split, not the data's. What the data determines "
           f"of them:</p><ul>{combos}</ul>")
    side = ""
    if r.get("compliances"):
        comp = [[html.escape(k), fmt(v["value"]), fmt(v["std"]), f"[{fmt(v['ci95'][0])}, {fmt(v['ci95'][1])}]"]
                for k, v in r["compliances"].items()]
        side += "<h3>Joint compliances</h3>" + _table(["compliance", "value", "std", "95 % interval"], comp, "num")
    if sensor:
        side += "<h3>Sensor geometry estimated with the robot</h3>" + _table(
            ["unknown", "unit", "value", "std", "95 % interval"], sensor, "num")
    return out + side + "</div></div>"


#: Key endings that name a unit (``anchor_mm``, ``rpy_deg``), shown in the geometry table's unit column.
UNITS = ("mm", "deg", "m", "rad")
#: Table names of top-level geometry keys whose bare name would be ambiguous: a contact set
#: reports its tool point (``tool_mm``) and whether it was given or estimated (``tool``),
#: which both read "tool" (a drawstring's ``tool_mm`` is its hook, a tool point too).
LABELS = {"tool_mm": "tool point (end frame)", "tool": "tool point given or estimated"}


def _cell(value: Any) -> str:
    """A geometry value for people: a number, a vector [a, b, c], a list of them, or text."""
    if isinstance(value, bool) or value is None:
        return html.escape(str(value))
    if isinstance(value, int | float):
        return fmt(value)
    if isinstance(value, list | tuple):
        if all(isinstance(v, int | float) and not isinstance(v, bool) for v in value):
            return "[" + ", ".join(fmt(v) for v in value) + "]"
        return "; ".join(_cell(v) for v in value)
    return html.escape(str(value))


def geometry_rows(geometry: dict, prefix: str = "") -> list[list[str]]:
    """A sensor's geometry as table rows (quantity, value, unit).

    The geometry is its model's ``geometry_report``, the unit in each key's ending; nested
    records flattened, their names joined by " / " (``device_frame / translation``), a
    top-level key of :data:`LABELS` by its name there. Names no sensor: any record a sensor
    reports is shown.
    """
    rows: list[list[str]] = []
    for key, value in geometry.items():
        name, _, unit = str(key).rpartition("_")
        if unit not in UNITS or not name:
            name, unit = str(key), ""
        label = LABELS[key] if not prefix and key in LABELS else f"{prefix}{name.replace('_', ' ')}"
        if isinstance(value, dict):
            if value and all(not isinstance(v, dict) for v in value.values()) and unit:  # labelled points in one unit
                rows += [[html.escape(f"{label} / {k}"), _cell(v), unit] for k, v in value.items()]
            else:
                rows += geometry_rows(value, f"{label} / ")
        else:
            rows.append([html.escape(label), _cell(value), unit])
    return rows


def _errors_by_part(doc: dict) -> str:
    """The table of a set's errors per part, each in its own unit (``errors_by_part``), or ""."""
    parts = doc.get("errors_by_part")
    if not parts:
        return ""
    rows = []
    for split, stages in parts.items():
        for stage, by in stages.items():
            for key, m in by.items():
                name, _, unit = key.rpartition("_")
                rows.append([split, stage, html.escape(name), unit, fmt(m[f"rmse_{unit}"]), fmt(m[f"mean_{unit}"]),
                             fmt(m[f"max_{unit}"])])
    noise = doc.get("noise_by_part")
    text = f"<p>{html.escape(noise_parts_line(noise).capitalize())}.</p>" if noise else ""
    return ("<h3>Errors per part, each in its own unit</h3>"
            + _table(["split", "stage", "part", "unit", "RMS", "mean", "max"], rows, "num") + text)


def _geometry_section(title: str, view: dict, describe: str) -> str:
    """One sensor's geometry as a table, with its description and its errors per part.

    Every key its ``geometry_report`` gives; the errors per part when its rows have parts.
    """
    keys = view.get("_geometry", {})
    head = f"<h3>{html.escape(title)}</h3>" if title else ""
    words = f"<p>{html.escape(describe)}</p>" if describe else ""
    return (head + words + _table(["quantity", "value", "unit"], geometry_rows(keys), "num geometry")
            + _errors_by_part(view))


def sensor_html(r: dict, figures: bool = True) -> str:
    """report.html's Sensor section: each sensor's description, geometry table and errors per part.

    One set, or each set in turn, with its figure where one is drawn.
    """
    return "".join(_geometry_section(title, v, str(v.get("sensor", ""))) + (_sensor_figure(v) if figures else "")
                   for title, v in sensor_views(r))


def _drawable(r: dict) -> bool:
    """Whether the sensor figure draws this geometry (a device frame with markers, a cable anchor).

    The others (a 6-D body, contact fixtures) have their table only.
    """
    return ("device_frame" in r and "markers_mm" in r) or all(k in r for k in ("anchor_mm", "tool_mm",
                                                                                 "length_offset_mm"))


def _sensor_figure(r: dict) -> str:
    """The sensor figure and its caption, or "" for a geometry it does not draw."""
    return _sensor_section(r) if _drawable(r) else ""


def _sensor_section(r: dict) -> str:
    if "device_frame" in r:
        frame = r["device_frame"]
        rotation = pin.rpy.rpyToMatrix(*np.deg2rad(frame["rpy_deg"]))
        text = (f"<p>Device frame ({html.escape(frame['meaning'])}): t = "
                f"[{', '.join(fmt(v) for v in frame['translation_mm'])}] mm, rpy = "
                f"[{', '.join(fmt(v) for v in frame['rpy_deg'])}] deg. Markers on the end frame [mm]: "
                + "; ".join(f"{html.escape(k)} [{', '.join(fmt(v) for v in m)}]" for k, m in r["markers_mm"].items())
                + ".</p>")
        return _img(_fig().sensor(r, rotation), "device frame and markers") + text
    return (_img(_fig().sensor(r), "cable anchor and hook")
            + f"<p>Cable anchor [{', '.join(fmt(v) for v in r['anchor_mm'])}] mm (base frame), hook "
            f"[{', '.join(fmt(v) for v in r['tool_mm'])}] mm (end frame), length offset "
            f"{fmt(r['length_offset_mm'])} mm.</p>")


def _noise(r: dict) -> str:
    """A report's or a set's noise with its unit (mm, px, ...), as text."""
    unit = r.get("noise_unit") or r.get("error_unit") or "mm"
    return f"{fmt(r[f'noise_{unit}'])} {unit}"


def _sets_section(r: dict) -> str:
    """A row per measurement set: its noise and where it came from, its rows and errors."""
    rows = []
    for s in r["sets"]:
        for split in ("train", "test"):
            if split in s:
                rows.append([html.escape(s["label"]), html.escape(str(s["data"])), f"{_noise(s)} ({s['noise_from']})",
                             split, str(s[f"{split}_rows"]), fmt(s[split]["before"]["rmse_mm"]),
                             fmt(s[split]["after"]["rmse_mm"])])
    return (_table(["set", "data", "noise", "split", "rows", "RMSE before", "RMSE after"], rows, "num")
            + "<p>One robot, each set with its own sensor set-up; rows weighted by their set's noise. The summary "
            f"pools {html.escape(r.get('metrics_pooled', 'every set'))}.</p>")


def _per_pose_section(r: dict) -> str:
    """Each set's error per pose (a camera's per image), in its unit: a table a set, worst after-fit first."""
    out = []
    for s in r.get("sets", ()):
        rows = s.get("per_pose")
        if not rows:
            continue
        unit = s.get("error_unit", "mm")
        what, items = s["pose_name"], s["row_name"]
        ranked = sorted(rows, key=lambda p: -p[f"rms_after_{unit}"])
        body = [[html.escape(str(p["id"])), p["split"], str(p["rows"]), fmt(p[f"rms_before_{unit}"]),
                 fmt(p[f"rms_after_{unit}"])] for p in ranked]
        title = f"<p>Set {html.escape(s['label'])}: {len(rows)} {what}s, the worst after the fit first.</p>" \
            if len(r["sets"]) > 1 else f"<p>{len(rows)} {what}s, the worst after the fit first.</p>"
        out.append(title + _table([what, "split", items, f"RMS before ({unit})", f"RMS after ({unit})"], body, "num"))
    return "".join(out)


def sensor_views(r: dict) -> list[tuple[str, dict]]:
    """The report's sensor geometry as (title, report-like dict) pairs: one, or one per set.

    ``_geometry``: what the sensor's ``geometry_report`` gave, report.json's
    ``sensor_geometry`` or the set's ``set_geometry``; a set's table, ``errors_by_part``
    among them, laid over the report's.
    """
    if "set_geometry" not in r:
        return [("", {**r, "_geometry": r.get("sensor_geometry", {})})]
    tables = {s["label"]: s for s in r.get("sets", ())}
    return [(f"Set {label}", {**r, **tables.get(label, {}), **geometry, "_geometry": geometry})
            for label, geometry in r["set_geometry"].items()]


CSS = """body{font-family:system-ui,sans-serif;max-width:1240px;margin:1.5em auto;padding:0 1em;color:#222}
.row{display:flex;gap:2em;flex-wrap:wrap;align-items:flex-start}.row>div{flex:1 1 0;min-width:280px}.row>div.fit{flex:0 0 auto}
h1{font-size:1.5em;margin-bottom:.2em}h2{border-bottom:2px solid #ddd;padding-bottom:.2em;margin-top:1.6em}
table{border-collapse:collapse;margin:.6em 0}td,th{border:1px solid #ccc;padding:.25em .6em;font-size:.9em}
table.num td{white-space:nowrap;text-align:right;font-variant-numeric:tabular-nums}
table.facts th{text-align:left;background:#f4f4f4}
img.fig{max-width:100%;display:block;margin:.6em 0;border:1px solid #eee}
.blind{color:#888}.combination{color:#7b3fa0}.identifiable{color:#1f5fa0}
.verdict{font-size:1.15em;background:#eef6ee;border-left:5px solid #3a3;padding:.5em .8em}
.verdict.worse{background:#fbeeee;border-color:#c33}nav a{margin-right:1em}"""

_MARK_IMAGES = """<script>window.addEventListener('load',function(){var i=document.images,n=0;
for(var k=0;k<i.length;k++){if(i[k].complete&&i[k].naturalWidth>0){n++;}}
document.body.setAttribute('data-images-ok',n+'/'+i.length);});</script>"""


def _verdict(r: dict) -> str:
    split = "test" if "test" in r else "train"
    if split not in r:  # several sets whose errors are in different units: no pooled score
        return ""
    b, a = r[split]["before"]["rmse_mm"], r[split]["after"]["rmse_mm"]
    cls = "verdict worse" if a > b else "verdict"
    return (f'<p class="{cls}">{split} RMSE {fmt(b)} mm before, {fmt(a)} mm after calibration '
            f"({r['data_kind']} data).</p>")


def _decimated(n_rows: int) -> str:
    """``; 1 in 34 of 100000 rows drawn, ...`` when the per-row figure is thinned, else ''."""
    from .figures import decimation_note

    note = decimation_note(n_rows)
    return f"; {note}, the distribution of all" if note else ""


def render_html(r: dict) -> str:
    """The report page of a report dict (:func:`calib_pin.report.build.build_report`).

    Args:
        r: The report dict, as report.json holds it.

    Raises:
        CalibPinError: matplotlib is not installed.
    """
    from ..util.progress import status

    status(f"drawing report.html ({len(r['residuals']['rows'])} rows; the first run in a new environment "
           "also builds matplotlib's font cache)")
    dev_rows = deviation_rows(r) if r.get("uncertainty") else []
    sections = [
        ("summary", "Summary", _verdict(r) + _summary(r)),
        ("residuals", "Error per data row", _img(_fig().residuals(r), "error per data row")
         + "<p>Blue: training rows, orange: held-out test rows; red rings: outliers of the robust loss "
         f"(data rows {html.escape(', '.join(str(v) for v in r['outlier_rows']) or 'none')})"
         f"{_decimated(len(r['residuals']['rows']))}.</p>"),
        ("deviations", "Deviations and identifiability", _deviation_section(r, dev_rows)),
    ]
    spectrum = (_img(_fig().spectrum(r), "singular values")
                + f"<p>Rank {r['identifiability_spectrum']['rank']}: singular values below the dashed cut "
                "are blind directions; the estimators do not move along them.</p>")
    convergence = _img(_fig().convergence(r), "convergence") + (
        f"<p>{r['iterations']} iterations, {fmt(r['evaluations'])} evaluations, {fmt(r['time_s'])} s.</p>")
    sections.append(("spectrum", "Identifiability spectrum | Convergence",
                     f'<div class="row"><div>{spectrum}</div><div>{convergence}</div></div>'))
    if r.get("accuracy"):
        lines = "\n".join(accuracy_lines(r["accuracy"]))
        sections.append(("workspace", "Accuracy where the robot works",
                         (_img(_fig().workspace(r), "predicted accuracy over the workspace")
                          if r.get("workspace_uncertainty") else "") + f"<pre>{html.escape(lines)}</pre>"))
    if len(r.get("sets", ())) > 1:  # one set's table is the summary's
        sections.insert(1, ("sets", "Measurement sets", _sets_section(r)))
    per_pose = _per_pose_section(r)
    if per_pose:
        names = {s["pose_name"] for s in r.get("sets", ()) if s.get("per_pose")}
        sections.append(("per-pose", f"Error per {names.pop()}" if len(names) == 1 else "Error per pose", per_pose))
    sections.append(("sensor", "Sensor", sensor_html(r)))
    nav = "".join(f'<a href="#{key}">{html.escape(title)}</a>' for key, title, _ in sections)
    body = "".join(f'<section id="{key}"><h2>{html.escape(title)}</h2>{content}</section>'
                   for key, title, content in sections)
    title = f"Calibration report: {r['robot']}, {r['method']}"
    return (f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>'
            f"<style>{CSS}</style></head><body><h1>{html.escape(title)}</h1><nav>{nav}</nav>{body}"
            f"{_MARK_IMAGES}</body></html>\n")


def write_html_report(report: dict[str, Any], path: str | Path) -> Path:
    """Write the self-contained HTML report of a report dict (``DIR/report.html``).

    Args:
        report: :func:`calib_pin.report.build.build_report`'s dict (what report.json holds).
        path: Output file.

    Raises:
        CalibPinError: matplotlib is not installed.
    """
    page = render_html(report)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text(path, page)
    return path


def write_figures(report: dict[str, Any], folder: str | Path) -> list[Path]:
    """Write the report's figures as PNG files (for a README), drawn from the report dict.

    Args:
        report: :func:`calib_pin.report.build.build_report`'s dict, e.g. a loaded report.json.
        folder: Where ``residuals.png``, ``deviations.png``, ``spectrum.png``,
            ``convergence.png``, ``workspace.png`` (kinematic methods) and ``sensor.png`` go.

    Raises:
        CalibPinError: matplotlib is not installed.
    """
    fig = _fig()
    drawn = {"residuals": fig.residuals(report), "spectrum": fig.spectrum(report),
             "convergence": fig.convergence(report)}
    if report.get("uncertainty"):
        drawn["deviations"] = fig.deviations(report, deviation_rows(report))
    if report.get("workspace_uncertainty"):
        drawn["workspace"] = fig.workspace(report)
    first = sensor_views(report)[0][1]  # several sets: the first set's sensor
    if not _drawable(first):
        pass  # a geometry the figure does not draw (a 6-D body, contact fixtures): its table is in the report
    elif "device_frame" in first:
        drawn["sensor"] = fig.sensor(first, pin.rpy.rpyToMatrix(*np.deg2rad(first["device_frame"]["rpy_deg"])))
    else:
        drawn["sensor"] = fig.sensor(first)
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, data in drawn.items():
        path = out / f"{name}.png"
        path.write_bytes(data)
        paths.append(path)
    return paths
