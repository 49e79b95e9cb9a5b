"""Shared seeded fixtures: the IRB120 chain and a simulated session with known truth."""

from __future__ import annotations

import gc

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.robot.poses import random_poses
from calib_pin.sensors import CableModel


@pytest.fixture(scope="session")
def chain() -> cp.Chain:
    return cp.load_chain("irb120")


@pytest.fixture(scope="session")
def params(chain) -> cp.DHModel:
    return cp.parameter_model(chain)


@pytest.fixture(scope="session")
def session(chain, params):
    """120 poses (96 train + 24 test at the default split), sigma 0.05 mm, nominal error 2 mm."""
    return cp.simulate(chain, params, 120, seed=7, noise_mm=0.05)


@pytest.fixture(scope="session")
def fresh(chain, params, session):
    """1000 fresh poses and their noise-free true readings [m]."""
    _, truth = session
    q = random_poses(chain, 1000, np.random.default_rng(123))
    return q, CableModel(chain, params, truth.sensor).predict(truth.x, q)


@pytest.fixture(scope="session")
def fresh_rmse_mm(fresh):
    """RMSE [mm] of a calibration's predictions on the fresh poses against the truth."""

    def rmse(result: cp.CalibrationResult) -> float:
        q, true_readings = fresh
        return float(np.sqrt(np.mean((result.predict(q) - true_readings) ** 2)) * 1e3)

    return rmse


@pytest.fixture(autouse=True)
def _collector_as_it_was():
    """A test that runs a script in this process (runpy) goes through calib_pin.cli.process,
    which turns the cyclic collector off and freezes every object for the process's exit:
    put the test session's collector back after each test."""
    enabled = gc.isenabled()
    yield
    gc.unfreeze()
    if enabled:
        gc.enable()


@pytest.fixture
def device_fits(monkeypatch) -> list[int]:
    """The rows of every position device-frame fit made while the test runs (``fit_device`` counted)."""
    from calib_pin.sensors import position

    real, calls = position.fit_device, []

    def counted(*args, **kwargs):
        calls.append(len(args[2]))
        return real(*args, **kwargs)

    monkeypatch.setattr(position, "fit_device", counted)
    return calls
