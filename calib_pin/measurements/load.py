"""A robot's measurement set, read from its file (or its shipped default) and checked.

It is checked against the chain, and comes with the chain for the set's own end frame.
"""

from __future__ import annotations

from pathlib import Path

from ..exceptions import ArgumentError, DataError
from ..robot import Chain, load_chain
from .checks import check_set
from .csv_reader import read_set
from .dataset import MeasurementSet


def load_data(chain: Chain, data: str | Path | MeasurementSet | None, robot_label: str = "",
              end_frame: str | None = None) -> tuple[Chain, MeasurementSet]:
    """The measurement set for ``chain``, and the chain again for the set's own ``end_frame``.

    The set is the shipped default when ``data`` is None; the chain is rebuilt for the
    set's end frame when the caller named none; a set in memory is checked as a file is
    (:func:`~calib_pin.measurements.checks.check_measurements`).
    """
    if data is None:
        data = chain.description.default_data
        if data is None or not Path(data).is_file():
            raise ArgumentError("data", f"robot '{chain.name}' has no default measurement set: give one")
    given = data if isinstance(data, MeasurementSet) else None
    # a path its caller checked (FitSet, TestSet): read as it is
    loaded = data if isinstance(data, MeasurementSet) else read_set(Path(data), chain, robot_label=robot_label)
    if end_frame is not None and loaded.end_frame and loaded.end_frame != end_frame:
        raise DataError(loaded.source or "data", f"was measured at end frame '{loaded.end_frame}', not '{end_frame}': "
                        "leave --end-frame out, or change the file's '# end_frame:' if it is wrong", None, "end_frame")
    if end_frame is None and loaded.end_frame and loaded.end_frame != chain.end_frame:
        chain = load_chain(chain.description, loaded.end_frame)
        loaded = given if given is not None else read_set(Path(loaded.source), chain, robot_label=robot_label)
    return chain, check_set(chain, loaded, robot_label)
