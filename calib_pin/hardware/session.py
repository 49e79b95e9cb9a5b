"""Collecting a measurement set from a drawstring sensor, pose by pose, losing nothing.

The output is a measurement CSV in the format of :mod:`calib_pin.measurements` with a
``pose`` column. It is created atomically (metadata and header written to a temporary
file, synced, then renamed); every completed pose is then appended as one line with
one ``write`` on an append-only descriptor followed by ``fsync``. The file is never
rewritten: a run that is killed at any moment leaves every completed row intact, and at
worst an incomplete last line, which the next run drops before it resumes at the first
pose of the pose list not yet in the file.
"""

from __future__ import annotations

import contextlib
import datetime
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import DataError
from ..measurements import MeasurementSet, read_measurements
from ..measurements.csv_writer import header, row
from ..progress import progress_bar
from ..robot.chain import Chain
from .reader import Reader, SensorProfile, StableReading, read_stable

#: Joint angles of a resumed row must match the pose list to this many degrees.
SAME_POSE_DEG = 1e-6


@dataclass
class Session:
    """An output file being filled.

    Attributes:
        path: The measurement CSV.
        poses: The pose list (``pose_ids`` set).
        remaining: Indices into the pose list still to measure, in order.
        dropped: Text of an incomplete last line removed when resuming, or "".
    """

    path: Path
    poses: MeasurementSet
    remaining: list[int]
    dropped: str = ""

    @property
    def done(self) -> int:
        return len(self.poses) - len(self.remaining)


def read_pose_list(path: str | Path, chain: Chain) -> MeasurementSet:
    """A pose list: ``pose`` (optional, default 1..n) and joint columns, within limits.

    Raises:
        DataError: as :func:`calib_pin.measurements.read_measurements`.
    """
    poses = read_measurements(path, chain, readings=False)
    if poses.pose_ids is None:
        poses.pose_ids = np.arange(1, len(poses) + 1)
    return poses


def _header(chain: Chain, profile: SensorProfile, poses_path: str, anchor_mm, tool_mm) -> str:
    lines = [f"# robot: {chain.name}", f"# end_frame: {chain.end_frame}"]
    if anchor_mm is not None:
        lines.append("# anchor_mm: " + ", ".join(f"{v:g}" for v in anchor_mm))
    if tool_mm is not None:
        lines.append("# tool_mm: " + ", ".join(f"{v:g}" for v in tool_mm))
    lines.append(f"# sensor: {profile.describe()}")
    lines.append(f"# stability: {profile.samples} samples within {profile.tolerance_mm:g} mm, averaged")
    lines.append(f"# poses: {poses_path}")
    lines.append(f"# started: {datetime.datetime.now().isoformat(timespec='seconds')}")
    return "\n".join(lines + [header(chain.n_joints, "cable", with_pose=True)]) + "\n"


def _fsync_dir(path: Path) -> None:
    fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def open_session(
    out: str | Path, poses: MeasurementSet, chain: Chain, profile: SensorProfile,
    *, anchor_mm=None, tool_mm=None,
) -> Session:
    """Create the output file, or reopen it to resume.

    Raises:
        DataError: the existing file is not a measurement set of this robot, or holds a
            pose that is not in the pose list or whose joint angles differ from it.
    """
    path = Path(out)
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.name + ".tmp")
        with tmp.open("w", encoding="utf-8") as f:
            f.write(_header(chain, profile, poses.source, anchor_mm, tool_mm))
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
        _fsync_dir(path)
        return Session(path, poses, list(range(len(poses))))
    try:
        data = path.read_bytes()
    except OSError as e:
        raise DataError(str(path), f"cannot be read: {e.strerror or e}") from None
    # A last line without a line end is a write cut short: it is checked as absent and
    # cut only once the rest has been accepted (a refused file keeps every byte).
    keep = len(data) if not data or data.endswith(b"\n") else data.rfind(b"\n") + 1
    done = read_measurements(path, chain, allow_empty=True, content=data[:keep])
    _check_resume(path, done, poses, anchor_mm, tool_mm)
    dropped = ""
    if keep < len(data):
        os.truncate(path, keep)
        dropped = data[keep:].decode("utf-8", "replace")
    measured = {int(p) for p in done.pose_ids}  # type: ignore[union-attr]
    remaining = [k for k, pid in enumerate(poses.pose_ids) if int(pid) not in measured]  # type: ignore[arg-type]
    return Session(path, poses, remaining, dropped)


def _check_resume(path: Path, done: MeasurementSet, poses: MeasurementSet, anchor_mm: Any, tool_mm: Any) -> None:
    """Refuse to resume a file that is not a session of this pose list and sensor set-up."""
    if done.kind != "cable" and len(done):
        raise DataError(str(path), "is not a drawstring session; choose another --out")
    for name, given, kept in (("anchor_mm", anchor_mm, done.anchor), ("tool_mm", tool_mm, done.tool)):
        if given is not None and (kept is None or not np.allclose(np.asarray(given) * 1e-3, kept, atol=1e-9)):
            was = "none" if kept is None else ", ".join(f"{v * 1e3:g}" for v in kept)
            raise DataError(str(path), f"was collected with {name} {was}, not {', '.join(f'{v:g}' for v in given)}; "
                            "resume with the same value or choose another --out", None, name)
    if done.pose_ids is None:
        raise DataError(path, "has no 'pose' column, so it cannot be resumed; choose another --out")
    assert poses.pose_ids is not None and done.lines is not None
    index = {int(pid): k for k, pid in enumerate(poses.pose_ids)}
    for r, pid in enumerate(done.pose_ids):
        k = index.get(int(pid))
        line = int(done.lines[r])
        if k is None:
            raise DataError(path, f"pose {pid} is not in {poses.source}; choose another --out", line, "pose")
        if np.max(np.abs(np.rad2deg(done.q[r] - poses.q[k]))) > SAME_POSE_DEG:
            raise DataError(
                path, f"pose {pid} has other joint angles than in {poses.source}; choose another --out",
                line, "pose",
            )


def append_row(session: Session, k: int, reading: StableReading) -> str:
    """Append pose ``k``'s row (one write, then fsync); return the line written."""
    pid = int(session.poses.pose_ids[k])  # type: ignore[index]
    line = row(session.poses.q[k], [reading.mean_mm * 1e-3], labels=(pid,)) + "\n"
    fd = os.open(session.path, os.O_WRONLY | os.O_APPEND)
    try:
        os.write(fd, line.encode("utf-8"))
        os.fsync(fd)
    finally:
        os.close(fd)
    return line


@contextlib.contextmanager
def _bar_aside(bar: Any) -> Iterator[None]:
    """Clear the progress bar (if any) while other lines are written, then redraw it."""
    if bar is not None:
        bar.clear()
    try:
        yield
    finally:
        if bar is not None:
            bar.refresh()


def collect(
    session: Session, reader: Reader, wait: Callable[[int, int, np.ndarray], bool],
    report: Callable[[str], None] = print,
) -> int:
    """Measure the remaining poses of a session.

    Args:
        session: From :func:`open_session`.
        reader: An open sensor reader.
        wait: Called with (pose id, position in the list 1-based, q [deg]) before each
            pose; it returns when the robot is there, or False to stop.
        report: Receives the progress lines.

    Returns:
        The number of rows written in this run.

    Raises:
        SensorFault: a fault that outlived its retries (no row is written for that pose).
    """
    n = len(session.poses)
    written = 0
    assert session.poses.pose_ids is not None
    with progress_bar(len(session.remaining), "poses") as bar:
        for k in list(session.remaining):
            pid = int(session.poses.pose_ids[k])
            with _bar_aside(bar):  # the prompt and the lines go to a clear line, the bar below
                if not wait(pid, k + 1, np.rad2deg(session.poses.q[k])):
                    break
            reader.flush()
            reading = read_stable(reader)
            append_row(session, k, reading)
            session.remaining.remove(k)
            written += 1
            with _bar_aside(bar):
                report(f"pose {pid} ({session.done} of {n}): {reading.mean_mm:.3f} mm, spread "
                       f"{reading.spread_mm:.3f} mm over {reading.samples} samples ({reading.reads} read)")
            if bar is not None:
                bar.update()
    return written
