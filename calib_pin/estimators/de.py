"""Differential evolution (paper M7): scipy.optimize.differential_evolution."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.optimize import differential_evolution

from ..exceptions import ArgumentError
from .base import Callback, EstimateResult, Tracker
from .problem import LeastSquares

#: scipy's ``updating`` modes (see :class:`DE`).
UPDATING = ("immediate", "deferred")


@dataclass(frozen=True)
class DE:
    """scipy's differential evolution in the whitened search coordinates.

    The coordinates are those of :mod:`calib_pin.estimators.subspace`.
    Strategy ``best1bin`` with dithered mutation (0.5, 1) and recombination 0.7 (scipy's
    defaults), a population of ``popsize`` x dimension members, Latin-hypercube start in
    a box of +-``bound`` times the start residual's norm per coordinate, with x0 as one
    member. No gradient polish (``polish=False``): the result is DE's own.

    One iteration is one generation (about ``popsize`` x dimension evaluations). It stops
    after ``max_iter`` generations or on scipy's ``tol``: the spread of the population's
    costs fell below ``tol`` times their mean.

    ``updating`` is scipy's: ``"immediate"`` (the default, the figures of the benchmark
    and of Table I) evaluates one trial at a time and a better trial joins the population
    at once, so the next trial already mutates from it; ``"deferred"`` makes a whole
    generation's trials from the population as it was, evaluates them in one batched
    forward-kinematics call (the problem's ``costs``, :meth:`.base.Tracker.costs`) and
    then keeps the better of each pair. That is another search (other iterations and
    estimate, of about the same accuracy), cheaper per evaluation.
    """

    popsize: int = 3
    max_iter: int = 300
    mutation: tuple[float, float] = (0.5, 1.0)
    recombination: float = 0.7
    tol: float = 1e-2
    bound: float = 1.0
    updating: str = "immediate"
    minimises_cost: ClassVar[bool] = True  # see :class:`.robust.Robust`
    #: Records once at the start, then once per generation: a progress bar of max_iter.
    reports_generations: ClassVar[bool] = True

    def __call__(
        self, problem: LeastSquares, x0: np.ndarray, *, seed: int = 0, noise: float = 5e-5,
        callback: Callback | None = None,
    ) -> EstimateResult:
        if self.updating not in UPDATING:
            raise ArgumentError("updating", f"expected one of {', '.join(UPDATING)}, got {self.updating!r}")
        track = Tracker(problem, callback)
        space = track.whitened(x0)

        def cost(z: np.ndarray) -> float:
            return track.cost(space.to_x(z))

        def costs(zs: np.ndarray) -> np.ndarray:
            """The costs of a generation's trials, zs (dim, S) -> (S,), in one batch."""
            return np.array(track.costs([space.to_x(z) for z in zs.T]))

        start = cost(np.zeros(space.dim))
        track.record(np.sqrt(start))
        half = self.bound * np.sqrt(start * problem.n_values)
        deferred = self.updating == "deferred"
        fit = differential_evolution(
            costs if deferred else cost, [(-half, half)] * space.dim, x0=np.zeros(space.dim),
            updating=self.updating, vectorized=deferred,
            strategy="best1bin", popsize=self.popsize, maxiter=self.max_iter,
            mutation=self.mutation, recombination=self.recombination, tol=self.tol,
            seed=seed, polish=False, init="latinhypercube",
            callback=lambda intermediate_result: track.record(np.sqrt(intermediate_result.fun)),
        )
        return track.result(space.to_x(fit.x), int(fit.nit), str(fit.message), status=0 if fit.success else 1)
