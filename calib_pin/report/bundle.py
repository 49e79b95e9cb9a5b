"""What a calibration writes, all together or none, through one function.

The corrected robot, the calibration file, report.html and report.json.

:func:`write_outputs` is what ``calibrate``, ``batch`` and library users call, so the same
rules hold for each:

* a fit beyond the sanity bound (:meth:`CalibrationResult.sanity_error`) writes no
  corrected robot and no calibration file; report.json is still written and gives the
  reason (``urdf_refused``); so does a method that learns no kinematics (``rbf``);
* every file goes through :class:`~calib_pin.util.outputs.Outputs`: written under
  temporary names and renamed together, and never one of the caller's inputs;
* a file an earlier run wrote in the folder that this run does not write (a stale URDF
  beside a fit refused in this run) is removed, unless it is an input;
* report.html needs a working matplotlib: without one a single warning line on stderr
  says so and everything else is written.

The work is in two steps: :func:`render_outputs` makes every file's text in memory (a
JSON-able :class:`RenderedOutputs`, which a batch worker returns and a checkpoint keeps),
and :func:`add_outputs` queues them in an :class:`Outputs` (a batch queues all its sets
in one, with its summary, and commits once).
"""

from __future__ import annotations

import io
import os
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..exceptions import ArgumentError, CalibPinError
from ..util.arguments import as_bool, as_instance, as_names, as_path
from ..util.outputs import Inputs, OutputError, Outputs, input_role
from .json_text import dumps_readable

if TYPE_CHECKING:
    from ..calibration.result import CalibrationResult
    from ..robot.chain import Chain

#: Export format -> what it writes.
EXPORTS = {"urdf": "corrected URDF", "yaml": "corrected joint origins for xacro (and ur_description's layout)",
           "dh": "corrected DH table (dh, hayati models)"}

#: Every file a calibration may write in its folder besides report.json, by name pattern
#: (one an earlier run left and this run does not write is removed).
STALE = ("{name}_calibrated.urdf", "{name}_calibration.json", "{name}_joint_origins.yaml",
         "{name}_default_kinematics.yaml", "{name}_dh.toml", "report.html", "{name}_hand_eye.yaml",
         "{name}_intrinsics.yaml", "{name}_*_hand_eye.yaml", "{name}_*_intrinsics.yaml")

_FILES = {"urdf": "{name}_calibrated.urdf", "yaml": "{name}_joint_origins.yaml", "dh": "{name}_dh.toml",
          "ur_kinematics": "{name}_default_kinematics.yaml"}


@dataclass
class RenderedOutputs:
    """A calibration's output files, made in memory and not yet written (JSON-able).

    Attributes:
        robot: The robot's name (the files' prefix).
        files: File name -> text, in the order they are written; report.json (last) is
            not among them: it is made from ``report`` when the folder is known.
        exports: Export format (``urdf``, ``yaml``, ``ur_kinematics``, ``dh``) -> file name.
        report: The report dict (:func:`calib_pin.report.build.build_report`) with
            ``urdf_refused``; ``urdf`` and ``exports`` are set by :func:`add_outputs`.
        refused: Why no corrected robot is written for a kinematic method (the
            sanity bound), else None.
        notes: Lines for the user (a correction ur_description's layout cannot hold).
    """

    robot: str
    files: dict[str, str]
    exports: dict[str, str]
    report: dict[str, Any]
    refused: str | None = None
    notes: list[str] = field(default_factory=list)


@dataclass
class WrittenOutputs:
    """What :func:`write_outputs` wrote.

    Attributes:
        files: The files written, in order (the exports, the calibration file,
            report.html, report.json).
        report: The report dict as written to report.json.
        refused: Why no corrected robot and no calibration file were written (a fit
            beyond the sanity bound), else None. report.json was written.
        notes: Lines for the user (a correction ur_description's layout cannot hold).
        removed: Files of an earlier run removed from the folder.
    """

    files: list[Path]
    report: dict[str, Any]
    refused: str | None
    notes: list[str]
    removed: list[Path] = field(default_factory=list)

    @property
    def folder(self) -> Path:
        """The folder of report.json."""
        return self.files[-1].parent


def check_exportable(formats: Sequence[str], chain: Chain, kinematic: bool = True) -> None:
    """Refuse, before a fit, a robot export its result could not be written in: the
    ``urdf`` and ``yaml`` of an end frame that is the last joint's own link
    (:func:`calib_pin.export.urdf.check_end_frame_writable`); a method that learns no
    kinematics (``kinematic`` False) exports nothing.

    Raises:
        RobotError: naming the end frame and what to do.
    """
    if kinematic and {"urdf", "yaml"} & set(formats):
        from ..export.urdf import check_end_frame_writable

        check_end_frame_writable(chain)


def check_formats(formats: str | Sequence[str], result: CalibrationResult | None = None) -> tuple[str, ...]:
    """``formats`` without repeats, each one of :data:`EXPORTS`, and one ``result`` can be written in.

    See :func:`check_exportable`.

    Args:
        formats: A sequence of names or ``"urdf,yaml"``.
        result: The calibration, to refuse a format it cannot be written in; None: not checked.

    Raises:
        ArgumentError: an unknown format, or none.
        CalibPinError: ``dh`` for the placement model (no DH table); an end frame no
            URDF or yaml can hold.
    """
    names = tuple(dict.fromkeys(as_names(formats, "formats")))
    unknown = [n for n in names if n not in EXPORTS]
    if unknown or not names:
        raise ArgumentError("formats", f"unknown export format '{unknown[0]}' (valid: {', '.join(EXPORTS)})" if unknown
                            else f"no export format given (valid: {', '.join(EXPORTS)})")
    if result is not None and "dh" in names and result.model_name == "placement":
        raise CalibPinError("the placement model has no DH table: the dh export needs the dh or hayati model "
                            "(urdf and yaml work for every model)")
    if result is not None:
        check_exportable(names, result.chain, result.kinematic)
    return names


def _exports(result: CalibrationResult, formats: Sequence[str], notes: list[str]) -> tuple[dict[str, str], dict[str, str]]:
    """(file name -> text, format -> file name) of the corrected robot in each format."""
    import numpy as np
    import pinocchio as pin

    from ..export.urdf import calibrated_urdf

    def yaml(tmp: Path) -> Any:
        from ..export.yaml import write_joint_origins_yaml  # PyYAML: imported when a YAML is written

        return write_joint_origins_yaml(result.chain, result.deltas, tmp, determined)

    def dh(tmp: Path) -> Any:
        from ..export.dh import write_dh_table

        return write_dh_table(result.params, result.problem.model.robot(result.x), tmp, determined)

    name = result.chain.name
    determined = result.determination_notes()
    setups = result.setup_exports()
    writers = {"urdf": lambda tmp: result.to_urdf(tmp), "yaml": yaml, "dh": dh}
    todo = [(fmt, _FILES[fmt].format(name=name)) for fmt in formats]
    if "yaml" in formats and name.startswith("ur"):
        todo.append(("ur_kinematics", _FILES["ur_kinematics"].format(name=name)))
    files: dict[str, str] = {}
    exports: dict[str, str] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for fmt, file in todo:
            path = Path(tmp) / file
            if fmt == "urdf":  # made in memory: the bytes result.to_urdf writes (the fit is within the bound here)
                frames = tuple(f for _, e in setups for f in e.frames)
                files[file] = _as_read(calibrated_urdf(result.chain, result.deltas, notes=determined, frames=frames))
                exports[fmt] = file
                continue
            if fmt == "ur_kinematics":
                from ..export.yaml import write_ur_kinematics_yaml

                rest = write_ur_kinematics_yaml(result.chain, result.deltas, path)
                if np.linalg.norm(pin.log6(rest).vector) > 1e-9:
                    notes.append(f"{file}: part of the tool0 correction does not fit ur_description's layout; "
                                 "its header gives it as a tool offset")
            else:
                writers[fmt](path)
            files[file] = path.read_text(encoding="utf-8")
            exports[fmt] = file
    for tag, e in setups:  # a sensor's calibrated set-up: the hand-eye transform, a camera's intrinsics
        for ending, text in e.files.items():
            files[f"{name}{tag}_{ending}"] = text
            exports[f"{Path(ending).stem}{tag}"] = f"{name}{tag}_{ending}"
    return files, exports


def _setup_files(result: CalibrationResult) -> list[str]:
    """The names of the files the sets' calibrated set-ups add (:meth:`CalibrationResult.setup_exports`)."""
    name = result.chain.name
    return [f"{name}{tag}_{ending}" for tag, e in result.setup_exports() for ending in e.files]


def _as_read(data: bytes) -> str:
    """``data`` as ``Path.read_text(encoding="utf-8")`` reads a file of these bytes.

    Universal newlines: a file's text made in memory is the text written and read back.
    """
    return io.TextIOWrapper(io.BytesIO(data), encoding="utf-8").read()


def planned_files(result: CalibrationResult, formats: str | Sequence[str] = ("urdf",), *,
                  html: bool = True) -> list[str]:
    """The names of the files :func:`write_outputs` may write for ``result``, in order.

    report.html is left out when matplotlib fails.
    """
    name = result.chain.name
    formats = check_formats(formats, result)
    files = []
    if result.kinematic and not result.sanity_error():
        files = [_FILES[fmt].format(name=name) for fmt in formats]
        if "yaml" in formats and name.startswith("ur"):
            files.append(_FILES["ur_kinematics"].format(name=name))
        files += _setup_files(result)
        if "urdf" in formats:
            files.append(f"{name}_calibration.json")
    return [*files, *(["report.html"] if html else []), "report.json"]


def _html(report: dict[str, Any], silence: str) -> str | None:
    """report.html's text, or None (one warning line on stderr) without a working matplotlib."""
    from ..util.optional import figures_or_warn

    def draw() -> str:
        from .html import render_html

        return render_html(report)

    return figures_or_warn("report.html", draw, silence)


def render_outputs(result: CalibrationResult, formats: str | Sequence[str] = ("urdf",), *, html: bool = True,
                   silence: str = "html=False silences this") -> RenderedOutputs:
    """Every file of ``result``'s outputs, in memory (nothing is written).

    Args:
        result: A calibration (:func:`calib_pin.calibrate`).
        formats: Formats of the corrected robot: ``urdf``, ``yaml`` (and ur_description's
            layout for ``ur*`` robots), ``dh`` (dh and hayati models).
        html: Make report.html (needs matplotlib; without it one warning line on stderr).
        silence: How the warning says to silence it (the CLI: ``--no-html``).

    Raises:
        CalibPinError: an unknown format, or ``dh`` with the placement model.
        OutputError: the temporary folder the files are made in cannot be written.
    """
    formats = check_formats(formats, result)
    try:
        return _render(result, formats, html, silence)
    except OSError as e:  # the temporary folder the files are made in (a full /tmp)
        raise OutputError(f"cannot make the outputs in a temporary folder: {e.strerror or e}; "
                          "no output was changed") from None


def _render(result: CalibrationResult, formats: tuple[str, ...], html: bool, silence: str) -> RenderedOutputs:
    from ..calibration.record import calibration_text
    from ..export.calibration_file import calibration_path
    from .build import build_report

    report = build_report(result)
    refused = result.sanity_error() if result.kinematic else None
    notes: list[str] = []
    files: dict[str, str] = {}
    exports: dict[str, str] = {}
    if result.kinematic and not refused:
        files, exports = _exports(result, formats, notes)
    report["urdf_refused"] = refused or (None if result.kinematic else
                                         f"{result.method} learns a correction of the measured values, which a URDF cannot hold")
    if "urdf" in exports:  # the calibration file goes with the URDF: geometry, compliance, sensor, versions
        files[calibration_path(".", result.chain.name).name] = _as_read(calibration_text(result).encode("utf-8"))
    if html:
        page = _html({**report, "urdf": None, "exports": {}}, silence)
        if page is not None:
            files["report.html"] = page
    return RenderedOutputs(result.chain.name, files, exports, report, refused, notes)


def report_in(rendered: RenderedOutputs, folder: str | os.PathLike[str]) -> dict[str, Any]:
    """``rendered.report`` with the paths of its files in ``folder`` (``urdf``, ``exports``)."""
    folder = Path(folder)
    exports = {fmt: str(folder / file) for fmt, file in rendered.exports.items()}
    report = dict(rendered.report)
    report["urdf"] = exports.get("urdf")
    report["exports"] = exports
    urdf_refused = report.pop("urdf_refused", None)
    report["urdf_refused"] = urdf_refused
    return report


def _writer(text: str) -> Callable[[Path], Any]:
    """A writer of ``text`` (UTF-8) to the temporary path it is given."""
    return lambda tmp: tmp.write_text(text, encoding="utf-8")


def add_outputs(out: Outputs, rendered: RenderedOutputs, folder: str | os.PathLike[str] | None = None) -> dict[str, Any]:
    """Queue ``rendered``'s files and its report.json in ``out``; the report as report.json holds it.

    Args:
        out: The output writer.
        rendered: The files' text (:func:`render_outputs`).
        folder: Where they go; default ``out.folder``.

    Raises:
        OutputError: a file is one of ``out``'s inputs, a folder, a device.
    """
    folder = Path(out.folder if folder is None else folder)
    report = report_in(rendered, folder)
    for file, text in rendered.files.items():
        out.add(folder / file, _writer(text))
    out.add(folder / "report.json", _writer(dumps_readable(report) + "\n"))
    return report


def stale_files(folder: str | os.PathLike[str], robot: str) -> list[Path]:
    """The files a calibration of ``robot`` may write in ``folder`` besides report.json.

    A pattern with ``*`` (a set's own hand-eye file) names the files in ``folder`` it matches.
    """
    import glob

    folder = Path(folder)
    out = []
    for pattern in STALE:
        if "*" in pattern:
            head, tail = pattern.split("*")
            out += sorted(folder.glob(glob.escape(head.format(name=robot)) + "*" + tail))
        else:
            out.append(folder / pattern.format(name=robot))
    return out


def remove_stale(candidates: Sequence[Path], written: Sequence[Path], inputs: Inputs | None = None) -> list[Path]:
    """Remove each of ``candidates`` that exists, was not ``written`` and is no input.

    Returns the files removed.
    """
    kept = {os.path.abspath(p) for p in written}
    removed = []
    for path in dict.fromkeys(candidates):
        if os.path.abspath(path) in kept or not path.is_file() or input_role(path, inputs or {}) is not None:
            continue
        path.unlink()
        removed.append(path)
    return removed


def write_outputs(result: CalibrationResult, folder: str | os.PathLike[str], formats: str | Sequence[str] = ("urdf",), *,
                  html: bool = True, inputs: Inputs | None = None, notes: list[str] | None = None,
                  silence: str = "html=False silences this") -> WrittenOutputs:
    """Write a calibration's outputs in ``folder``, all together or none.

    ``folder/<robot>_calibrated.urdf`` (and the other ``formats``),
    ``folder/<robot>_calibration.json`` (with the URDF), ``folder/report.html`` (``html``)
    and ``folder/report.json``. A fit beyond the sanity bound writes report.json only,
    with the reason in ``urdf_refused`` and in the returned ``refused``; ``rbf`` writes
    no corrected robot either. Files an earlier calibration of the robot left in
    ``folder`` that this one does not write are removed (never one of ``inputs``).
    Existing outputs are replaced; an input is never an output.

    Args:
        result: A calibration (:func:`calib_pin.calibrate`).
        folder: The output folder (made if missing).
        formats: ``urdf``, ``yaml``, ``dh`` (see :func:`render_outputs`): a sequence or ``"urdf,yaml"``.
        html: Write report.html (needs matplotlib: without it one warning line on
            stderr, and the rest is written).
        inputs: The caller's input files by label (``{"--data": "s.csv"}``): none is
            ever written over or removed.
        notes: A list the notes for the user are appended to (also in the result).
        silence: How the missing-matplotlib warning says to silence it.

    Returns:
        The files written, the report, the refusal reason (or None) and the notes.

    Raises:
        ArgumentError: an argument of the wrong type, an unknown format.
        CalibPinError: ``dh`` with the placement model.
        OutputError: an output is an input or a folder, or could not be written
            (nothing was then changed).
    """
    from ..calibration.result import CalibrationResult

    as_instance(result, "result", CalibrationResult, "a CalibrationResult (calib_pin.calibrate)")
    folder = as_path(folder, "folder")
    formats = check_formats(formats, result)
    html = as_bool(html, "html")
    inputs = dict(as_instance(inputs if inputs is not None else {}, "inputs", Mapping, "a mapping {label: path}"))
    for path in inputs.values():
        if path is not None and path != "":
            as_path(path, "inputs")
    as_instance(notes if notes is not None else [], "notes", list, "a list (the notes are appended to it) or None")
    out = Outputs(folder, inputs=inputs)
    for file in planned_files(result, formats, html=html):  # refused before the work that makes them
        out.check(out.folder / file)
    rendered = render_outputs(result, formats, html=html, silence=silence)
    report = add_outputs(out, rendered)
    written = out.commit()
    removed = remove_stale(stale_files(out.folder, rendered.robot), written, out.inputs)
    if notes is not None:
        notes.extend(rendered.notes)
    return WrittenOutputs(written, report, rendered.refused, list(rendered.notes), removed)


__all__ = ["EXPORTS", "STALE", "RenderedOutputs", "WrittenOutputs", "add_outputs", "check_exportable", "check_formats",
           "planned_files", "remove_stale", "render_outputs", "report_in", "stale_files", "write_outputs"]
