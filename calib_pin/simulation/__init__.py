"""Simulated measurement sets with known true deviations, of any registered sensor."""

from typing import Any

from .contact import simulate_contacts
from .pose import simulate_poses
from .simulator import (
    NOISE_KINDS,
    SimulationDraw,
    Truth,
    reading_noise,
    simulate,
    simulate_positions,
    simulate_sessions,
    simulate_set,
)

__all__ = ["NOISE_KINDS", "SimulationDraw", "Truth", "reading_noise", "simulate", "simulate_positions",
           "simulate_contacts", "simulate_poses", "simulate_sessions", "simulate_set"]


def __getattr__(name: str) -> Any:
    """The old names of what moved elsewhere (the simulator's), with a DeprecationWarning."""
    from ..util.deprecation import moved_names

    return moved_names(__name__, {
        "STUDENT_DOF": "calib_pin.simulation.simulator", "OUTLIER_FRACTION": "calib_pin.simulation.simulator",
        "OUTLIER_MM": "calib_pin.simulation.simulator"})(name)
