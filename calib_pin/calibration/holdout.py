"""How a calibration holds out rows to score it: a seeded fraction, K folds or a separate session.

- :class:`Fraction`: each set (of role ``split``) split by pose, ``test_fraction`` of its
  poses held out, seeded (the paper's 80/20).
- :class:`Folds`: the same split, then K-fold cross-validation by pose of the training rows
  (each fold held out once while the model is fitted on the others).
- :class:`TestSet`: a separate validation session: every row of every set trains, the
  session is scored. Measured with a training set's sensor set-up (``register`` None,
  checked), or on a new one re-registered first on its stated rows
  (:func:`calib_pin.calibration.validation.register_session`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import ArgumentError
from ..measurements import MeasurementSet
from ..util.arguments import as_float, as_int, as_path

#: The ``role`` column value of a validation session's registration rows.
REGISTER_ROLE = "register"


@dataclass(frozen=True)
class Fraction:
    """A seeded share of each set's poses held out.

    Attributes:
        test_fraction: The share of poses held out, in [0, 1) (0: every row trains).
    """

    test_fraction: float = 0.2

    def __post_init__(self) -> None:
        """Raises: ArgumentError naming ``test_fraction``."""
        object.__setattr__(self, "test_fraction",
                           as_float(self.test_fraction, "test_fraction", 0.0, 1.0, high_open=True))


@dataclass(frozen=True)
class Folds:
    """K-fold cross-validation by pose of the training rows, besides the fit on all of them.

    The training rows are those :class:`Fraction`'s ``test_fraction`` leaves.

    Attributes:
        k: Folds, at least 2 (and at most the training poses).
        test_fraction: As :class:`Fraction`'s.
    """

    k: int
    test_fraction: float = 0.0

    def __post_init__(self) -> None:
        """Raises: ArgumentError naming ``k`` or ``test_fraction``."""
        object.__setattr__(self, "k", as_int(self.k, "k", 2))
        object.__setattr__(self, "test_fraction",
                           as_float(self.test_fraction, "test_fraction", 0.0, 1.0, high_open=True))


@dataclass(frozen=True)
class TestSet:
    """A separate validation session and how its sensor set-up relates to the calibration.

    Attributes:
        data: The session: a measurement CSV or a :class:`~calib_pin.measurements.MeasurementSet`.
        register: None: a training set's set-up (checked, never fitted); an int k >= 1:
            a new set-up, re-registered on k of the session's poses (its first k in file
            order; of a session of several fixtures or points, one of each in turn:
            :func:`~calib_pin.calibration.validation.registration_rows`);
            ``"role"``: re-registered on its rows whose ``role`` column is ``register``.
        same: With ``register`` None, the label of the training set whose set-up the session
            shares (its file's stem, or file name); "" the only training set of its kind.
    """

    __test__ = False  # not a pytest class

    data: str | Path | MeasurementSet
    register: int | str | None = None
    same: str = ""

    def __post_init__(self) -> None:
        """Raises: ArgumentError naming ``test_data``, ``register`` or ``same``."""
        if not isinstance(self.data, MeasurementSet):
            as_path(self.data, "test_data")
        r = self.register
        if r is not None and not (r == "role" or (isinstance(r, int | np.integer) and not isinstance(r, bool) and r >= 1)):
            raise ArgumentError("register", f"expected a number of poses >= 1 or 'role' (rows with role={REGISTER_ROLE}), "
                                f"got {r!r}")
        if not isinstance(self.same, str):
            raise ArgumentError("same", f"expected a training set's label (text), got {type(self.same).__name__}")
        if r is not None and self.same:
            raise ArgumentError("same", "a re-registered session has its own set-up: give register or same, not both")


#: How rows are held out: a fraction, folds, or a session.
Holdout = Fraction | Folds | TestSet


def as_holdout(test_fraction: float | None = None, test_data: Any = None) -> Holdout:
    """The holdout of ``calibrate``'s two arguments ``test_fraction`` and ``test_data``.

    ``test_data`` (a path, a set or a :class:`TestSet`) when given, else :class:`Fraction`
    of ``test_fraction``.

    Args:
        test_fraction: Share of each set's poses held out, in [0, 1); None: the default
            (0.2), or none beside ``test_data`` (where only 0 agrees).
        test_data: A separate validation session (a CSV path, a
            :class:`~calib_pin.measurements.MeasurementSet` or a :class:`TestSet`), or None.

    Raises:
        ArgumentError: naming the argument; a share held out beside ``test_data``.
    """
    if test_data is None:
        return Fraction() if test_fraction is None else Fraction(test_fraction)
    if test_fraction is not None and Fraction(test_fraction).test_fraction > 0:
        raise ArgumentError("test_fraction", f"{test_fraction} beside a separate validation session, which is the "
                            "test (every row trains): leave it out, or 0")
    if isinstance(test_data, TestSet):
        return test_data
    if not isinstance(test_data, MeasurementSet | str | Path) and not hasattr(test_data, "__fspath__"):
        raise ArgumentError("test_data", f"expected a measurement CSV path, a MeasurementSet or a TestSet, got "
                            f"{type(test_data).__name__}")
    return TestSet(test_data)


def fold_of_rows(groups: np.ndarray, folds: int, seed: int) -> np.ndarray:
    """Each row's fold (0 .. folds - 1), whole poses to a fold.

    ``groups`` holds one pose label a row; the poses are dealt out in a seeded random order.
    """
    poses = np.unique(groups)
    order = np.random.default_rng(seed).permutation(len(poses))
    fold_of_pose = np.empty(len(poses), dtype=int)
    fold_of_pose[order] = np.arange(len(poses)) % folds
    return fold_of_pose[np.searchsorted(poses, groups)]
