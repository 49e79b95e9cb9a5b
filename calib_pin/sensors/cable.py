"""The drawstring (cable) sensor: predicted readings and their identification Jacobian.

A drawstring sensor whose body sits at a fixed point P0 of the base frame reads the
distance to a tool point p on the end effector, plus a zero offset (paper eq. 6-7):

    reading(q) = || p(q, x) - P0 || + length_offset.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from ..exceptions import ArgumentError, DataError
from ..measurements.schema import SCHEMAS, Schema
from ..robot.chain import Chain
from ..robot.deflection import ComplianceSpec
from ..util.arguments import MAX_MM, as_array, as_float, as_optional, as_point_mm, too_far
from .base import SETUP_MISFIT_M, MeasurementModel, check_rows, chosen, fit_rows_name
from .misreading import setup_in_metres
from .problem import SetProblem
from .registry import check_estimate
from .setup import SensorSetup, estimate_names, finite, option, point_mm

if TYPE_CHECKING:
    from ..measurements import MeasurementSet
    from ..parameters import ParameterModel

#: Sensor quantities a cable model can estimate with the robot's parameters.
CABLE_EXTRAS = ("anchor", "offset", "tool")

#: The pre-fit's starts per axis (:func:`fit_drawstring`): a grid of PREFIT_GRID^3 anchors.
PREFIT_GRID = 3

#: Default sensor geometry of simulated sessions: the sensor body on the floor in
#: front of the robot, the cable hooked on the tool axis 50 mm out of the flange.
DEFAULT_ANCHOR_MM = (600.0, 200.0, -100.0)
DEFAULT_TOOL_MM = (0.0, 0.0, 50.0)
#: Spread of the anchors drawn for simulated sessions 2.. around the default anchor, base
#: frame, per axis, [mm] (a drawstring re-anchored elsewhere on the floor or a fixture).
SESSION_ANCHOR_SPREAD_MM = (400.0, 400.0, 150.0)


@dataclass(frozen=True)
class Drawstring:
    """Geometry of a drawstring sensor.

    Attributes:
        anchor: P0, the sensor's fixed point, shape (3,), [m], base frame.
        tool: The tool point where the cable hooks on, shape (3,), [m], end frame.
        length_offset: Zero offset added to the distance, [m].
    """

    anchor: np.ndarray
    tool: np.ndarray
    length_offset: float = 0.0

    def __post_init__(self) -> None:
        """Checked as given (a list is fine): 3 finite numbers each, a finite offset, [m].

        Raises:
            ArgumentError: naming ``anchor``, ``tool`` or ``length_offset``.
        """
        object.__setattr__(self, "anchor", as_array(self.anchor, "anchor", (3,), unit="m"))
        object.__setattr__(self, "tool", as_array(self.tool, "tool", (3,), unit="m"))
        object.__setattr__(self, "length_offset", as_float(self.length_offset, "length_offset", unit="m"))

    @classmethod
    def _unchecked(cls, anchor: np.ndarray, tool: np.ndarray, length_offset: float) -> Drawstring:
        """A geometry an estimator is trying (its x may be anything on the way): not checked."""
        sensor = object.__new__(cls)
        for name, value in (("anchor", anchor), ("tool", tool), ("length_offset", length_offset)):
            object.__setattr__(sensor, name, value)
        return sensor

    def to_dict(self) -> dict:
        """In mm, the measurement file's metadata names."""
        return {"anchor_mm": (self.anchor * 1e3).tolist(), "tool_mm": (self.tool * 1e3).tolist(),
                "length_offset_mm": self.length_offset * 1e3}

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> Drawstring:
        """Inverse of :meth:`to_dict`.

        Raises:
            ValueError: a point beyond :data:`~calib_pin.util.arguments.POINT_REACH_MM`.
        """
        for key, frame in (("anchor_mm", "base"), ("tool_mm", "end frame")):
            why = too_far(np.asarray(doc[key], dtype=float), frame)
            if why is not None:
                raise ValueError(f"{key}: {why}")
        return cls(np.array(doc["anchor_mm"], dtype=float) * 1e-3, np.array(doc["tool_mm"], dtype=float) * 1e-3,
                   float(doc["length_offset_mm"]) * 1e-3)


@dataclass(frozen=True, eq=False)
class CableSetup(SensorSetup):
    """A drawstring's set-up options, each None when not given, checked once here.

    A field not given is the measurement file's ``# anchor_mm`` / ``# tool_mm`` /
    ``# length_offset_mm``.

    Attributes:
        anchor_mm: The sensor's point P0 in the base frame, shape (3,), [mm].
        tool_mm: The tool point where the cable hooks on, in the end frame, shape (3,), [mm].
        length_offset_mm: The sensor's zero offset, [mm].
        estimate: Geometry estimated with the robot: ``anchor``, ``offset`` (names, in order given).

    Raises:
        ArgumentError: naming the field.
    """

    title: ClassVar[str] = "drawstring"

    anchor_mm: Any = option(help="sensor point P0 in the base frame, 'x,y,z'", unit="mm", parser=point_mm("base"))
    tool_mm: Any = option(help="tool point in the end frame (where a cable hooks on), 'x,y,z'", unit="mm",
                          parser=point_mm("end frame"))
    length_offset_mm: Any = option(help="sensor zero offset", unit="mm", parser=finite)
    estimate: Any = option((), help="drawstring geometry to estimate with the robot, comma-separated: anchor, "
                           "offset, tool (the tool point in the end frame); a set without '# anchor_mm' has its "
                           "anchor and offset pre-fitted and estimated", parser=estimate_names)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "anchor_mm", as_optional(as_point_mm, self.anchor_mm, "anchor_mm", "base"))
        set_(self, "tool_mm", as_optional(as_point_mm, self.tool_mm, "tool_mm", "end frame"))
        set_(self, "length_offset_mm", as_optional(as_float, self.length_offset_mm, "length_offset_mm", -MAX_MM,
                                                   MAX_MM, unit="mm"))
        set_(self, "estimate", check_estimate(self.estimate))


def _gives_offset(data: MeasurementSet) -> bool:
    """The set's file (or, in memory, a non-zero value) gives the zero offset."""
    from ..measurements.checks import _file_keys

    keys = _file_keys(data.source) if data.source else None
    return bool({"length_offset_mm", "length_offset_m"} & keys) if keys is not None else data.length_offset != 0.0


def _check_setup_fits(model: CableModel, data: MeasurementSet, options: Mapping[str, Any]) -> None:
    """Refuse a known set-up whose cable lengths at the nominal robot are not the readings.

    The set-up is the anchor, tool point and offset, the caller's or the file's. A miss is
    a unit mistake or an anchor in another frame: a first fit would chase it and say only
    that the noise is metres.

    A miss that is the same on every row (spread under 25 mm: a robot's deviations) is the
    offset's; another names the whole set-up (the field: the caller's one key, else its anchor, else none).

    Raises:
        DataError: naming the file, the set-up's values (each given or the file's), the
            lengths and the readings.
    """
    rows = check_rows(len(data.q))
    lengths, readings = model.predict(None, data.q[rows]), data.values[rows]
    miss = lengths - readings
    misfit = float(np.median(np.abs(miss)))
    if not misfit > SETUP_MISFIT_M:  # NaN-safe: a reading NaN is the checks' business
        return
    sensor = model.sensor
    values = {"anchor_mm": sensor.anchor * 1e3, "tool_mm": sensor.tool * 1e3,
              "length_offset_mm": np.array([sensor.length_offset * 1e3])}

    def said(key: str, named: bool = True) -> str:
        origin = "given" if options.get(key) is not None else "the file's"
        return f"{key + ' ' if named else ''}{','.join(f'{v:g}' for v in values[key])} mm ({origin})"

    # Only the offset wrong: the miss is the same on every row to the robot's deviations (mm).
    field: str | None = "length_offset_mm"
    if float(np.std(miss)) < 0.05 * SETUP_MISFIT_M:
        what = (f"{said('length_offset_mm', False)} does not fit the readings: they miss the cable lengths at the nominal robot "
                f"by the same {float(np.median(miss)):+.4g} m on every row (the zero offset's; with "
                f"{said('anchor_mm')}, {said('tool_mm')})")
    else:
        # Any of them may be wrong: the message names each, and the field is the caller's own input
        # (the one key given, else the anchor if given: a far-off anchor is the usual cause), or none.
        typed = [k for k in values if options.get(k) is not None]
        field = typed[0] if len(typed) == 1 else ("anchor_mm" if "anchor_mm" in typed else None)
        what = (f"the set-up ({said('anchor_mm')}, {said('tool_mm')}, {said('length_offset_mm')}) does not fit the "
                f"readings: the cable lengths at the nominal robot are {lengths.min():.4g}-{lengths.max():.4g} m, "
                f"the readings {readings.min():.4g}-{readings.max():.4g} m, a median miss of {misfit:.4g} m")
    raise DataError(data.source, f"{what} (valid: within {SETUP_MISFIT_M:g} m, a robot's deviation): a unit or "
                    "frame mistake?", None, field)


class CableModel(MeasurementModel):
    """Drawstring readings of a chain whose deviations follow a parameter model.

    With ``estimate`` the sensor's anchor P0 (``anchor_x/y/z`` [m], base frame, typical
    error 2 mm), its zero offset (``offset`` [m], 1 mm) and the tool point (``tool_x/y/z``
    [m], end frame, 1 mm) join x after the robot's deviations, as corrections to
    ``sensor``'s values.

    Attributes:
        prefit: How ``sensor`` was found when the data did not give it (a set without
            ``# anchor_mm``: :func:`fit_drawstring` on the training rows), else None.
    """

    prefit: DrawstringPrefit | None = None

    schema: ClassVar[Schema] = SCHEMAS["cable"]
    values_per_row = 1
    geometry_type = Drawstring
    error_name = "reading error"
    estimable = CABLE_EXTRAS
    setup_type = CableSetup
    misreadings = (*MeasurementModel.misreadings, setup_in_metres(("anchor_mm", "base"), ("tool_mm", "end frame")))

    def __init__(self, chain: Chain, params: ParameterModel, sensor: Drawstring, estimate: tuple[str, ...] = (),
                 compliance: ComplianceSpec | None = None) -> None:
        if not isinstance(sensor, Drawstring):
            raise ArgumentError("sensor", f"expected a Drawstring (anchor, tool [m], length_offset [m]), got "
                                f"{type(sensor).__name__}")
        self.estimate = chosen(estimate, CABLE_EXTRAS, "a drawstring")
        extra = [(f"anchor_{a}", "m", 2e-3) for a in "xyz"] if "anchor" in self.estimate else []
        extra += [("offset", "m", 1e-3)] if "offset" in self.estimate else []
        extra += [(f"tool_{a}", "m", 1e-3) for a in "xyz"] if "tool" in self.estimate else []
        # The cable pulls from the given tool point towards the given anchor (not a correction of it).
        super().__init__(chain, params, extra, compliance, cable=(sensor.tool, sensor.anchor))
        self.sensor = sensor

    @classmethod
    def planning_model(cls, chain: Chain, params: ParameterModel, setup: Any) -> CableModel:
        """The drawstring at ``setup``'s points, estimating ``setup.estimate``.

        ``setup`` is a :class:`CableSetup`; the simulator's defaults stand for points not given.
        """
        setup = setup if setup is not None else CableSetup()
        anchor = setup.anchor_mm if setup.anchor_mm is not None else DEFAULT_ANCHOR_MM
        tool = setup.tool_mm if setup.tool_mm is not None else DEFAULT_TOOL_MM
        return cls(chain, params, Drawstring(np.array(anchor) * 1e-3, np.array(tool) * 1e-3), setup.estimate)

    @classmethod
    def setup_of(cls, data: MeasurementSet) -> CableSetup:
        """The set-up the set's file gave (``anchor``, ``tool``, ``length_offset``), in [mm].

        Not checked (:func:`~calib_pin.measurements.checks.check_measurements` does).
        """
        setup = object.__new__(CableSetup)
        for name, value in (("anchor_mm", data.anchor), ("tool_mm", data.tool), ("length_offset_mm", data.length_offset)):
            object.__setattr__(setup, name, None if value is None else np.asarray(value, dtype=float) * 1e3)
        object.__setattr__(setup, "estimate", ())
        return setup

    @classmethod
    def problem_for(cls, chain: Chain, params: ParameterModel, data: MeasurementSet,
                    fit_rows: np.ndarray, options: Mapping[str, Any]) -> SetProblem:
        cls.refuse_foreign(options, data)
        get = options.get
        # the options' points come from a CableSetup record, checked when it was made [mm]
        anchor = np.asarray(get("anchor_mm")) * 1e-3 if get("anchor_mm") is not None else data.anchor
        tool = np.asarray(get("tool_mm")) * 1e-3 if get("tool_mm") is not None else data.tool
        estimate = tuple(get("estimate") or ())
        if tool is None and "tool" not in estimate:
            raise DataError(data.source, "no tool point: add '# tool_mm: x, y, z', pass --tool-mm, or estimate it "
                            "(--estimate tool)", None, "tool_mm")
        given = get("length_offset_mm")
        offset = data.length_offset if given is None else float(given) * 1e-3
        prefit = None
        if anchor is None:  # no anchor known: fit the set-up on the training rows first, then estimate it
            prefit = fit_drawstring(chain, params, data.q[fit_rows], data.values[fit_rows],
                                    np.zeros(3) if tool is None else tool, "tool" in estimate, data.source,
                                    rows=fit_rows_name(options))
            anchor, tool, offset = prefit.sensor.anchor, prefit.sensor.tool, prefit.sensor.length_offset
            estimate = tuple(dict.fromkeys(("anchor", "offset") + estimate))
        if tool is None:  # estimated, the anchor known: its start fitted on the nominal robot
            tool = fit_tool_point(chain, params, data.q[fit_rows], data.values[fit_rows], anchor, offset, data.source,
                                  fit_rows_name(options))
        model = cls(chain, params, Drawstring(anchor, tool, offset), estimate, get("compliance"))
        model.prefit = prefit
        if prefit is None:
            _check_setup_fits(model, data, options)
        return SetProblem(model, data.q, data.values)

    @classmethod
    def simulate_rows(cls, draw: Any, geometry: Drawstring | None) -> tuple[MeasurementSet, Drawstring]:
        """A simulated drawstring session (:meth:`MeasurementModel.simulate_rows`).

        Poses with the tool point above the mounting plane (z > 0), each reading's noise of
        ``draw.noise_kind``; ``geometry`` None: the default anchor and tool point, no offset.
        """
        from ..measurements import MeasurementSet

        sensor = geometry if geometry is not None else Drawstring(
            np.asarray(DEFAULT_ANCHOR_MM) * 1e-3, np.asarray(DEFAULT_TOOL_MM) * 1e-3, 0.0)
        chain, params = draw.chain, draw.params
        cable = cls(chain, params, sensor)
        poses = draw.poses(lambda q: cable.tool_positions(None, q)[:, 2] > 0.0,
                           "put the tool point above the base's mounting plane (z > 0); check the tool point")
        nominal = cable.predict(np.zeros(len(params.names)), poses)
        draw.deviations(lambda x: np.abs(cable.predict(x, poses) - nominal))
        noise = draw.noise(len(poses))
        readings = cls(chain, params, sensor, compliance=draw.compliance).predict(draw.x_model, poses) + noise
        data = MeasurementSet(q=poses, values=readings, kind=cls.kind, anchor=sensor.anchor, tool=sensor.tool,
                              length_offset=sensor.length_offset, robot=chain.name, end_frame=chain.end_frame,
                              notes={"source": f"calib-pin simulator, seed {draw.seed}, noise {draw.noise_mm:g} mm "
                                               f"({draw.noise_kind})"})
        return data, sensor

    @classmethod
    def session_geometry(cls, first: Drawstring, rng: np.random.Generator) -> Drawstring:
        """A later session's drawstring: re-anchored, the same tool point and offset.

        Re-anchored uniformly within :data:`SESSION_ANCHOR_SPREAD_MM` of the default anchor.
        """
        spread = np.asarray(SESSION_ANCHOR_SPREAD_MM)
        anchor = np.asarray(DEFAULT_ANCHOR_MM) + rng.uniform(-spread, spread)
        return Drawstring(anchor * 1e-3, first.tool, first.length_offset)

    @classmethod
    def registration_problem(cls, chain: Chain, params: ParameterModel, session: MeasurementSet, rows: np.ndarray,
                             calibrated: MeasurementModel, x: np.ndarray,
                             options: Mapping[str, Any]) -> SetProblem:
        """The problem of a re-anchored session: its anchor estimated.

        The anchor starts from its file's anchor or, without one, is pre-fitted on ``rows``
        (:func:`fit_drawstring`, the offset held). The tool point and the zero offset belong
        to the tool and the instrument, not to where the sensor sits: the session's file's
        when it gives them, else the calibration's (as calibrated).
        """
        assert isinstance(calibrated, CableModel)
        known = calibrated.geometry_at(x)
        tool = known.tool if session.tool is None else session.tool
        offset = session.length_offset if _gives_offset(session) else known.length_offset
        anchor, prefit = session.anchor, None
        if anchor is None:
            prefit = fit_drawstring(chain, params, session.q[rows], session.values[rows], tool, source=session.source,
                                    offset=offset, rows=fit_rows_name(options))
            anchor = prefit.sensor.anchor
        model = cls(chain, params, Drawstring(anchor, tool, offset), ("anchor",), options.get("compliance"))
        model.prefit = prefit
        return SetProblem(model, session.q, session.values)

    @classmethod
    def check_same_setup(cls, session: MeasurementSet, training: MeasurementSet, options: Mapping[str, Any]) -> None:
        """Refuse a validation session whose own drawstring set-up contradicts the calibration's.

        The set-up is ``anchor_mm``, ``tool_mm``, ``length_offset_mm``; the calibration's is
        the training set's, or the caller's overrides in ``options``. Agreement within
        :data:`SETUP_TOLERANCE_M`, or a session that does not say, is fine.

        Args:
            session: The validation session's readings.
            training: The training set whose set-up it shares.
            options: The caller's sensor options for that set ([mm]).

        Raises:
            DataError: naming the session's file, the key and both values.
        """
        from ..measurements.checks import SETUP_TOLERANCE_M, _file_keys, _mm

        keys = _file_keys(session.source) if session.source else None
        for name in ("anchor", "tool", "length_offset"):
            key = f"{name}_mm"
            own = getattr(session, name)
            if name == "length_offset":
                given = (keys is not None and bool({"length_offset_mm", "length_offset_m"} & keys)) or (
                    keys is None and own != 0.0)
                if not given:
                    continue
            elif own is None:
                continue
            override = options.get(key)
            used = np.asarray(override, dtype=float) * 1e-3 if override is not None else getattr(training, name)
            if used is None:  # the calibration fitted it (pre-fit): a stated one cannot be checked against it
                raise DataError(session.source or "test_data",
                                f"the validation session has {_mm(own)} mm, the calibration's is fitted on its training "
                                f"rows ({training.source or 'the training set'} gives none): leave the session's line "
                                "out to score it with the calibrated one, or re-register the session on its own "
                                "first poses (register=K)", None, key)
            if not np.allclose(np.asarray(own, dtype=float), used, rtol=0.0, atol=SETUP_TOLERANCE_M):
                by = "given" if override is not None else (training.source or "the training set")
                raise DataError(session.source or "test_data",
                                f"the validation session has {_mm(own)} mm, the calibration {_mm(used)} mm ({by}): "
                                "measure both with the same set-up, re-register the session on its own first poses "
                                "(register=K), or correct the file's line", None, key)

    def geometry_at(self, x: np.ndarray | None) -> Drawstring:
        """The sensor geometry x implies (``sensor`` plus the estimated corrections)."""
        if x is None or not self.estimate:
            return self.sensor
        extra = self.sensor_part(x)
        anchor, offset = self.sensor.anchor, self.sensor.length_offset
        if "anchor" in self.estimate:
            anchor, extra = anchor + extra[:3], extra[3:]
        tool = self.sensor.tool
        if "offset" in self.estimate:
            offset, extra = offset + extra[0], extra[1:]
        if "tool" in self.estimate:
            tool = tool + extra[:3]
        return Drawstring._unchecked(anchor, tool, offset)

    def geometry_report(self, x: np.ndarray | None) -> dict:
        """The geometry at x (mm), and ``setup_prefit`` when the anchor was pre-fitted."""
        doc = self.geometry_at(x).to_dict()
        if self.prefit is not None:
            doc["setup_prefit"] = self.prefit.as_dict()
        return doc

    def describe(self) -> str:
        known = [p for p in ("anchor", "offset") if p not in self.estimate]  # the tool point: known unless estimated
        text = "drawstring sensor, " + (f"{' and '.join(known)} known" if known else "nothing known")
        text += f", {' and '.join(self.estimate)} estimated" if self.estimate else ""
        return text + (f" ({self.prefit.how()})" if self.prefit is not None else "")

    @property
    def reference_point(self) -> np.ndarray:
        return self.sensor.tool

    def measured_points(self, x: np.ndarray | None) -> tuple[tuple[str, np.ndarray], ...]:
        return (("hook", np.asarray(self.geometry_at(x).tool, dtype=float)),)

    def tool_positions(self, x: np.ndarray | None, q: np.ndarray) -> np.ndarray:
        """Tool point in the base frame, shape (n_rows, 3), [m]; x None: nominal."""
        return self.points_at(x, q, self.geometry_at(x).tool)

    def predict(self, x: np.ndarray | None, q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        """Predicted readings, shape (n_rows,), [m], for joint angles q (n_rows, n) [rad]."""
        sensor = self.geometry_at(x)
        return np.linalg.norm(self.tool_positions(x, q) - sensor.anchor, axis=1) + sensor.length_offset

    def predict_many(self, xs: list[np.ndarray], q: np.ndarray, points: np.ndarray | None = None) -> list[np.ndarray]:
        """:meth:`predict` at several x, the tool positions in one batched pass."""
        sensors = [self.geometry_at(x) for x in xs]
        tips = self.points_at_many(xs, q, [s.tool for s in sensors])
        if tips is None:
            return super().predict_many(xs, q, points)
        return [np.linalg.norm(t - s.anchor, axis=1) + s.length_offset for t, s in zip(tips, sensors, strict=True)]

    def predict_with_jacobian(self, x: np.ndarray, q: np.ndarray,
                              points: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Predicted readings (n_rows,) [m] and their derivative (n_rows, n_params)."""
        sensor = self.geometry_at(x)
        tips, end_rot, d_tips = self.points_with_jacobians(x, q, sensor.tool)
        cable = tips - sensor.anchor
        length = np.linalg.norm(cable, axis=1)
        direction = cable / length[:, None]
        jac = np.einsum("ni,nij->nj", direction, d_tips)
        col = self.sensor_start
        if "anchor" in self.estimate:
            jac[:, col : col + 3] = -direction
            col += 3
        if "offset" in self.estimate:
            jac[:, col] = 1.0
            col += 1
        if "tool" in self.estimate:  # the tool point moves with the end frame: d p / d tool = R_end
            jac[:, col : col + 3] = np.einsum("ni,nij->nj", direction, end_rot)
        return length + sensor.length_offset, jac


@dataclass(frozen=True)
class DrawstringPrefit:
    """What :func:`fit_drawstring` found.

    Attributes:
        sensor: The fitted geometry (anchor [m] base frame, tool [m] end frame, offset [m]).
        tool_fitted: The tool point was fitted too (else held at the given one).
        starts: Starts tried; ``agreeing``: how many of them ended at the best fit (within 1 mm).
        rows: Training rows fitted; ``rms``: their reading RMS with the nominal robot, [m].
    """

    sensor: Drawstring
    tool_fitted: bool
    starts: int
    agreeing: int
    rows: int
    rms: float
    offset_fitted: bool = True

    def how(self) -> str:
        """For people: how the anchor was obtained."""
        what = ", ".join(self.fitted()[:-1]) + (" and " if len(self.fitted()) > 1 else "") + self.fitted()[-1]
        return (f"{what} pre-fitted with the nominal robot on {self.rows} rows, best of {self.starts} "
                f"starts ({self.agreeing} agree), reading RMS {self.rms * 1e3:.3g} mm")

    def as_dict(self) -> dict:
        """For report.json, in mm."""
        return {**self.sensor.to_dict(), "fitted": self.fitted(),
                "robot": "nominal", "rows": self.rows, "starts": self.starts, "starts_agreeing": self.agreeing,
                "rms_mm": self.rms * 1e3, "how": self.how(), "summary": self.summary()}

    def fitted(self) -> list[str]:
        """What was fitted: ``anchor``, ``offset``, ``tool``."""
        return ["anchor"] + (["offset"] if self.offset_fitted else []) + (["tool"] if self.tool_fitted else [])

    def summary(self) -> str:
        """The fitted values for people, [mm]."""
        def mm(v: np.ndarray) -> str:
            return ", ".join(f"{c * 1e3:.3f}" for c in v)

        text = f"anchor {mm(self.sensor.anchor)} mm, offset {self.sensor.length_offset * 1e3:.3f} mm"
        return text + (f", tool {mm(self.sensor.tool)} mm" if self.tool_fitted else "")


def _cables(origin: np.ndarray, end_rot: np.ndarray, tool: np.ndarray,
            anchor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The cable lengths |c_i + R_i t - P0| [m], shape (n,), and their unit directions from the anchor.

    The directions have shape (n, 3); c: the end frames' origins (n, 3) [m], R: their
    rotations (n, 3, 3), t: the tool point [m, end frame], P0: the anchor [m, base frame].
    These are the pre-fits' residual and its derivative.
    """
    cable = origin + end_rot @ tool - anchor
    lengths = np.linalg.norm(cable, axis=1)
    return lengths, cable / np.maximum(lengths, 1e-12)[:, None]


def fit_tool_point(chain: Chain, params: ParameterModel, q: np.ndarray, readings: np.ndarray, anchor: np.ndarray,
                   offset: float, source: str = "", rows: str = "training rows") -> np.ndarray:
    """Best-fit tool point [m, end frame] for the nominal robot with the anchor and zero offset known.

    The start of an estimated tool point that no file or flag gives (from the flange
    origin, the estimate would split the tool's z with d_6, which the readings see only
    together). Residual of row i: |c_i + R_i t - P0| + offset - reading_i, fitted by
    scipy's least squares from t = 0.

    Args:
        chain, params: The nominal robot chain and its parameter model.
        q: Joint angles, shape (n_rows, n_joints), [rad].
        readings: Cable readings, shape (n_rows,), [m].
        anchor: The anchor P0, shape (3,), [m], base frame.
        offset: The zero offset, [m].
        source: The file, for messages.
        rows: What messages call the rows (a cross-validation fold's).

    Raises:
        DataError: fewer rows than the 3 unknowns, naming ``source``.
    """
    from scipy.optimize import least_squares  # imported here: scipy.optimize is slow to import

    if len(q) <= 3:
        raise DataError(source, f"{len(q)} {rows} cannot locate the tool point (3 unknowns to pre-fit): add "
                        "'# tool_mm: x, y, z' or more rows", None, "tool_mm")
    model = CableModel(chain, params, Drawstring(np.zeros(3), np.zeros(3)))
    end_rot, origin = model.end_frames(None, q)

    def residual(t: np.ndarray) -> np.ndarray:
        return _cables(origin, end_rot, t, anchor)[0] + offset - readings

    def jacobian(t: np.ndarray) -> np.ndarray:
        return np.einsum("ni,nij->nj", _cables(origin, end_rot, t, anchor)[1], end_rot)

    return np.array(least_squares(residual, np.zeros(3), jac=jacobian, method="lm").x, dtype=float)


def fit_drawstring(chain: Chain, params: ParameterModel, q: np.ndarray, readings: np.ndarray, tool: np.ndarray,
                   fit_tool: bool = False, source: str = "", offset: float | None = None,
                   rows: str = "training rows") -> DrawstringPrefit:
    """Best-fit anchor P0 [m, base frame] and zero offset [m] for the nominal robot, with no guess.

    With ``fit_tool``, the tool point [m, end frame] is fitted too; no guess of the anchor
    is needed.

    The residual of row i is |c_i + R_i t - P0| + offset - reading_i (c_i, R_i: the nominal
    end frame's origin and rotation at q_i; t the tool point). It is fitted by scipy's
    least squares from PREFIT_GRID^3 = 27 anchors on a grid over the box of the nominal
    tool points, widened on every side by half the median reading (a cable reaches its
    anchor, so the anchor is within that box and one start lies within a grid cell of it);
    the offset starts at 0, the tool at ``tool``. The best final cost wins. Several starts
    because the problem has a local minimum for each side of the tool points' spread (the
    mirror anchor, with a negative offset); each start is a small fit of 4 to 7 unknowns.

    Args:
        q: Joint angles, shape (n_rows, n_joints), [rad].
        readings: Cable readings, shape (n_rows,), [m].
        tool: The tool point's start (or its fixed value without ``fit_tool``), shape (3,), [m].
        fit_tool: Fit the tool point too.
        source: The file, for messages.
        offset: The zero offset [m] held fixed (a re-anchored instrument's, known), or None: fitted.
        source, rows: The data's name and what its rows are called, for a refusal.

    Raises:
        DataError: fewer rows than unknowns, naming ``source``.
    """
    from scipy.optimize import least_squares  # imported here: scipy.optimize is slow to import

    fixed = offset is not None
    n_unknowns = 3 + (not fixed) + 3 * fit_tool
    if len(q) <= n_unknowns:
        raise DataError(source, f"{len(q)} {rows} cannot locate the drawstring's anchor ({n_unknowns} unknowns "
                        "to pre-fit): add '# anchor_mm: x, y, z' or more rows", None, "anchor_mm")
    model = CableModel(chain, params, Drawstring(np.zeros(3), np.zeros(3)))
    end_rot, origin = model.end_frames(None, q)

    def unpack(v: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
        rest = v[3:] if fixed else v[4:]
        return v[:3], (offset if fixed else v[3]), (rest[:3] if fit_tool else tool)  # type: ignore[return-value]

    def residual(v: np.ndarray) -> np.ndarray:
        anchor, offset, t = unpack(v)
        return _cables(origin, end_rot, t, anchor)[0] + offset - readings

    def jacobian(v: np.ndarray) -> np.ndarray:
        anchor, _, t = unpack(v)
        u = _cables(origin, end_rot, t, anchor)[1]
        cols = [-u] + ([] if fixed else [np.ones((len(q), 1))]) + ([np.einsum("ni,nij->nj", u, end_rot)] if fit_tool else [])
        return np.hstack(cols)

    tips = origin + end_rot @ tool
    reach = 0.5 * float(np.median(readings))
    low, high = tips.min(axis=0) - reach, tips.max(axis=0) + reach
    axes = [np.linspace(lo, hi, PREFIT_GRID) for lo, hi in zip(low, high, strict=True)]
    starts = np.array(np.meshgrid(*axes, indexing="ij")).reshape(3, -1).T
    fits = []
    for start in starts:
        v0 = np.concatenate([start, [] if fixed else [0.0], tool if fit_tool else []])
        fits.append(least_squares(residual, v0, jac=jacobian, method="lm"))
    best = min(fits, key=lambda f: f.cost)
    agreeing = sum(int(np.linalg.norm(f.x[:3] - best.x[:3]) < 1e-3) for f in fits)
    anchor, found, t = unpack(best.x)
    rms = float(np.sqrt(2.0 * best.cost / len(q)))
    return DrawstringPrefit(Drawstring(anchor.copy(), np.array(t, dtype=float), float(found)), fit_tool,
                            len(starts), agreeing, len(q), rms, not fixed)
