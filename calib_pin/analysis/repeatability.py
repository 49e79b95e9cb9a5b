"""How well a sensor repeats, from what its own data repeats: the floor of any residual.

A residual far above the sensor's repeatability is not reading noise: it is an error the
model does not explain (joint readings not in step with the measurement, compliance not
modelled, the wrong tool point), and it will be there at every pose the robot works at.
Where a set repeats itself, the repeatability can be read from it without any robot model:

- several markers (reflectors) at one pose: their distances from each other are the same
  at every pose, so their spread is the tracker's (a distance of two points with noise
  sigma per coordinate spreads by sqrt(2) sigma);
- the same pose read again: the spread of the readings of one pose (one point).

Otherwise a set's stated noise (``# noise_mm``, ``noise_mm=``) is taken as its
repeatability, and without one it is unknown.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Joint angles within this of each other are one pose, [rad].
SAME_POSE_RAD = 1e-6
#: Distances between two markers at fewer poses than this give no repeatability.
MIN_POSES = 5


@dataclass(frozen=True)
class Repeatability:
    """A sensor's repeatability, 1 sigma per value (a reading, a coordinate).

    Attributes:
        sigma: [m], or None when unknown.
        source: Where it came from, for people (``12 markers' distances at 120 poses``,
            ``stated noise (file)``, ``unknown``).
        from_data: True when the set's own repeats gave it.
    """

    sigma: float | None
    source: str
    from_data: bool = False

    def as_dict(self) -> dict[str, object]:
        return {"sigma_mm": None if self.sigma is None else self.sigma * 1e3, "source": self.source,
                "from_data": self.from_data}


def _poses(q: np.ndarray) -> np.ndarray:
    """Each row's pose index: rows whose joint angles agree within SAME_POSE_RAD share one."""
    key = np.round(np.asarray(q, dtype=float) / SAME_POSE_RAD).astype(np.int64)
    _, index = np.unique(key, axis=0, return_inverse=True)
    return index.reshape(-1)


def _marker_distances(values: np.ndarray, points: np.ndarray | None, poses: np.ndarray) -> float | None:
    """sigma per coordinate from the spread of the distances between markers seen at one pose."""
    if points is None or values.ndim != 2 or values.shape[1] != 3:
        return None
    labels = np.asarray([str(p) for p in points])
    pairs: dict[tuple[str, str], list[float]] = {}
    for pose in np.unique(poses):
        rows = np.flatnonzero(poses == pose)
        if len(rows) < 2:
            continue
        for i, a in enumerate(rows):
            for b in rows[i + 1:]:
                if labels[a] != labels[b]:
                    key = (min(labels[a], labels[b]), max(labels[a], labels[b]))
                    pairs.setdefault(key, []).append(float(np.linalg.norm(values[a] - values[b])))
    spreads = [(np.var(d, ddof=1), len(d) - 1) for d in pairs.values() if len(d) >= MIN_POSES]
    if not spreads:
        return None
    pooled = sum(v * dof for v, dof in spreads) / sum(dof for _, dof in spreads)
    return float(np.sqrt(pooled / 2.0))


def _repeated_readings(values: np.ndarray, points: np.ndarray | None, poses: np.ndarray) -> tuple[float, int] | None:
    """sigma per value from readings of one point repeated at one pose, and the repeats."""
    values = values.reshape(len(values), -1)
    point = np.zeros(len(values), dtype=object) if points is None else np.asarray(points, dtype=object)
    groups: dict[tuple[int, str], list[int]] = {}
    for row, (pose, label) in enumerate(zip(poses, point, strict=True)):
        groups.setdefault((int(pose), str(label)), []).append(row)
    squares, dof = 0.0, 0
    for rows in groups.values():
        if len(rows) > 1:
            block = values[rows]
            squares += float(np.sum((block - block.mean(axis=0)) ** 2))
            dof += (len(rows) - 1) * block.shape[1]
    if dof < MIN_POSES:
        return None
    return float(np.sqrt(squares / dof)), dof


def repeatability(q: np.ndarray, values: np.ndarray | None, points: np.ndarray | None, stated: float | None,
                  origin: str) -> Repeatability:
    """The repeatability of a set's sensor: from its own repeats, else its stated noise.

    Args:
        q: The rows' joint angles, shape (n_rows, n_joints), [rad].
        values: What the sensor read, [m]: readings (n_rows,) or positions (n_rows, 3); None
            for a sensor whose repeats say nothing of its noise (touches, 6-D poses).
        points: Each row's measured point (a marker's label or index), or None.
        stated: The noise stated for the set, [m], or None.
        origin: Where ``stated`` came from (``file``, ``caller``).
    """
    if values is not None and len(values):
        values = np.asarray(values, dtype=float)
        poses = _poses(q)
        markers = _marker_distances(values, points, poses)
        if markers is not None:
            n = len(np.unique(poses))
            return Repeatability(markers, f"spread of the distances between markers seen at one pose ({n} poses)",
                                 True)
        repeated = _repeated_readings(values, points, poses)
        if repeated is not None:
            return Repeatability(repeated[0], f"readings repeated at one pose ({repeated[1]} repeats)", True)
    if stated is not None and origin in ("file", "caller"):
        return Repeatability(stated, f"stated noise ({'the file' if origin == 'file' else 'given'})")
    return Repeatability(None, "unknown: the set states no noise and repeats no pose")
