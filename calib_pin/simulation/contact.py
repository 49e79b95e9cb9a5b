"""A simulated contact session: configurations touching sockets and planes, with a known true robot."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..measurements import MeasurementSet
from ..parameters import ParameterModel
from ..robot import Chain
from ..robot.poses import random_poses
from ..sensors.contact import DEFAULT_CONTACT_TOOL_MM, DEFAULT_SOCKETS_MM, ContactModel, Fixtures
from .simulator import Truth


def simulate_contacts(chain: Chain, params: ParameterModel, per_fixture: int, seed: int, noise_mm: float = 0.05,
                      nominal_rmse_mm: float = 2.0, sockets_mm: Mapping[str, Any] | None = None,
                      planes: Mapping[str, tuple[Any, float]] | None = None,
                      distances: tuple[tuple[str, str], ...] = (("A", "B"),),
                      tool_mm: Any = DEFAULT_CONTACT_TOOL_MM, tool_known: bool = False,
                      true_x: np.ndarray | None = None) -> tuple[MeasurementSet, Any]:
    """Simulate a contact session of one true robot touching each socket and plane.

    ``per_fixture`` configurations touch each socket (``sockets_mm``: label -> (x, y, z)
    [mm], base frame) and each plane (``planes``: label -> (normal, offset [mm])), the
    true tool point missing each by
    Gaussian noise ``noise_mm`` per axis; the file states the true distance of each pair in
    ``distances`` (``# distance_mm``) and, with ``tool_known``, the tool point.

    True deviations (unless ``true_x``) are drawn normal with the parameter model's typical
    sizes, scaled so the nominal tool point's error has RMSE ``nominal_rmse_mm``.

    Returns:
        The set and its :class:`~calib_pin.simulation.simulator.Truth` (``sensor``: the true Fixtures).
    """
    rng = np.random.default_rng(seed)
    sockets = {str(k): np.asarray(v, dtype=float) * 1e-3 for k, v in (sockets_mm or DEFAULT_SOCKETS_MM).items()}
    plane_map = {str(k): (np.asarray(n, dtype=float) / np.linalg.norm(n), float(d) * 1e-3)
                 for k, (n, d) in (planes or {}).items()}
    labels = tuple(sorted(sockets))
    plane_labels = tuple(sorted(plane_map))
    index = {label: k for k, label in enumerate(labels)}
    known = tuple((index[a], index[b], float(np.linalg.norm(sockets[a] - sockets[b]))) for a, b in distances)
    tool = np.asarray(tool_mm, dtype=float) * 1e-3
    truth_fixtures = Fixtures(tool, True, labels, np.array([sockets[k] for k in labels]).reshape(-1, 3), plane_labels,
                              np.array([plane_map[k][0] for k in plane_labels]).reshape(-1, 3),
                              np.array([plane_map[k][1] for k in plane_labels]), known)
    model = ContactModel(chain, params, truth_fixtures)
    if true_x is None:
        x = rng.normal(size=len(params.names)) * params.scale
        probe = random_poses(chain, 200, rng)
        nominal = model.points_at(None, probe, tool)
        gap = np.linalg.norm(model.points_at(np.concatenate([x, np.zeros(model.n_params - len(x))]), probe, tool)
                             - nominal, axis=1)
        x = x * (nominal_rmse_mm * 1e-3 / np.sqrt(np.mean(gap**2))) if nominal_rmse_mm > 0 else np.zeros_like(x)
    else:
        x = np.asarray(true_x, dtype=float)
    full = np.concatenate([x, np.zeros(model.n_params - len(x))])
    rows = np.repeat(np.arange(len(labels) + len(plane_labels)), per_fixture)
    q = model.touching_angles(full, rows, rng, noise_mm * 1e-3)
    names = labels + plane_labels
    contact = np.array([names[k] if k < len(labels) else "" for k in rows], dtype=str)
    plane = np.array([names[k] if k >= len(labels) else "" for k in rows], dtype=str)
    data = MeasurementSet(
        q=q, values=np.zeros((len(q), 0)), kind=ContactModel.kind, robot=chain.name, end_frame=chain.end_frame,
        tool=tool if tool_known else None, noise=noise_mm * 1e-3 or None,
        notes={"source": f"calib-pin contact simulator, seed {seed}, {per_fixture} configurations a fixture, "
                         f"noise {noise_mm:g} mm per axis"},
        labels={"contact_id": contact, "plane_id": plane},
        sensor_meta={"distance": tuple((labels[a], labels[b], length, None) for a, b, length in known),
                     **({"tool": tool} if tool_known else {})})
    truth = Truth(x, tuple(params.names), tuple(params.units), truth_fixtures, ContactModel.kind, noise_mm * 1e-3, seed)
    return data, truth
