"""A sensor's repeatability, from what its own data repeats."""

from __future__ import annotations

import numpy as np

from calib_pin.analysis.repeatability import repeatability


def _markers(sigma, poses=50, seed=0):
    """Three markers on a rigid body at ``poses`` random placements, each coordinate read
    with noise ``sigma``: (q, values, labels)."""
    rng = np.random.default_rng(seed)
    body = np.array([[0.06, 0.0, 0.04], [-0.03, 0.052, 0.04], [-0.03, -0.052, 0.04]])
    q, values, labels = [], [], []
    for k in range(poses):
        angles = rng.uniform(-2, 2, 6)
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        c, s, t = np.cos(angles[0]), np.sin(angles[0]), 1 - np.cos(angles[0])
        x, y, z = axis
        turn = np.array([[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
                         [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
                         [t * x * z - s * y, t * y * z + s * x, t * z * z + c]])
        for label, point in zip((1, 2, 3), body, strict=True):
            q.append(angles)
            values.append(turn @ point + angles[:3] * 0.1 + rng.normal(scale=sigma, size=3))
            labels.append(label)
    return np.array(q), np.array(values), np.array(labels, dtype=object)


def test_the_markers_distances_give_the_trackers_noise():
    q, values, labels = _markers(20e-6)
    rep = repeatability(q, values, labels, None, "default")
    assert rep.from_data and abs(rep.sigma / 20e-6 - 1) < 0.2


def test_a_pose_read_again_gives_the_readings_noise():
    rng = np.random.default_rng(1)
    q = np.repeat(rng.uniform(-1, 1, (30, 6)), 3, axis=0)
    values = np.repeat(rng.uniform(0.5, 1.5, 30), 3) + rng.normal(scale=30e-6, size=90)
    rep = repeatability(q, values, None, None, "default")
    assert rep.from_data and abs(rep.sigma / 30e-6 - 1) < 0.25


def test_without_repeats_the_stated_noise_else_unknown():
    q = np.random.default_rng(2).uniform(-1, 1, (20, 6))
    values = np.linspace(0.5, 1.5, 20)
    assert repeatability(q, values, None, 50e-6, "file").sigma == 50e-6
    assert repeatability(q, values, None, 50e-6, "estimate").sigma is None
    assert repeatability(q[:0], values[:0], None, None, "default").sigma is None  # no rows
