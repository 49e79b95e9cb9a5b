"""An invented third sensor, to prove the plug-in seam: a 1-D laser distance meter.

A laser fixed in the base frame measures along a fixed unit direction u to a target
point t fixed on the end effector; it reads the target's coordinate along the beam plus
a zero offset:

    reading(q) = u . p(q, x, t) + zero.

This module is all a new sensor needs (plus one registry line, :func:`register` below:
``calib_pin.sensors.register(DistanceModel)``): its set-up record (CLI flags from its
fields), its file's schema (the CSV value column ``distance_mm``, the metadata keys
``# target_mm`` and ``# zero_mm``), its geometry, its predictions and
their Jacobian, its report section, and its simulated rows (``simulate_rows``: then
``calib_pin.simulation.simulator.simulate_set`` and ``simulate_sessions(kinds=[..., "distance"])``
simulate it with truth). No other module of calib-pin is touched.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from calib_pin.exceptions import DataError
from calib_pin.measurements.schema import SCHEMAS, Schema
from calib_pin.sensors import SENSORS
from calib_pin.sensors import register as register_sensor
from calib_pin.sensors.base import MeasurementModel
from calib_pin.sensors.problem import SetProblem
from calib_pin.sensors.setup import SensorSetup, option, xyz_mm
from calib_pin.util.arguments import as_optional, as_xyz_mm


@dataclass(frozen=True, eq=False)
class DistanceSetup(SensorSetup):
    """The laser's set-up options (None: the file's, or the default beam +x)."""

    title: ClassVar[str] = "laser distance"

    beam: Any = option(help="laser beam direction in the base frame, 'x,y,z' (normalised)", parser=xyz_mm)
    target_mm: Any = option(help="laser target point in the end frame, 'x,y,z'", unit="mm", parser=xyz_mm)

    def __post_init__(self) -> None:
        beam = as_optional(as_xyz_mm, self.beam, "beam")
        if beam is not None:
            norm = float(np.linalg.norm(beam))
            if norm == 0.0:
                from calib_pin.exceptions import ArgumentError

                raise ArgumentError("beam", "is zero: give the laser's direction")
            beam = beam / norm
        object.__setattr__(self, "beam", beam)
        object.__setattr__(self, "target_mm", as_optional(as_xyz_mm, self.target_mm, "target_mm"))


@dataclass(frozen=True)
class Beam:
    """The laser's geometry: direction (3,) base frame, target (3,) [m] end frame, zero [m]."""

    direction: np.ndarray
    target: np.ndarray
    zero: float = 0.0

    def to_dict(self) -> dict:
        return {"beam": self.direction.tolist(), "target_mm": (self.target * 1e3).tolist(), "zero_mm": self.zero * 1e3}

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> Beam:
        return cls(np.array(doc["beam"], dtype=float), np.array(doc["target_mm"], dtype=float) * 1e-3,
                   float(doc["zero_mm"]) * 1e-3)


class DistanceModel(MeasurementModel):
    """Laser distances along a fixed beam; the zero offset is estimated with the robot."""

    schema: ClassVar[Schema] = Schema("distance", "laser distances", value_columns=("distance",),
                                      metadata_keys={"target": 3, "zero": 1})
    values_per_row = 1
    geometry_type = Beam
    error_name = "distance error"
    setup_type = DistanceSetup

    def __init__(self, chain: Any, params: Any, beam: Beam, compliance: Any = None,
                 estimate: tuple[str, ...] = ("zero",)) -> None:
        self.estimate = tuple(estimate)  # () : nothing of the laser estimated (the simulator's truth)
        super().__init__(chain, params, [("zero", "m", 1e-3)] if "zero" in self.estimate else [], compliance)
        self.beam = beam

    @classmethod
    def simulate_rows(cls, draw: Any, geometry: Beam | None) -> tuple[Any, Beam]:
        """Simulated laser distances (the one simulate method): random poses, each reading
        with the draw's noise; default beam +x, target 50 mm out of the flange, no zero."""
        from calib_pin.measurements import MeasurementSet

        beam = geometry if geometry is not None else Beam(np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 0.05]))
        laser = cls(draw.chain, draw.params, beam, estimate=())
        q = draw.poses()
        nominal = laser.predict(None, q)
        draw.deviations(lambda x: np.abs(laser.predict(x, q) - nominal))
        values = cls(draw.chain, draw.params, beam, draw.compliance, estimate=()).predict(draw.x_model, q)
        data = MeasurementSet(q=q, values=values + draw.noise(len(q)), kind=cls.kind, robot=draw.chain.name,
                              end_frame=draw.chain.end_frame, sensor_meta={"target": beam.target, "zero": beam.zero})
        return data, beam

    @classmethod
    def setup_of(cls, data: Any) -> DistanceSetup | None:
        meta = data.sensor_meta
        return DistanceSetup(target_mm=meta["target"] * 1e3) if "target" in meta else None

    @classmethod
    def problem_for(cls, chain: Any, params: Any, data: Any, fit_rows: np.ndarray,
                    options: Mapping[str, Any]) -> SetProblem:
        cls.refuse_foreign(options, data)
        target = options.get("target_mm")
        target = target * 1e-3 if target is not None else data.sensor_meta.get("target")
        if target is None:
            raise DataError(data.source, "no target point: add '# target_mm: x, y, z' or pass --target-mm",
                            None, "target_mm")
        beam = options.get("beam")
        beam = np.array([1.0, 0.0, 0.0]) if beam is None else beam
        model = cls(chain, params, Beam(beam, target, data.sensor_meta.get("zero", 0.0)), options.get("compliance"))
        return SetProblem(model, data.q, data.values)

    def geometry_at(self, x: np.ndarray | None) -> Beam:
        if x is None or not self.estimate:
            return self.beam
        return Beam(self.beam.direction, self.beam.target, self.beam.zero + float(self.sensor_part(x)[0]))

    def geometry_report(self, x: np.ndarray | None) -> dict:
        return self.geometry_at(x).to_dict()

    def describe(self) -> str:
        return "laser distance along a fixed beam, target known, zero estimated"

    @property
    def reference_point(self) -> np.ndarray:
        return self.beam.target

    def predict(self, x: np.ndarray | None, q: np.ndarray, points: np.ndarray | None = None) -> np.ndarray:
        beam = self.geometry_at(x)
        return self.points_at(x, q, beam.target) @ beam.direction + beam.zero

    def predict_with_jacobian(self, x: np.ndarray, q: np.ndarray,
                              points: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        beam = self.geometry_at(x)
        tips, d_tips = self.point_jacobian(x, q, beam.target)
        jac = np.einsum("i,nij->nj", beam.direction, d_tips)
        if self.estimate:
            jac[:, self.sensor_start] = 1.0
        return tips @ beam.direction + beam.zero, jac


def register() -> None:
    """The one registry entry (the model in SENSORS, its schema in SCHEMAS)."""
    register_sensor(DistanceModel)


def unregister() -> None:
    SENSORS.pop(DistanceModel.kind, None)
    SCHEMAS.pop(DistanceModel.kind, None)
