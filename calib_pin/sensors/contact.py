"""Contact fixtures, no instrument at all: the cheapest calibration there is.

Each row says that, at its joint angles q, the tool point t (fixed in the end frame)
touches a fixture:

- a fixed point (``contact_id``: a socket, a sphere's centre, a cone), whose position P
  in the base frame is unknown and estimated: the row's residual is p(q, x, t) - P
  (3 entries, [m]);
- a plane (``plane_id``: a face of a datum cube, a table), unknown and estimated as a
  unit normal n and an offset d (n . p = d): the row's residual is the signed distance
  n . p(q, x, t) - d (1 entry, [m]).

Known distances between points (``# distance_mm: A, B, 300.000`` lines, several allowed:
a calibrated bar, two sockets of a fixture plate; one length a pair, in either order) are
residual rows of the set too:
|P_A - P_B| - L (1 entry each, [m]); they belong to every part of the set (a split
scores them with the training rows and with the test rows alike).

Unknowns after the robot's: the tool point (``tool_x/y/z`` [m], end frame; unless given
by ``# tool_mm`` or ``--tool-mm``), each point (``contact<id>_x/y/z`` [m], base frame), each
plane (``plane<id>_a``, ``plane<id>_b`` [rad]: a right rotation of the starting normal
about two axes perpendicular to it, n = R0 exp3((a, b, 0)) e_z with R0 e_z = n0; and
``plane<id>_d`` [m], the offset's correction), all around a nominal fit on the training
rows (:func:`fit_fixtures`).

What fixtures cannot see: the robot's base placement (the fixtures are located in the
base frame, so moving the base and every fixture together changes no residual), and,
without a known distance, the scale: every length of the robot, the tool point, the
points and the planes' offsets grown together by one factor change no residual.
:meth:`ContactProblem.named_directions` gives these directions (the scale; the base's
translations and turns the parameter model can make), and ``--analyze`` says whether the
set sees each.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import pinocchio as pin

from ..exceptions import ArgumentError, CalibPinError, DataError
from ..measurements.schema import SCHEMAS, Schema
from ..robot.chain import Chain
from ..robot.deflection import ComplianceSpec
from ..util.arguments import as_optional, as_point_mm, too_far
from .base import DEFAULT_NOISE_MM, SETUP_MISFIT_M, MeasurementModel, check_rows, fit_rows_name
from .misreading import Misreading, Reading, Suspect, setup_in_metres
from .problem import SetProblem
from .setup import SensorSetup, option, point_mm

if TYPE_CHECKING:
    from ..measurements import MeasurementSet
    from ..parameters import ParameterModel

#: A plane needs at least this many rows at distinct configurations to be located.
MIN_PLANE_POINTS = 3
_EZ = np.array([0.0, 0.0, 1.0])
#: Why a contact set cannot see its base placement.
_LOCATED = "the fixtures are located in the base frame and move with it: no contact row sees it"


def _frame_of(normal: np.ndarray) -> np.ndarray:
    """A rotation R0 with R0 e_z = normal (unit)."""
    n = normal / np.linalg.norm(normal)
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(helper, n)
    u /= np.linalg.norm(u)
    return np.column_stack([u, np.cross(n, u), n])


@dataclass(frozen=True)
class Fixtures:
    """Geometry of a contact set-up.

    Attributes:
        tool: The tool point in the end frame, shape (3,), [m].
        tool_known: The tool point was given (not estimated).
        point_labels: The ``contact_id`` of each point, shape (n_points,).
        points: The points in the base frame, shape (n_points, 3), [m].
        plane_labels: The ``plane_id`` of each plane, shape (n_planes,).
        normals: Unit normals, shape (n_planes, 3), base frame.
        offsets: Offsets d of n . p = d, shape (n_planes,), [m].
        distances: Known distances: (index of point A, index of point B, length [m]).
    """

    tool: np.ndarray
    tool_known: bool
    point_labels: tuple[str, ...]
    points: np.ndarray
    plane_labels: tuple[str, ...]
    normals: np.ndarray
    offsets: np.ndarray
    distances: tuple[tuple[int, int, float], ...] = ()

    def to_dict(self) -> dict:
        """In mm (normals unit-free)."""
        return {
            "tool_mm": (self.tool * 1e3).tolist(), "tool": "given" if self.tool_known else "estimated",
            "points_mm": {label: (p * 1e3).tolist() for label, p in zip(self.point_labels, self.points, strict=True)},
            "planes": {label: {"normal": n.tolist(), "offset_mm": float(d) * 1e3, "meaning": "normal . p_base = offset"}
                       for label, n, d in zip(self.plane_labels, self.normals, self.offsets, strict=True)},
            "distances_mm": [[self.point_labels[a], self.point_labels[b], length * 1e3]
                             for a, b, length in self.distances],
        }

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> Fixtures:
        """Inverse of :meth:`to_dict`; also a layout written by hand (``--geometry FILE``).

        ``planes``, ``distances_mm`` and ``tool_mm`` optional (no planes, no distances,
        :data:`DEFAULT_CONTACT_TOOL_MM` estimated), a distance ``[A, B]`` the points' own,
        a plane's normal normalised here, labels sorted.

        Args:
            doc: The layout as a mapping (lengths in [mm]).

        Raises:
            ValueError: no points or planes, a point or normal not 3 numbers, a distance
                naming an unknown point or a point to itself, a pair given two lengths, a
                tool point beyond :data:`~calib_pin.util.arguments.POINT_REACH_MM`.
        """
        points = {str(k): np.asarray(v, dtype=float) for k, v in doc["points_mm"].items()}
        planes = {str(k): (np.asarray(v["normal"], dtype=float), float(v["offset_mm"]))
                  for k, v in doc.get("planes", {}).items()}
        if not points and not planes:
            raise ValueError("no points_mm and no planes: nothing to touch")
        for label, p in [*points.items(), *((k, n) for k, (n, _) in planes.items())]:
            if p.shape != (3,) or not np.all(np.isfinite(p)) or not np.any(p):
                raise ValueError(f"{label}: expected 3 finite numbers (a point [mm], or a plane's non-zero normal)")
        tool = np.asarray(doc.get("tool_mm", DEFAULT_CONTACT_TOOL_MM), dtype=float)
        why = too_far(tool, "end frame") if tool.shape == (3,) else None
        if why is not None:
            raise ValueError(f"tool_mm: {why}")
        fx = layout(points, planes, (), tool, doc.get("tool") == "given")
        index = {label: k for k, label in enumerate(fx.point_labels)}
        given = []
        for pair in doc.get("distances_mm", ()):
            a, b = str(pair[0]), str(pair[1])
            if a not in index or b not in index or a == b:
                raise ValueError(f"distance {a}, {b}: it joins two different points of points_mm")
            length = float(pair[2]) * 1e-3 if len(pair) > 2 else float(np.linalg.norm(fx.points[index[a]]
                                                                                      - fx.points[index[b]]))
            given.append((a, b, length))
        keep, clash = same_pair(given)
        if clash is not None:
            (a0, b0, l0), (a, b, length) = given[clash[0]], given[clash[1]]
            raise ValueError(f"distance {a}, {b}: {length * 1e3:g} mm, and {l0 * 1e3:g} mm as {a0}, {b0}: one "
                             "length a pair (give it once)")
        return replace(fx, distances=tuple((index[given[k][0]], index[given[k][1]], given[k][2]) for k in keep))


@dataclass(frozen=True, eq=False)
class ContactSetup(SensorSetup):
    """A contact set-up's options: the tool point, when known (else estimated).

    Attributes:
        tool_mm: The tool point in the end frame, shape (3,), [mm] (None: the file's
            ``# tool_mm``, else estimated). Shared with the drawstring's ``--tool-mm``.
    """

    title: ClassVar[str] = "contact fixtures"

    tool_mm: Any = option(help="tool point in the end frame, 'x,y,z'", unit="mm", parser=point_mm("end frame"))

    def __post_init__(self) -> None:
        object.__setattr__(self, "tool_mm", as_optional(as_point_mm, self.tool_mm, "tool_mm", "end frame"))


def _label_rows(data: MeasurementSet) -> tuple[np.ndarray, np.ndarray]:
    """Each row's ``contact_id`` and ``plane_id`` text ('' where not given)."""
    n = len(data)
    columns = [np.asarray(data.labels.get(name, np.full(n, "")), dtype=str) for name in ContactModel.schema.label_columns]
    return columns[0], columns[1]


def _line(data: MeasurementSet, row: int) -> int | None:
    return None if data.lines is None else int(data.lines[row])


def fixture_rows(data: MeasurementSet) -> tuple[tuple[str, ...], tuple[str, ...], np.ndarray]:
    """The set's point labels and plane labels (each sorted) and each row's fixture.

    A row's fixture is an index into the points, or n_points + index into the planes,
    shape (n_rows,).

    Args:
        data: A contact set (``contact_id`` and ``plane_id`` columns).

    Raises:
        DataError: a row with both ids or neither, naming the file and line.
    """
    contact, plane = _label_rows(data)
    for r in range(len(data)):
        if bool(contact[r]) == bool(plane[r]):
            what = "both contact_id and plane_id" if contact[r] else "neither contact_id nor plane_id"
            raise DataError(data.source, f"has {what}: a row touches one fixture (a point or a plane)",
                            _line(data, r), "contact_id")
    points = tuple(sorted(set(contact[contact != ""].tolist())))
    planes = tuple(sorted(set(plane[plane != ""].tolist())))
    index: dict[Any, int] = {label: k for k, label in enumerate(points)}
    index.update({("plane", label): len(points) + k for k, label in enumerate(planes)})
    rows = np.array([index[c] if c else index[("plane", p)] for c, p in zip(contact, plane, strict=True)], dtype=int)
    return points, planes, rows


def same_pair(pairs: list[tuple[str, str, float]]) -> tuple[list[int], tuple[int, int] | None]:
    """Each pair of points once: of ``pairs`` (label, label, length [m]), the entries to
    keep (a pair given again, in either order, with the same length to
    :data:`~calib_pin.measurements.checks.SETUP_TOLERANCE_M`, is dropped), and the first
    two entries that give one pair two lengths, or None.

    One length a pair: two would be fitted as a compromise between them, without a word.
    """
    from ..measurements.checks import SETUP_TOLERANCE_M

    seen: dict[frozenset[str], int] = {}
    keep = []
    for k, (a, b, length) in enumerate(pairs):
        first = seen.setdefault(frozenset((a, b)), k)
        if first == k:
            keep.append(k)
        elif abs(pairs[first][2] - length) > SETUP_TOLERANCE_M:
            return keep, (first, k)
    return keep, None


def known_distances(data: MeasurementSet, points: tuple[str, ...]) -> tuple[tuple[int, int, float], ...]:
    """The file's ``# distance_mm`` lines as (point index, point index, length [m]), each
    pair once (:func:`same_pair`).

    Args:
        data: A contact set.
        points: Its point labels, sorted (as :func:`fixture_rows` gives them).

    Raises:
        DataError: a distance naming an id that is no ``contact_id`` of the set, a point
            to itself, or a pair given two lengths, naming the file and the metadata line.
    """
    index = {label: k for k, label in enumerate(points)}
    given = list(data.sensor_meta.get("distance", ()))
    keep, clash = same_pair([(a, b, length) for a, b, length, _ in given])
    if clash is not None:
        (a0, b0, l0, line0), (a, b, length, line) = given[clash[0]], given[clash[1]]
        where = f"line {line0}" if line0 is not None else f"entry {clash[0] + 1}"
        raise DataError(data.source, f"{a}, {b}: {length * 1e3:g} mm here, {l0 * 1e3:g} mm on {where} ({a0}, {b0}): "
                        "one length a pair (give it once)", line, "distance_mm")
    out = []
    for a, b, length, line in (given[k] for k in keep):
        for label in (a, b):
            if label not in index:
                known = ", ".join(points) or "none"
                raise DataError(data.source, f"{a}, {b}: {label} is no contact_id of this set (contact_ids: {known}); "
                                "a known distance joins two points the rows touch", line, "distance_mm")
        if a == b:
            raise DataError(data.source, f"{a}, {b}: a distance joins two different points", line, "distance_mm")
        if not length > 0:
            raise DataError(data.source, f"{length * 1e3:g} mm: a distance is positive", line, "distance_mm")
        out.append((index[a], index[b], float(length)))
    return tuple(out)


#: Units a known distance is written in by mistake, each by how many mm it holds.
DISTANCE_UNITS = ((1000.0, "metres"), (10.0, "cm"))


def _distance_units(s: Suspect) -> Iterator[Reading]:
    """Each ``# distance_mm`` line read in metres or cm, when the fixtures the nominal robot
    locates (the set as prepared) are about that many times farther apart than it says."""
    fixtures = s.problem.model.fixtures
    index = {label: k for k, label in enumerate(fixtures.point_labels)}
    given = list(s.data.sensor_meta.get("distance", ()))
    for k, (a, b, length, line) in enumerate(given):
        if a not in index or b not in index or not length > 0:
            continue
        located = float(np.linalg.norm(fixtures.points[index[a]] - fixtures.points[index[b]]))
        for factor, unit in DISTANCE_UNITS:
            if not 0.5 * factor <= located / length <= 2.0 * factor:
                continue
            read = [*given[:k], (a, b, length * factor, line), *given[k + 1 :]]
            mm = f"{length * factor * 1e3:g}"
            yield Reading(f"{unit}, not mm", "distance_mm", line,
                          f"{a}, {b}, {length * 1e3:g} mm; the fixtures the nominal robot locates are "
                          f"{located * 1e3:.4g} mm apart", f"with {mm} mm", f"give it in mm ({a}, {b}, {mm})",
                          data=replace(s.data, sensor_meta={**s.data.sensor_meta, "distance": read}))


#: A known distance of a contact set in another unit than its key's.
DISTANCE_IN_ANOTHER_UNIT = Misreading("a known distance in metres or cm", _distance_units)


def rigid_aligned(points: np.ndarray, onto: np.ndarray) -> np.ndarray:
    """``points`` (n, 3) moved by the rigid motion that brings them closest to ``onto`` (n, 3).

    The motion is a rotation, no reflection, and a translation (Kabsch's least squares);
    same unit in and out. This is how a contact calibration's tool points are compared with
    the truth, since the fixtures are located in the base frame and move with it (the base
    placement is blind).
    """
    points, onto = np.asarray(points, dtype=float), np.asarray(onto, dtype=float)
    cp_, ct = points.mean(axis=0), onto.mean(axis=0)
    u, _, vt = np.linalg.svd((points - cp_).T @ (onto - ct))
    rot = vt.T @ np.diag([1.0, 1.0, np.sign(np.linalg.det(vt.T @ u.T))]) @ u.T
    return (points - cp_) @ rot.T + ct


@dataclass
class ContactProblem(SetProblem):
    """A calibration problem of contact rows and the set's known distances, which every subset keeps.

    ``points``: each row's fixture index, see :func:`fixture_rows`.
    Rows differ in size: a point row holds 3 residual entries, a plane row 1, a distance
    row 1 (after the data rows); use :attr:`row_offsets`.
    """

    other_rows: ClassVar[str] = "known distances"

    @property
    def n_data(self) -> int:
        """Data rows (touches), without the distance rows."""
        return len(self.q)

    @property
    def n_rows(self) -> int:
        return len(self.q) + len(self.model.fixtures.distances)

    n_poses = n_rows

    @property
    def data_rows(self) -> np.ndarray:
        """The rows that are touches (the known distances' rows follow them), shape (n_data,)."""
        return np.arange(self.n_data)

    @property
    def row_sizes(self) -> np.ndarray:
        """Residual entries of each row, shape (n_rows,)."""
        assert self.points is not None
        data = np.where(self.points < len(self.model.fixtures.points), 3, 1)
        return np.concatenate([data, np.ones(len(self.model.fixtures.distances), dtype=int)]).astype(int)

    @property
    def row_offsets(self) -> np.ndarray:
        return np.concatenate([[0], np.cumsum(self.row_sizes)]).astype(int)

    @property
    def n_values(self) -> int:
        return int(np.sum(self.row_sizes))

    def subset(self, rows: np.ndarray | slice) -> ContactProblem:
        """The same problem restricted to some data rows; the distance rows always stay.

        Indices past the data rows, the distance rows', are dropped.
        """
        assert self.points is not None
        if not isinstance(rows, slice):
            rows = np.asarray(rows, dtype=int)
            rows = rows[rows < self.n_data]
        return replace(self, q=self.q[rows], readings=self.readings[rows], points=self.points[rows])

    def residual(self, x: np.ndarray | None) -> np.ndarray:
        """Every row's residual, flattened, shape (n_values,), [m]."""
        return self.model.residual(x, self.q, self.points)[0]

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        return self.model.residual(x, self.q, self.points, jacobian=True)[1]

    def predict_with_jacobian(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The residual (this sensor reads nothing: a touch's value is zero) and its Jacobian."""
        return self.model.residual(x, self.q, self.points, jacobian=True)

    def row_residual_with_jacobian(self, x: np.ndarray, row: int) -> tuple[np.ndarray, np.ndarray]:
        """Row ``row``'s residual and Jacobian (a data row, or a distance row after them)."""
        assert self.points is not None
        if row < self.n_data:
            rows = slice(row, row + 1)
            r, jac = self.model.residual(x, self.q[rows], self.points[rows], jacobian=True, distances=False)
            return r, jac
        r, jac = self.model.distance_residual(x, jacobian=True)
        k = row - self.n_data
        return r[k : k + 1], jac[k : k + 1]

    def row_errors(self, residual: np.ndarray) -> np.ndarray:
        """Size of each row's error, shape (n_rows,), [m].

        The tool point's distance from its point, |signed distance| from its plane,
        |length error| of a distance.
        """
        offsets = self.row_offsets
        r = np.asarray(residual)
        return np.array([np.linalg.norm(r[offsets[k] : offsets[k + 1]]) for k in range(self.n_rows)])

    def named_directions(self, x: np.ndarray | None = None) -> dict[str, tuple[np.ndarray, str]]:
        """Directions of x with a name, for ``--analyze``: name -> (direction, what would make it seen).

        - ``scale``: every length grown by one factor: the robot's deviations (and the tool
          point, when estimated) fitted to grow each tool point p by p, each point P by P,
          each plane's offset by itself;
        - ``base ...``: the robot's base moved rigidly (a translation along, or a turn about,
          a base axis) with every fixture: the robot's deviations fitted to move each tool
          point so; present only where the parameter model can move its base that way
          (the fit leaves < 1e-6 of the motion).
        """
        model = self.model
        x = np.zeros(self.n_params) if x is None else np.asarray(x, dtype=float)
        fx = model.geometry_at(x)
        tips, d_tips = model.predict_with_jacobian(x, self.q)
        col = model.sensor_start + (0 if fx.tool_known else 3)
        first_plane = col + 3 * len(fx.points)
        _, _, planes = model._split(x)
        d_normals = [-model._frames[m] @ pin.exp3(np.array([planes[m, 0], planes[m, 1], 0.0])) @ pin.skew(_EZ)
                     @ pin.Jexp3(np.array([planes[m, 0], planes[m, 1], 0.0]))[:, :2] for m in range(len(fx.normals))]

        def direction(tip_motion: np.ndarray, point_motion: np.ndarray, normal_motion: np.ndarray,
                      offset_motion: np.ndarray, with_tool: bool) -> np.ndarray | None:
            moving = np.r_[np.arange(model.n_robot), np.arange(model.sensor_start, col) if with_tool else []]
            moving = moving.astype(int)
            scaled = d_tips[:, :, moving].reshape(-1, len(moving)) * model.scale[moving]
            fit = np.linalg.lstsq(scaled, tip_motion.reshape(-1), rcond=1e-10)[0]
            if np.linalg.norm(scaled @ fit - tip_motion.reshape(-1)) > 1e-6 * np.linalg.norm(tip_motion):
                return None  # the parameter model cannot move the robot so
            v = np.zeros(self.n_params)
            v[moving] = model.scale[moving] * fit
            v[col:first_plane] = point_motion.reshape(-1)
            for m, d_normal in enumerate(d_normals):
                v[first_plane + 3 * m : first_plane + 3 * m + 2] = np.linalg.lstsq(d_normal, normal_motion[m],
                                                                                   rcond=None)[0]
                v[first_plane + 3 * m + 2] = offset_motion[m]
            return v

        out: dict[str, tuple[np.ndarray, str]] = {}
        zeros = np.zeros_like(fx.normals)
        scale = direction(tips, fx.points, zeros, fx.offsets, not fx.tool_known)
        if scale is not None:
            out["scale (every length together: robot, tool point, points, plane offsets)"] = (
                scale, "a known distance between two points, '# distance_mm: A, B, length', makes it seen")
        for k, axis in enumerate("xyz"):
            e = np.eye(3)[k]
            moved = direction(np.tile(e, (len(tips), 1)), np.tile(e, (len(fx.points), 1)), zeros, fx.normals @ e, False)
            if moved is not None:
                out[f"base translation along {axis} (the robot with every fixture)"] = (
                    moved, _LOCATED)
            turned = direction(np.cross(e, tips), np.cross(e, fx.points).reshape(-1, 3),
                               np.cross(e, fx.normals).reshape(-1, 3), np.zeros(len(fx.normals)), False)
            if turned is not None:
                out[f"base turn about {axis} (the robot with every fixture)"] = (
                    turned, _LOCATED)
        return out


class ContactModel(MeasurementModel):
    """Touches of fixed points and planes by a tool point on a chain of a parameter model.

    The chain's deviations follow the parameter model.
    """

    schema: ClassVar[Schema] = SCHEMAS["contact"]
    #: Residual entries differ by row (3 a point, 1 a plane or a distance: see
    #: ``ContactProblem.row_offsets``); 1, the fewest, for a count of values.
    values_per_row = 1
    #: Rows differ in size within a set (a set of several is not stacked yet: it is fitted alone).
    rows_differ = True
    #: Methods that need rows of one size (a sigma-point batch, a correction per row's values).
    unsupported_methods = ("ukf", "rbf", "lm+rbf")
    geometry_type = Fixtures
    error_name = "contact error (distance of the tool point from its point or plane)"
    setup_type = ContactSetup
    fits_setup = True
    fitted_setup = "fixture points and planes"
    misreadings = (*MeasurementModel.misreadings, setup_in_metres(("tool_mm", "end frame")), DISTANCE_IN_ANOTHER_UNIT)
    moved_setup = ("fixtures", "the fixtures (a plate, a cube) were moved between the sessions?")

    def __init__(self, chain: Chain, params: ParameterModel, fixtures: Fixtures,
                 compliance: ComplianceSpec | None = None, estimate: tuple[str, ...] | None = None) -> None:
        """Build the model; ``estimate`` says which of the set-up is unknown.

        ``estimate=()``: nothing of the set-up unknown (the true fixtures and tool point,
        as :meth:`calib_pin.simulation.simulator.Truth.model` builds a truth's model): x holds the
        robot's unknowns only. None (the default): the points and planes are estimated,
        and the tool point unless ``fixtures.tool_known``.
        """
        if not isinstance(fixtures, Fixtures):
            raise ArgumentError("fixtures", f"expected Fixtures, got {type(fixtures).__name__}")
        if estimate is not None and tuple(estimate):
            raise ArgumentError("estimate", f"{','.join(estimate)}: a contact model estimates every fixture "
                                "(None) or nothing of its set-up (())")
        #: Nothing of the set-up is unknown (``estimate=()``).
        self.known = estimate is not None
        if self.known:
            fixtures = replace(fixtures, tool_known=True)
        extra = [] if fixtures.tool_known else [(f"tool_{a}", "m", 1e-3) for a in "xyz"]
        if not self.known:
            extra += [(f"contact{label}_{a}", "m", 1e-3) for label in fixtures.point_labels for a in "xyz"]
            extra += [(f"plane{label}_{c}", u, s) for label in fixtures.plane_labels
                      for c, u, s in (("a", "rad", 2e-3), ("b", "rad", 2e-3), ("d", "m", 1e-3))]
        super().__init__(chain, params, extra, compliance)
        self.fixtures = fixtures
        self._frames = np.array([_frame_of(n) for n in fixtures.normals]).reshape(-1, 3, 3)

    # --- set-up -------------------------------------------------------------------------

    @classmethod
    def setup_of(cls, data: MeasurementSet) -> ContactSetup | None:
        tool = data.sensor_meta.get("tool", data.tool)
        return None if tool is None else ContactSetup(tool_mm=np.asarray(tool, dtype=float) * 1e3)

    @classmethod
    def problem_for(cls, chain: Chain, params: ParameterModel, data: MeasurementSet,
                    fit_rows: np.ndarray, options: Mapping[str, Any]) -> ContactProblem:
        """Points and planes start from their fit with the nominal robot on ``fit_rows``.

        See :func:`fit_fixtures`; every fixture must be touched there, a plane at 3 or more
        distinct configurations.
        """
        cls.refuse_foreign(options, data)
        if options.get("estimate"):
            raise ArgumentError("setup", f"estimate {','.join(options['estimate'])} is for drawstring data; with "
                                f"contact fixtures ({data.source}) the points and planes are always estimated, and "
                                "the tool point unless the set-up gives it")
        points, planes, rows = fixture_rows(data)
        distances = known_distances(data, points)
        given = options.get("tool_mm")
        tool = np.asarray(given, dtype=float) * 1e-3 if given is not None else data.sensor_meta.get("tool", data.tool)
        fit_rows = np.asarray(fit_rows, dtype=int)
        labels = points + planes
        for k, label in enumerate(labels):
            where = fit_rows[rows[fit_rows] == k]
            distinct = len(np.unique(np.round(data.q[where], 9), axis=0)) if len(where) else 0
            need = 1 if k < len(points) else MIN_PLANE_POINTS
            if distinct < need:
                what = f"contact_id {label}" if k < len(points) else f"plane_id {label}"
                raise DataError(data.source, f"{what} is touched at {distinct} distinct configuration(s) of the "
                                f"{fit_rows_name(options)}: {'a plane needs 3 or more' if need > 1 else 'nothing locates it'}",
                                None, "plane_id" if k >= len(points) else "contact_id")
        fixtures = fit_fixtures(chain, params, data.q[fit_rows], rows[fit_rows], points, planes, tool, distances)
        model = cls(chain, params, fixtures, options.get("compliance"))
        problem = ContactProblem(model, data.q, np.zeros((len(data), 0)), rows)
        if tool is not None:
            _check_tool_fits(problem, data, given is not None)
        return problem

    # --- geometry -------------------------------------------------------------------------

    def _split(self, x: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """x's tool correction (3,), point corrections (n_points, 3), plane parts (n_planes, 3)."""
        fx = self.fixtures
        if self.known:
            return np.zeros(3), np.zeros((len(fx.points), 3)), np.zeros((len(fx.normals), 3))
        e = np.zeros(self.n_params - self.sensor_start) if x is None else self.sensor_part(x)
        tool, e = (np.zeros(3), e) if fx.tool_known else (e[:3], e[3:])
        n_points = len(fx.points)
        return tool, e[: 3 * n_points].reshape(-1, 3), e[3 * n_points :].reshape(-1, 3)

    def geometry_at(self, x: np.ndarray | None) -> Fixtures:
        """The tool point, points and planes x implies."""
        if x is None:
            return self.fixtures
        tool, points, planes = self._split(x)
        fx = self.fixtures
        normals = np.array([frame @ pin.exp3(np.array([a, b, 0.0])) @ _EZ
                            for frame, (a, b, _) in zip(self._frames, planes, strict=True)]).reshape(-1, 3)
        return replace(fx, tool=fx.tool + tool, points=fx.points + points, normals=normals,
                       offsets=fx.offsets + planes[:, 2])

    def geometry_report(self, x: np.ndarray | None) -> dict:
        return self.geometry_at(x).to_dict()

    def describe(self) -> str:
        fx = self.fixtures
        parts = [f"{len(fx.points)} point(s)", f"{len(fx.normals)} plane(s)", f"{len(fx.distances)} known distance(s)"]
        return f"contact fixtures ({', '.join(parts)}), tool point {'given' if fx.tool_known else 'estimated'}"

    @property
    def reference_point(self) -> np.ndarray:
        return np.asarray(self.fixtures.tool, dtype=float)

    def measured_points(self, x: np.ndarray | None) -> tuple[tuple[str, np.ndarray], ...]:
        return (("tool point", np.asarray(self.geometry_at(x).tool, dtype=float)),)

    def fresh_difference(self, predicted: np.ndarray, true: np.ndarray) -> np.ndarray:
        """Predicted tool points (n, 3) [m] moved by the best rigid motion onto the true ones, minus them.

        See :func:`rigid_aligned`: the base placement no contact set sees.
        """
        return rigid_aligned(predicted, true) - true

    # --- residuals ------------------------------------------------------------------------

    def predict(self, x: np.ndarray | None, q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        """The tool point in the base frame at q, shape (n_rows, 3), [m] (what touches the fixtures)."""
        return self.points_at(x, q, self.geometry_at(x).tool)

    def predict_with_jacobian(self, x: np.ndarray, q: np.ndarray,
                              points: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The tool point (n_rows, 3) [m] and its derivative (n_rows, 3, n_params)."""
        fx = self.geometry_at(x)
        tips, end_rot, jac = self.points_with_jacobians(x, q, fx.tool)
        if not fx.tool_known:
            jac[:, :, self.sensor_start : self.sensor_start + 3] = end_rot
        return tips, jac

    def distance_residual(self, x: np.ndarray | None, jacobian: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Each known distance's |P_A - P_B| - L [m], shape (n_distances,), and its Jacobian.

        The Jacobian has shape (n_distances, n_params) (zeros without ``jacobian``).
        """
        fx = self.geometry_at(x)
        r = np.empty(len(fx.distances))
        jac = np.zeros((len(fx.distances), self.n_params))
        first = self.sensor_start + (0 if fx.tool_known else 3)
        for k, (a, b, length) in enumerate(fx.distances):
            gap = fx.points[a] - fx.points[b]
            size = float(np.linalg.norm(gap))
            r[k] = size - length
            if jacobian and not self.known:
                jac[k, first + 3 * a : first + 3 * a + 3] = gap / size
                jac[k, first + 3 * b : first + 3 * b + 3] = -gap / size
        return r, jac

    def residual(self, x: np.ndarray | None, q: np.ndarray, rows: np.ndarray, jacobian: bool = False,
                 distances: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """The residual of data rows touching fixtures ``rows``, flattened, [m], and its Jacobian.

        With ``distances``, the known distances' rows follow. The Jacobian has shape
        (n_values, n_params) (an empty one without ``jacobian``).
        """
        fx = self.geometry_at(x)
        n_points = len(fx.points)
        rows = np.asarray(rows, dtype=int)
        xx = np.zeros(self.n_params) if x is None else np.asarray(x, dtype=float)
        if jacobian:
            tips, d_tips = self.predict_with_jacobian(xx, q)
        else:
            tips, d_tips = self.predict(x, q), None
        tool_cols = 0 if fx.tool_known else 3
        first_point = self.sensor_start + tool_cols
        first_plane = first_point + 3 * n_points
        tool, points, planes = self._split(x)
        parts, jacs = [], []
        for r, k in enumerate(rows):
            if k < n_points:
                parts.append(tips[r] - fx.points[k])
                if d_tips is not None:
                    j = d_tips[r].copy()
                    if not self.known:
                        j[:, first_point + 3 * k : first_point + 3 * k + 3] = -np.eye(3)
                    jacs.append(j)
            else:
                m = k - n_points
                normal = fx.normals[m]
                parts.append(np.array([normal @ tips[r] - fx.offsets[m]]))
                if d_tips is not None:
                    j = (normal @ d_tips[r])[None, :]
                    if not self.known:
                        w = np.array([planes[m, 0], planes[m, 1], 0.0])
                        # n = R0 exp3(w) e_z: d n = -R0 exp3(w) [e_z]x Jexp3(w) d w
                        d_normal = -self._frames[m] @ pin.exp3(w) @ pin.skew(_EZ) @ pin.Jexp3(w)
                        j[0, first_plane + 3 * m : first_plane + 3 * m + 2] = tips[r] @ d_normal[:, :2]
                        j[0, first_plane + 3 * m + 2] = -1.0
                    jacs.append(j)
        if distances and fx.distances:
            r_d, j_d = self.distance_residual(x, jacobian)
            parts.append(r_d)
            jacs.append(j_d)
        residual = np.concatenate(parts) if parts else np.zeros(0)
        jac = np.concatenate(jacs) if jacs else np.zeros((0, self.n_params))
        return residual, jac

    def session_errors(self, x: np.ndarray | None, data: MeasurementSet,
                       correction: Callable[[np.ndarray, np.ndarray | None], np.ndarray] | None = None,
                       ) -> np.ndarray:
        """Each data row's error [m] of a separate session touching this calibration's fixtures.

        Fixtures are matched by label; a row's error is its distance from its point, or
        from its plane.

        Args:
            x: The unknowns, SI; None: nominal.
            data: The session's contact set.
            correction: A learnt correction of the values; must be None.

        Raises:
            CalibPinError: a learnt correction, or a fixture this calibration does not know.
        """
        if correction is not None:
            raise CalibPinError("a learnt correction (rbf, lm-rbf) cannot be scored on a separate contact session")
        fx = self.fixtures
        points, planes, rows = fixture_rows(data)
        ours: dict[Any, int] = {label: k for k, label in enumerate(fx.point_labels)}
        ours.update({("plane", label): len(fx.points) + k for k, label in enumerate(fx.plane_labels)})
        index = []
        for label in points + tuple(("plane", p) for p in planes):
            if label not in ours:
                shown = label[1] if isinstance(label, tuple) else label
                raise CalibPinError(f"{data.source}: fixture {shown} is not one of this calibration's")
            index.append(ours[label])
        mapped = np.asarray(index, dtype=int)[rows]
        residual = self.residual(x, data.q, mapped, distances=False)[0]
        sizes = np.where(mapped < len(fx.points), 3, 1)
        offsets = np.concatenate([[0], np.cumsum(sizes)])
        return np.array([np.linalg.norm(residual[offsets[k] : offsets[k + 1]]) for k in range(len(mapped))])

    def session_frame_shift(self, x: np.ndarray | None, data: MeasurementSet) -> float | None:
        """How far a separate session's own fixtures are from the calibration's, [m]: the
        RMS, over the session's fixtures this calibration knows, of the distance between
        where its touches put each (the model at x; a point: their mean tool point, a plane:
        their mean distance from it along its normal) and where the calibration has it. The
        rows' play averages out, a moved plate does not. None: no fixture known."""
        fx = self.geometry_at(x)
        points, planes, rows = fixture_rows(data)
        tips = self.points_at(x, data.q, fx.tool)
        shifts = []
        for k, label in enumerate(points + planes):
            these = tips[rows == k]
            if k < len(points) and label in fx.point_labels:
                shifts.append(float(np.linalg.norm(these.mean(axis=0) - fx.points[fx.point_labels.index(label)])))
            elif k >= len(points) and label in fx.plane_labels:
                m = fx.plane_labels.index(label)
                shifts.append(abs(float(np.mean(these @ fx.normals[m] - fx.offsets[m]))))
        return float(np.sqrt(np.mean(np.square(shifts)))) if shifts else None

    @classmethod
    def row_targets(cls, data: MeasurementSet) -> np.ndarray:
        """Each row's fixture (index, as :func:`fixture_rows`')."""
        return fixture_rows(data)[2]

    # --- simulation -----------------------------------------------------------------------

    def touching_angles(self, x: np.ndarray | None, fixtures: np.ndarray, rng: np.random.Generator,
                        noise_m: float = DEFAULT_NOISE_MM * 1e-3, tries: int = 40,
                        margin: float = 0.0, starts: np.ndarray | None = None) -> np.ndarray:
        """Joint angles (n_rows, n_joints) [rad] at which the model at x puts the tool point on each fixture.

        Each row's fixture is an index, as :func:`fixture_rows`'; the touch is missed by
        Gaussian noise of ``noise_m`` per axis (a socket's play): inverse kinematics by
        Newton steps of least norm from random starts, clipped to the joint limits less
        ``margin`` [rad] (a plane's row: a random point of it within 0.1 m of the plane's
        point nearest the base origin). Each row's start is its own, so rows of one fixture
        touch it in distinct configurations (the tool's orientation about the point, elbow
        and wrist variants: a touch fixes 3 of the 6 joints' freedoms, a plane's 1).

        Args:
            x: The unknowns, SI; None: nominal.
            fixtures: Each row's fixture index, shape (n_rows,).
            rng: The random generator of the starts and the noise.
            noise_m: The touch's noise (1 sigma) per axis, [m].
            tries: Random starts tried per row before giving up.
            margin: Kept from the joint limits, [rad].
            starts: The first start of each row instead of a random one, shape (n_rows,
                n_joints) [rad] (planned configurations of the nominal robot, touched by the
                true arm near them); None: random.

        Raises:
            CalibPinError: a fixture the arm cannot reach from ``tries`` starts.
        """
        from ..robot.poses import random_poses

        fx = self.geometry_at(x)
        xx = np.zeros(self.n_params) if x is None else np.asarray(x, dtype=float)
        fixtures = np.asarray(fixtures, dtype=int)
        targets = np.empty((len(fixtures), 3))
        near = None if starts is None else self.points_at(xx, np.asarray(starts, dtype=float), fx.tool)
        for r, k in enumerate(fixtures):
            if k < len(fx.points):
                targets[r] = fx.points[k] + rng.normal(size=3) * noise_m
            else:
                m = k - len(fx.points)
                frame = _frame_of(fx.normals[m])
                on = fx.normals[m] * fx.offsets[m] + frame[:, :2] @ rng.uniform(-0.1, 0.1, 2) if near is None else \
                    near[r] - fx.normals[m] * (fx.normals[m] @ near[r] - fx.offsets[m])  # the start's point, on the plane
                targets[r] = on + fx.normals[m] * rng.normal() * noise_m
        out = np.empty((len(fixtures), self.chain.n_joints))
        lo, hi = self.chain.lower + margin, self.chain.upper - margin
        todo = np.arange(len(fixtures))
        self.set_robot(xx)
        for attempt in range(tries):  # every row still without a solution from a new random start, together
            q = random_poses(self.chain, len(todo), rng, margin=max(margin, np.deg2rad(5.0))) \
                if starts is None or attempt else np.clip(np.asarray(starts, dtype=float), lo, hi)
            for _ in range(40):  # Newton steps of least norm (6 joints, 3 equations): quadratic near the touch
                tips, d_points = self._kin.points(q, fx.tool, jacobian=True, joints=True)
                assert d_points is not None
                miss = tips - targets[todo]
                d_q = d_points[:, :, -q.shape[1] :]
                q = np.clip(q - np.einsum("nij,nj->ni", np.linalg.pinv(d_q), miss), lo, hi)
            tips = self._kin.points(q, fx.tool)[0]
            done = np.linalg.norm(tips - targets[todo], axis=1) < 1e-10
            out[todo[done]] = q[done]
            todo = todo[~done]
            if not len(todo):
                return out
        k = int(fixtures[todo[0]])  # where the fixture is (a plane: its point nearest the base origin)
        target = fx.points[k] if k < len(fx.points) else fx.normals[k - len(fx.points)] * fx.offsets[k - len(fx.points)]
        label = (fx.point_labels + fx.plane_labels)[k]
        raise CalibPinError(f"fixture {label} at {np.round(target * 1e3, 1).tolist()} mm: the arm does not "
                            f"reach it from {tries} starts")

    # --- simulation and planning on the sensor seam -----------------------------------------

    @classmethod
    def simulate_rows(cls, draw: Any, geometry: Fixtures | None) -> tuple[MeasurementSet, Fixtures]:
        """A simulated contact session (:meth:`MeasurementModel.simulate_rows`).

        ``draw.n_poses`` touches spread over the fixtures in turn (point A, B, ..., then the
        planes), each made by the TRUE arm: inverse kinematics of the true robot (deviations
        and compliances) from its own random start, so the true tool point touches, missed
        by the socket's play (``draw.noise_mm`` per axis); the joint angles are recorded.
        Given poses (planned touches of the nominal arm, ``plan-poses --sensor contact``):
        each touches the fixture the nominal tool point is on there (within
        :data:`TOUCH_TOLERANCE_M`), the true arm's configuration found from it. The file
        states its known distances, and its tool point when ``tool_known``.

        Args:
            draw: The simulation's seeded draws (:class:`~calib_pin.sensors.base.Draw`).
            geometry: The fixture layout; None: :func:`default_fixtures`.

        Raises:
            CalibPinError: a given pose touching no fixture, a gross-error noise kind, too
                few touches for the fixtures, or a fixture out of reach.
        """
        fx = default_fixtures() if geometry is None else geometry
        if draw.noise_kind != "gauss":
            raise CalibPinError(f"contact fixtures are simulated with a socket's play, gauss: not '{draw.noise_kind}'")
        n_fixtures = len(fx.points) + len(fx.normals)
        need = len(fx.points) + MIN_PLANE_POINTS * len(fx.normals)
        starts = rows = None
        if draw.given_poses is not None:  # planned touches: each the fixture the nominal arm touches there
            starts = draw.given_poses
            rows = _touched(cls(draw.chain, draw.params, replace(fx, tool_known=True)), starts)
            draw.n_poses = len(starts)
        elif draw.n_poses < need:
            raise CalibPinError(f"{draw.n_poses} touches for {len(fx.points)} point(s) and {len(fx.normals)} "
                                f"plane(s): give --poses {need} or more (a plane is located by 3 touches)")
        model = cls(draw.chain, draw.params, replace(fx, tool_known=True), draw.compliance)
        from ..robot.poses import random_poses

        probe = random_poses(draw.chain, 200, draw.rng)
        nominal = model.points_at(None, probe, fx.tool)
        extra = model.n_params - len(draw.params.names) - len(draw.true_compliance)

        def gap(x: np.ndarray) -> np.ndarray:
            full = np.concatenate([x, draw.true_compliance, np.zeros(extra)])
            return np.linalg.norm(model.points_at(full, probe, fx.tool) - nominal, axis=1)

        draw.deviations(gap)
        full = np.concatenate([draw.x_model, np.zeros(extra)])
        rows = np.arange(draw.n_poses) % n_fixtures if rows is None else rows
        q = model.touching_angles(full, rows, draw.rng, draw.noise_mm * 1e-3, starts=starts)
        data = contact_set(draw.chain, fx, q, rows, noise_m=draw.noise_mm * 1e-3 or None)
        data.notes["source"] = (f"calib-pin contact simulator, seed {draw.seed}, {draw.n_poses} touches of "
                                f"{n_fixtures} fixtures by the true arm, play {draw.noise_mm:g} mm per axis")
        return data, fx

    @classmethod
    def planning_model(cls, chain: Chain, params: ParameterModel, setup: SensorSetup | None,
                       geometry: Fixtures | None = None) -> ContactModel:
        """The model configurations are planned for, on the fixture layout ``geometry``.

        ``geometry`` None: :func:`default_fixtures`. Its tool point is estimated unless the
        set-up gives it (``--tool-mm``).
        """
        fx = default_fixtures() if geometry is None else geometry
        tool_mm = getattr(setup, "tool_mm", None)
        if tool_mm is not None:
            fx = replace(fx, tool=np.asarray(tool_mm, dtype=float) * 1e-3, tool_known=True)
        return cls(chain, params, fx)

    def plan_candidates(self, n: int, rng: np.random.Generator, margin: float) -> tuple[np.ndarray, np.ndarray]:
        """Candidate touches to plan from: about ``n`` nominal configurations touching a fixture.

        The tool point of the nominal robot touches each fixture in turn, each from its own
        random start (several distinct configurations per fixture), within the joint limits
        less ``margin`` [rad], in random order. Returns the joint angles (n, n_joints) [rad]
        and each one's fixture (index, as :func:`fixture_rows`').
        """
        n_fixtures = len(self.fixtures.points) + len(self.fixtures.normals)
        rows = rng.permutation(np.arange(max(n, n_fixtures)) % n_fixtures)
        return self.touching_angles(None, rows, rng, 0.0, margin=margin), rows

    def planning_rows(self, q: np.ndarray, fixtures: np.ndarray) -> np.ndarray:
        """Scaled identification rows of each candidate touch at the nominal robot, shape (n, 3, n_params).

        A point's 3 entries, a plane's 1 and two rows of zeros (no information), so that
        touches of both kinds are chosen among together.
        """
        fixtures = np.asarray(fixtures, dtype=int)
        jac = self.residual(np.zeros(self.n_params), q, fixtures, jacobian=True, distances=False)[1] * self.scale
        sizes = np.where(fixtures < len(self.fixtures.points), 3, 1)
        out = np.zeros((len(q), 3, self.n_params))
        starts = np.concatenate([[0], np.cumsum(sizes)])
        for r in range(len(q)):
            out[r, : sizes[r]] = jac[starts[r] : starts[r + 1]]
        return out

    def planning_problem(self, q: np.ndarray, fixtures: np.ndarray) -> ContactProblem:
        """The problem of touches at q of ``fixtures`` with the layout's known distances.

        For what a plan identifies: the scale is seen only with a known distance.
        """
        return ContactProblem(self, np.asarray(q, dtype=float), np.zeros((len(q), 0)),
                              np.asarray(fixtures, dtype=int))

    def planned_set(self, q: np.ndarray, fixtures: np.ndarray) -> MeasurementSet:
        """The touches to make, as a contact set (:func:`contact_set`).

        What ``plan-poses --sensor contact`` writes.
        """
        return contact_set(self.chain, self.fixtures, q, fixtures)


#: A given configuration touches the fixture its nominal tool point is within this of, [m].
TOUCH_TOLERANCE_M = 5e-3


def _touched(model: ContactModel, q: np.ndarray) -> np.ndarray:
    """The fixture (index) the nominal tool point of ``model`` touches at each of q.

    Raises:
        CalibPinError: a configuration whose tool point is on no fixture (1-based row).
    """
    fx = model.fixtures
    tips = model.points_at(None, q, fx.tool)
    gaps = np.concatenate([np.linalg.norm(tips[:, None] - fx.points[None], axis=2).reshape(len(q), -1),
                           np.abs(tips @ fx.normals.T - fx.offsets).reshape(len(q), -1)], axis=1)
    rows = np.argmin(gaps, axis=1)
    far = np.flatnonzero(gaps[np.arange(len(q)), rows] > TOUCH_TOLERANCE_M)
    if len(far):
        raise CalibPinError(f"pose {far[0] + 1}: the nominal tool point is on no fixture of the layout (nearest "
                            f"{gaps[far[0], rows[far[0]]] * 1e3:.1f} mm off): give touches planned for it "
                            "(plan-poses --sensor contact)")
    return rows


def _check_tool_fits(problem: ContactProblem, data: MeasurementSet, caller: bool) -> None:
    """Refuse a known tool point whose nominal touches miss their fitted fixtures by metres.

    The tool point is the caller's (``caller``) or the file's; its touches at the nominal
    robot, with the fixtures fitted to them, miss those fixtures by metres (a unit mistake,
    a point in another frame): the fit would only hit the sanity bound.

    Raises:
        DataError: naming the file, ``tool_mm``, its value and the miss.
    """
    rows = check_rows(problem.n_data)
    part = problem.subset(rows) if len(rows) < problem.n_data else problem
    errors = part.row_errors(part.residual(np.zeros(problem.n_params)))
    miss = float(np.median(errors))
    if not miss > SETUP_MISFIT_M:
        return
    tool = ",".join(f"{v * 1e3:g}" for v in problem.model.fixtures.tool)
    origin = "given" if caller else "the file's"
    raise DataError(data.source, f"{tool} mm ({origin}; the tool point in "
                    f"the end frame) does not fit the touches: at the nominal robot the tool point misses its fitted "
                    f"point or plane by a median {miss:.4g} m, max {errors.max():.4g} m (valid: within "
                    f"{SETUP_MISFIT_M:g} m, a robot's deviation): a unit or frame mistake?", None, "tool_mm")


def fit_fixtures(chain: Chain, params: ParameterModel, q: np.ndarray, rows: np.ndarray, points: tuple[str, ...],
                 planes: tuple[str, ...], tool: np.ndarray | None,
                 distances: tuple[tuple[int, int, float], ...] = ()) -> Fixtures:
    """Best-fit fixtures (and tool point, unless given) for the nominal robot.

    With the tool point unknown and point rows: one linear least squares for the tool
    point and every point (p_E + R_E t = P on each point row); else the tool point starts
    at the end frame's origin. With planes, the tool point and the planes are then fitted
    in turn (each plane by SVD of its rows' tool points, the tool point and offsets by
    linear least squares) until the tool point stops moving.

    Args:
        q: The training rows' joint angles (n_rows, n_joints) [rad]; rows: each one's
            fixture index (as :func:`fixture_rows`'); tool: given tool point [m] or None.
    """
    n_points, n_planes = len(points), len(planes)
    model = ContactModel(chain, params, Fixtures(np.zeros(3), True, points, np.zeros((n_points, 3)), planes,
                                                  np.tile(_EZ, (n_planes, 1)), np.zeros(n_planes), distances))
    end_rot, origin = model.end_frames(None, q)
    known = tool is not None
    t = np.zeros(3) if tool is None else np.asarray(tool, dtype=float)
    on_point = rows < n_points
    if not known and on_point.any():
        n = int(on_point.sum())
        a = np.zeros((n, 3, 3 + 3 * n_points))
        a[:, :, :3] = end_rot[on_point]
        for r, k in enumerate(rows[on_point]):
            a[r, :, 3 + 3 * k : 6 + 3 * k] = -np.eye(3)
        sol = np.linalg.lstsq(a.reshape(3 * n, -1), -origin[on_point].reshape(-1), rcond=None)[0]
        t = sol[:3]
    normals, offsets = np.tile(_EZ, (n_planes, 1)), np.zeros(n_planes)
    for _ in range(1 if known or not n_planes or on_point.any() else 50):
        tips = origin + end_rot @ t
        for m in range(n_planes):
            these = tips[rows == n_points + m]
            centre = these.mean(axis=0)
            normal = np.linalg.svd(these - centre)[2][-1]
            normal = normal if normal @ centre >= 0 else -normal  # the offset >= 0
            normals[m], offsets[m] = normal, normal @ centre
        if known or on_point.any():
            break
        # the tool point and the offsets, planes' normals fixed: n . (p_E + R_E t) - d = 0
        a = np.zeros((len(q), 3 + n_planes))
        for r, k in enumerate(rows):
            a[r, :3] = normals[k - n_points] @ end_rot[r]
            a[r, 3 + k - n_points] = -1.0
        moved, t = t, np.linalg.lstsq(a, -np.einsum("ni,ni->n", normals[rows - n_points], origin), rcond=None)[0][:3]
        if np.max(np.abs(t - moved)) < 1e-12:
            break
    tips = origin + end_rot @ t
    located = np.array([tips[rows == k].mean(axis=0) for k in range(n_points)]).reshape(-1, 3)
    return Fixtures(t, known, points, located, planes, normals, offsets, distances)


@dataclass
class _Layout:
    """Where a simulated contact set's fixtures are (base frame, [m])."""

    points: dict[str, np.ndarray] = field(default_factory=dict)
    planes: dict[str, tuple[np.ndarray, float]] = field(default_factory=dict)


#: Default sockets of simulated contact sets, base frame, [mm].
DEFAULT_SOCKETS_MM = {"A": (380.0, 120.0, 250.0), "B": (300.0, -250.0, 150.0), "C": (420.0, -40.0, 480.0)}
#: Default tool point of simulated contact sets (a probe tip 60 mm out of the flange, off axis), end frame, [mm].
DEFAULT_CONTACT_TOOL_MM = (10.0, -5.0, 60.0)
#: Default plane of the simulator and planner: a datum cube's face, label -> (normal, offset [mm]), base frame.
DEFAULT_PLANES_MM = {"F": ((1.0, 0.2, 1.0), 500.0)}


def default_fixtures() -> Fixtures:
    """The layout ``simulate --kinds contact`` and ``plan-poses --sensor contact`` use by default.

    Used unless given one (``--geometry FILE``): the sockets :data:`DEFAULT_SOCKETS_MM`,
    the datum-cube face :data:`DEFAULT_PLANES_MM`, the distance A-B known, the tool point
    :data:`DEFAULT_CONTACT_TOOL_MM` (to be estimated).
    """
    return layout(DEFAULT_SOCKETS_MM, DEFAULT_PLANES_MM, (("A", "B"),), DEFAULT_CONTACT_TOOL_MM, False)


def layout(sockets_mm: Mapping[str, Any], planes_mm: Mapping[str, tuple[Any, float]],
           distances: tuple[tuple[str, str], ...], tool_mm: Any, tool_known: bool) -> Fixtures:
    """A fixture layout of points, planes, known distances and a tool point.

    Points: label -> (x, y, z) [mm], base frame; planes: label -> (normal, offset [mm]):
    n . p = offset, n normalised here; the pairs of points whose distance is known (it is
    their true distance); the tool point [mm] (end frame).
    """
    points = {str(k): np.asarray(v, dtype=float) * 1e-3 for k, v in sockets_mm.items()}
    planes = {str(k): (np.asarray(n, dtype=float) / np.linalg.norm(n), float(d) * 1e-3)
              for k, (n, d) in planes_mm.items()}
    labels, plane_labels = tuple(sorted(points)), tuple(sorted(planes))
    index = {label: k for k, label in enumerate(labels)}
    known = tuple((index[a], index[b], float(np.linalg.norm(points[a] - points[b]))) for a, b in distances)
    return Fixtures(np.asarray(tool_mm, dtype=float) * 1e-3, tool_known, labels,
                    np.array([points[k] for k in labels]).reshape(-1, 3), plane_labels,
                    np.array([planes[k][0] for k in plane_labels]).reshape(-1, 3),
                    np.array([planes[k][1] for k in plane_labels]), known)


def contact_set(chain: Chain, fixtures: Fixtures, q: np.ndarray, rows: np.ndarray,
                noise_m: float | None = None) -> MeasurementSet:
    """A contact set of touches at q (n, n_joints) [rad] of fixtures ``rows``.

    ``rows`` are indices, as :func:`fixture_rows`'. The set holds its ``contact_id`` /
    ``plane_id`` labels, the layout's known distances (``# distance_mm``) and its tool
    point when known (``# tool_mm``).
    """
    from ..measurements import MeasurementSet

    fx = fixtures
    names = fx.point_labels + fx.plane_labels
    n_points = len(fx.points)
    contact = np.array([names[k] if k < n_points else "" for k in rows], dtype=str)
    plane = np.array([names[k] if k >= n_points else "" for k in rows], dtype=str)
    return MeasurementSet(
        q=np.asarray(q, dtype=float), values=np.zeros((len(q), 0)), kind=ContactModel.kind, robot=chain.name,
        end_frame=chain.end_frame, tool=fx.tool if fx.tool_known else None, noise=noise_m, notes={},
        labels={"contact_id": contact, "plane_id": plane},
        sensor_meta={"distance": tuple((fx.point_labels[a], fx.point_labels[b], length, None)
                                       for a, b, length in fx.distances),
                     **({"tool": fx.tool} if fx.tool_known else {})})


def __getattr__(name: str) -> Any:
    """The old names of what moved elsewhere (the example sessions of calib_pin.simulation), with a DeprecationWarning."""
    from ..util.deprecation import moved_names

    return moved_names(__name__, {
        "simulate_contacts": "calib_pin.simulation.contact"})(name)
