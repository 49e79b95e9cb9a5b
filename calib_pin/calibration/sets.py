"""The measurement sets of a calibration: what the caller says of each, and what is made of it.

A calibration is one robot and a list of measurement sets; one set is a list of one. Each
set keeps its own sensor set-up (its file's anchor, tool point and cable offset, or a
device frame and markers fitted on that set's own training rows), its own split and its
own noise sigma_k: the caller's (:class:`FitSet`'s ``noise_mm``, or ``noise_mm`` for all
sets), else its file's (``# noise_mm``), else estimated from the data
(:mod:`calib_pin.calibration.noise`).

A set's role says how its rows are used: split by pose (``split``, the default), all
training rows (``train``), or all test rows (``test``: scored, never fitted; only a sensor
whose set-up is not fitted on the data, a drawstring with its anchor known).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import ArgumentError, CalibPinError, DataError
from ..measurements import MeasurementSet
from ..sensors import SensorSetup, sensor_for
from ..sensors.setup import given as given_value
from ..util.arguments import MAX_MM, as_choice, as_float, as_instance, as_path
from .repeats import repeat_error, shares_lines

#: A set's role: split by pose (default), all training rows, or all test rows.
ROLES = ("split", "train", "test")


@dataclass(frozen=True)
class FitSet:
    """One measurement set of a calibration, with what the caller says of it.

    Attributes:
        data: A measurement CSV or a :class:`~calib_pin.measurements.MeasurementSet`.
        label: Its name in reports and unknowns (``s2:anchor_x``); default the file's stem.
        role: ``split`` (train/test by pose, the default), ``train`` or ``test``.
        noise_mm: Its sensor noise (1 sigma) [mm]; default the file's ``noise_mm``, else
            estimated from the residual.
        setup: Its sensor set-up overrides, a record of its sensor kind
            (:class:`~calib_pin.sensors.CableSetup`): each field given wins over the file's
            metadata (``estimate`` is one for all sets: give it to ``calibrate``).
    """

    data: str | Path | MeasurementSet
    label: str = ""
    role: str = "split"
    noise_mm: float | None = None
    setup: SensorSetup | None = None

    def __post_init__(self) -> None:
        """Raises: ArgumentError naming ``data``, ``role``, ``label`` or ``noise_mm``."""
        if self.data is not None and not isinstance(self.data, MeasurementSet):
            as_path(self.data, "data")
        as_choice(self.role, "role", ROLES)
        as_instance(self.label, "label", str, "a set's label (text)")
        if self.noise_mm is not None:
            as_float(self.noise_mm, "noise_mm", 0.0, MAX_MM, low_open=True, unit="mm")
        if self.setup is not None and not isinstance(self.setup, SensorSetup):
            raise ArgumentError("setup", f"of set {self.label or self.data}: expected a sensor set-up record, got "
                                f"{type(self.setup).__name__}")


@dataclass(frozen=True)
class PreparedSet:
    """A measurement set loaded and checked against the robot, ready to be fitted.

    Attributes:
        data: The set's rows.
        label: Its label (given, else its file's stem, else ``s<k>``).
        role: ``split``, ``train`` or ``test``.
        sigma: Its noise (1 sigma) [m] when known, else None (estimated when it matters).
        origin: Where ``sigma`` came from: ``caller``, ``file``, or ``estimate`` (unknown).
        options: Its sensor options: the shared ones (``estimate``, ``compliance``) with
            its own set-up overrides laid over them.
        overrides: The set-up fields the caller gave for this set (its FitSet's ``setup``),
            each winning over its file's; ``overridden``: those of them the file also had.
    """

    data: MeasurementSet
    label: str
    role: str
    sigma: float | None
    origin: str
    options: dict[str, Any]
    overrides: tuple[str, ...] = ()
    overridden: tuple[str, ...] = ()

    @property
    def kind(self) -> str:
        return self.data.kind

    def split(self, test_fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
        """Its (train, test) rows: by pose with the seed and fraction, or all of one side by its role."""
        from ..analysis.metrics import split_rows

        every = np.arange(len(self.data))
        if self.role == "train":
            return every, every[:0]
        if self.role == "test":
            return every[:0], every
        groups = self.data.groups
        poses = np.unique(groups)
        train_poses, _ = split_rows(len(poses), test_fraction, seed)
        in_train = np.isin(groups, poses[train_poses])
        return np.flatnonzero(in_train), np.flatnonzero(~in_train)


def set_sigma(given: FitSet, noise_mm: float | None, data: MeasurementSet) -> tuple[float | None, str]:
    """A set's sigma [m] and its origin: its FitSet's, the caller's for all, its file's, or None."""
    if given.noise_mm is not None:
        return float(given.noise_mm) * 1e-3, "caller"
    if noise_mm is not None:
        return float(noise_mm) * 1e-3, "caller"
    if data.noise:
        return float(data.noise), "file"
    return None, "estimate"


def set_overrides(given: FitSet, data: MeasurementSet, label: str) -> tuple[dict[str, Any], tuple[str, ...]]:
    """A set's own set-up overrides, checked against its sensor kind, and those its file also had.

    The overrides are its FitSet's ``setup``, the fields given.

    Args:
        given: The set as the caller gave it.
        data: The set's loaded measurements.
        label: The set's label, for messages.

    Raises:
        ArgumentError: a ``setup`` with ``estimate`` (one for every set).
        DataError: a field the set's sensor has no use for, naming the set's file and the field.
    """
    if given.setup is None:
        return {}, ()
    chosen = given.setup.given()
    if "estimate" in chosen:
        raise ArgumentError("estimate", f"of set {label}: it applies to every set, give it to calibrate (--estimate)")
    sensor = sensor_for(data.kind)
    sensor.refuse_foreign(chosen, data)  # a field another sensor takes
    own = set(sensor.setup_type.field_names()) - {"estimate"}
    for name in chosen:
        if name not in own:
            theirs = f"theirs: {', '.join(sorted(own))}" if own else "they take none"
            raise DataError(data.source or label, f"not a set-up option of {sensor.data_name} "
                            f"(set {label}; {theirs})", None, name)
    filed = sensor.setup_of(data)
    had = {n for n, v in (filed.options() if filed is not None else {}).items() if given_value(v)}
    return chosen, tuple(n for n in chosen if n in had)


def labelled(sets: list[FitSet], loaded: list[MeasurementSet]) -> tuple[str, ...]:
    """Each set's label: given, else its file's stem, else ``s<k>``.

    The same label or the same file twice is refused.

    Args:
        sets: The sets as the caller gave them.
        loaded: Their loaded measurements, in the same order.

    Raises:
        CalibPinError: two sets of one label; a file given twice; a set of role ``test``
            whose sensor fits its set-up on training rows.
    """
    labels: list[str] = []
    for k, (s, data) in enumerate(zip(sets, loaded, strict=True)):
        label = s.label or (Path(data.source).stem if data.source else f"s{k + 1}")
        for other, earlier in zip(labels, loaded[:k], strict=True):  # one file in two sets (its path twice)
            if data.source and earlier.source and Path(data.source).resolve() == Path(earlier.source).resolve() \
                    and shares_lines(data, earlier):  # subsets of one file may share no line
                raise DataError(data.source, f"given twice (sets {other} and {k + 1}): a row is fitted once")
        if label in labels:
            raise CalibPinError(f"two sets are labelled '{label}': give each set its own label (or file name)")
        labels.append(label)
    for s, data, label in zip(sets, loaded, labels, strict=True):
        if s.role == "test" and sensor_for(data.kind).fits_setup:
            raise DataError(data.source or label, f"a {data.kind} set with role 'test' has no training rows to fit "
                            f"its {sensor_for(data.kind).fitted_setup} on: give it role 'split'")
    return tuple(labels)


def refuse_repeats(sets: list[PreparedSet] | tuple[PreparedSet, ...]) -> None:
    """Refuse one measurement in two sets: a file again under another name (a hard link, a
    copy), or rows of one set repeated in another (:mod:`calib_pin.calibration.repeats`);
    subsets of one file that share no line are two sets.

    Raises:
        DataError: naming both files (or sets) and the rows.
    """
    for k, s in enumerate(sets):
        for earlier in sets[:k]:
            if s.data.source and earlier.data.source and not shares_lines(s.data, earlier.data) \
                    and Path(s.data.source).resolve() == Path(earlier.data.source).resolve():
                continue
            twice = repeat_error(earlier.data, earlier.label, s.data, s.label)
            if twice:
                raise DataError(s.data.source or f"set {s.label}", f"{twice}: a row is fitted once; give each "
                                "measurement in one set")


#: A set whose training RMSE after the fit exceeds this many noise sigmas, and whose rows a
#: column of :data:`SETUP_COLUMNS` assigns to several set-ups, gets a warning naming them.
SETUP_SIGMAS = 5.0

#: Columns (a file's extra columns) that say which sensor set-up a row was measured with.
SETUP_COLUMNS = ("session", "setup", "station")


def mixed_setups_warning(data: MeasurementSet, train: np.ndarray, after_rmse_mm: float, sigma: float) -> str | None:
    """The warning for a set fitted as one sensor set-up whose rows come from several, or None.

    The set's own column says its training rows come from several set-ups (``session`` A,
    B, C: three anchors in one file); the warning is given when the fit leaves more than
    SETUP_SIGMAS x its noise ``sigma`` [m].
    """
    for name in SETUP_COLUMNS:
        column = data.extra.get(name)
        if column is None or after_rmse_mm <= SETUP_SIGMAS * sigma * 1e3:
            continue
        setups = sorted({str(v) for v in np.asarray(column, dtype=object)[train]})
        if len(setups) > 1:
            shown = ", ".join(setups[:6]) + (", ..." if len(setups) > 6 else "")
            return (f"{Path(data.source).name if data.source else 'the set'}: its '{name}' column names "
                    f"{len(setups)} set-ups ({shown}) fitted here as one (train RMSE {after_rmse_mm:.3g} mm, "
                    f"{after_rmse_mm / (sigma * 1e3):.0f} x the noise {sigma * 1e3:.3g} mm): give each set-up its "
                    "own file with its own metadata and pass them together (--data a.csv --data b.csv)")
    return None


#: Held-out rows that miss by this many times the training rows (and by SETUP_SIGMAS noise sigmas) get a warning.
HELD_OUT_TIMES = 10.0


def held_out_warning(label: str, train_rmse: float, test_rmse: float, sigma_mm: float, unit: str) -> str | None:
    """The warning for a set whose held-out rows miss by far more than its training rows, or None.

    RMSE and noise in the set's unit (``unit``; mm, px). Such a fit follows its training rows
    and not the robot: too few poses for its unknowns, or held-out rows that do not belong (an
    image of another pose, a set-up moved between the rows).
    """
    if test_rmse <= HELD_OUT_TIMES * train_rmse or test_rmse <= SETUP_SIGMAS * sigma_mm:
        return None
    return (f"{label}: the held-out rows miss by {test_rmse:.3g} {unit}, {test_rmse / max(train_rmse, 1e-12):.0f} "
            f"times the training rows' {train_rmse:.3g} {unit}: too few poses for the unknowns, or held-out rows that "
            "do not belong (an image of another pose, a set-up moved between rows); report.json's per_pose names "
            "the worst poses")

