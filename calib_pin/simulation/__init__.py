"""Simulated measurement sets with known true deviations, of any registered sensor."""

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
