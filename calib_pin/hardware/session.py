"""Collecting a measurement set from a drawstring sensor, pose by pose, losing nothing.

The output is a measurement CSV in the format of :mod:`calib_pin.measurements` with a
``pose`` column. :func:`prepare_session` checks everything and writes nothing: a new
file's header, or an existing file's cut last line, is only written by
:meth:`Session.start`, once the caller has checked the rest (the serial port, the other
outputs). The file is created atomically (metadata and header written to a temporary
file, synced, then linked to its name); every completed pose is then appended as one
line on an append-only descriptor, every ``write`` checked, followed by ``fsync``. A row
that does not reach the disk in full (a full disk) is cut away again and not counted.
The file is never rewritten: a run that is killed at any moment leaves every completed
row intact, and at worst an incomplete last line, which the next run drops before it
resumes at the first pose of the pose list (read by
:func:`calib_pin.measurements.pose_list.read_pose_list`) not yet in the file.

One run at a time: a session holds an exclusive lock (``flock``) on its file from
:func:`prepare_session` until :meth:`Session.close`; a second run on the same file is
refused with one line.
"""

from __future__ import annotations

import contextlib
import datetime
import errno
import fcntl
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import CalibPinError, DataError
from ..measurements import MeasurementSet, read_measurements
from ..measurements.csv_writer import header, row
from ..robot.chain import Chain
from ..util.atomic import fsync_path, write_all
from ..util.input_files import check_regular
from ..util.progress import progress_bar
from .reader import Reader, SensorProfile, StableReading, read_stable

#: Joint angles of a resumed row must match the pose list to this many degrees.
SAME_POSE_DEG = 1e-6


class SessionWriteError(CalibPinError):
    """A row or the header did not reach the disk in full (a full disk, an I/O error).

    The message says how many poses are safe.
    """


@dataclass
class Session:
    """An output file being filled, locked for this run (see :func:`prepare_session`).

    Attributes:
        path: The measurement CSV.
        poses: The pose list (``pose_ids`` set).
        remaining: Indices into the pose list still to measure, in order.
        dropped: Text of an incomplete last line, removed by :meth:`start`, or "".
    """

    path: Path
    poses: MeasurementSet
    remaining: list[int]
    dropped: str = ""
    _fd: int | None = field(default=None, repr=False)
    _header: str | None = field(default=None, repr=False)  # to write when a new file starts
    _keep: int | None = field(default=None, repr=False)  # bytes to keep of an existing file

    @property
    def done(self) -> int:
        return len(self.poses) - len(self.remaining)

    @property
    def started(self) -> bool:
        """Whether :meth:`start` has written what it had to (rows may be appended)."""
        return self._header is None and self._keep is None and self._fd is not None

    @property
    def new(self) -> bool:
        """Whether the file does not exist yet (:meth:`start` creates it)."""
        return self._header is not None

    def start(self) -> None:
        """Write what preparing only planned: a new file with its header, or a cut last line.

        A new file is created atomically, and locked; an incomplete last line is cut.

        Raises:
            SessionWriteError: the header could not be written (nothing is then left).
            DataError: another run created the file meanwhile.
        """
        if self._header is not None:
            self._fd = _create(self.path, self._header)
            self._header = None
        elif self._keep is not None:
            assert self._fd is not None
            os.ftruncate(self._fd, self._keep)
            os.fsync(self._fd)
            self._keep = None

    def discard(self) -> None:
        """Remove a file this run created and has not written a row to, and release it.

        Another output of the run failed: all of them or none.
        """
        if self._fd is not None and self.done == 0:
            with contextlib.suppress(FileNotFoundError):
                self.path.unlink()
        self.close()

    def close(self) -> None:
        """Release the file and its lock."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> Session:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


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


def _write_all(fd: int, data: bytes, written: list[int] | None = None) -> None:
    """Write every byte of ``data``, then ``fsync``; ``written[0]`` counts the bytes written.

    A short write is continued; a write that makes no progress is a full disk.

    Raises:
        OSError: the bytes did not all reach the disk.
    """
    write_all(fd, data, written)
    os.fsync(fd)


def _lock(fd: int, path: Path) -> None:
    """Take the session's exclusive lock, or refuse: another run holds it."""
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise DataError(str(path), "another collect is writing this session now: wait for it to end, "
                        "then run the same command to resume") from None


def _create(path: Path, text: str) -> int:
    """Create ``path`` holding ``text`` atomically, locked; return its append descriptor.

    Raises:
        SessionWriteError: the header did not reach the disk (no file is left).
        DataError: another run created ``path`` meanwhile.
    """
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(tmp, os.O_RDWR | os.O_APPEND | os.O_CREAT | os.O_TRUNC, 0o644)
    except (FileExistsError, NotADirectoryError):
        raise SessionWriteError(f"{path}: cannot create its folder {path.parent}: a file is in the way; "
                                "no file was created") from None
    except OSError as e:  # a read-only folder: name the session, not its temporary file
        raise SessionWriteError(f"{path}: cannot create the session: {e.strerror or e}; no file was created") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        try:
            _write_all(fd, text.encode("utf-8"))
        except OSError as e:
            raise SessionWriteError(f"{path}: cannot write the header: {e.strerror or e}; "
                                    "no file was created") from None
        try:
            os.link(tmp, path)  # never over a file another run created meanwhile
        except FileExistsError:
            raise DataError(str(path), "another collect created this session meanwhile: "
                            "run the same command again to resume") from None
        except OSError as e:
            if e.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.ENOTSUP):
                raise
            os.replace(tmp, path)  # a filesystem without hard links
        fsync_path(path.parent)
    except BaseException:
        os.close(fd)
        raise
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
    return fd


def _read_locked(path: Path) -> tuple[int, bytes]:
    """Open an existing session for appending, lock it, and read it."""
    check_regular(path)
    try:
        fd = os.open(path, os.O_RDWR | os.O_APPEND)
    except OSError as e:
        raise DataError(str(path), f"cannot be opened to read and append: {e.strerror or e}") from None
    _lock(fd, path)
    try:
        chunks: list[bytes] = []
        offset = 0
        while chunk := os.pread(fd, 1 << 20, offset):
            chunks.append(chunk)
            offset += len(chunk)
    except OSError as e:
        os.close(fd)
        raise DataError(str(path), f"cannot be read: {e.strerror or e}") from None
    return fd, b"".join(chunks)


def prepare_session(
    out: str | Path, poses: MeasurementSet, chain: Chain, profile: SensorProfile,
    *, anchor_mm=None, tool_mm=None,
) -> Session:
    """Check the output file (to create, or to resume) and lock it; write nothing yet.

    :meth:`Session.start` then writes the header of a new file, or cuts an incomplete
    last line; :meth:`Session.close` releases the lock.

    Args:
        out: The measurement CSV to create or resume.
        poses: The pose list to measure.
        chain: The robot chain.
        profile: The sensor's profile (written in the header).
        anchor_mm, tool_mm: The drawstring's anchor (base frame) and tool point (end
            frame), [mm], or None; a resumed file's must agree.

    Raises:
        DataError: the existing file is not a measurement set of this robot, holds a
            pose that is not in the pose list or whose joint angles differ from it, or
            another run is writing it.
    """
    path = Path(out)
    if not os.path.lexists(path):
        return Session(path, poses, list(range(len(poses))),
                       _header=_header(chain, profile, poses.source, anchor_mm, tool_mm))
    fd, data = _read_locked(path)
    try:
        # A last line without a line end is a write cut short: it is checked as absent and
        # cut only once the rest has been accepted (a refused file keeps every byte).
        keep = len(data) if not data or data.endswith(b"\n") else data.rfind(b"\n") + 1
        done = read_measurements(path, chain, allow_empty=True, content=data[:keep])
        _check_resume(path, done, poses, anchor_mm, tool_mm)
    except BaseException:
        os.close(fd)
        raise
    dropped = data[keep:].decode("utf-8", "replace") if keep < len(data) else ""
    measured = {int(p) for p in done.pose_ids}  # type: ignore[union-attr]
    remaining = [k for k, pid in enumerate(poses.pose_ids) if int(pid) not in measured]  # type: ignore[arg-type]
    return Session(path, poses, remaining, dropped, _fd=fd, _keep=keep if dropped else None)


def open_session(
    out: str | Path, poses: MeasurementSet, chain: Chain, profile: SensorProfile,
    *, anchor_mm=None, tool_mm=None,
) -> Session:
    """Create the output file, or reopen it to resume; close the session when done.

    :func:`prepare_session`, then :meth:`Session.start`.

    Args:
        out, poses, chain, profile, anchor_mm, tool_mm: As :func:`prepare_session`.

    Raises:
        DataError: as :func:`prepare_session`.
        SessionWriteError: the header could not be written.
    """
    session = prepare_session(out, poses, chain, profile, anchor_mm=anchor_mm, tool_mm=tool_mm)
    try:
        session.start()
    except BaseException:
        session.close()
        raise
    return session


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
    """Append pose ``k``'s row (every byte written, then fsync); return the line written.

    Args:
        session: The started session.
        k: The pose's index in the pose list (0-based).
        reading: Its settled reading.

    Raises:
        SessionWriteError: the row did not reach the disk in full. It is cut away
            again (the file stays a valid session to resume), and the message says how
            many poses are saved.
    """
    if not session.started:
        raise RuntimeError("Session.start() before append_row")
    fd = session._fd
    assert fd is not None
    pid = int(session.poses.pose_ids[k])  # type: ignore[index]
    line = row(session.poses.q[k], [reading.mean_mm * 1e-3], labels=(pid,)) + "\n"
    size = os.fstat(fd).st_size
    data, written = line.encode("utf-8"), [0]
    try:
        _write_all(fd, data, written)
    except BaseException as e:  # a full disk, or Ctrl-C mid-write: the row is not counted
        if not isinstance(e, OSError) and written[0] == len(data):  # Ctrl-C after the whole row was written: kept
            with contextlib.suppress(OSError):
                os.fsync(fd)
            raise
        try:
            os.ftruncate(fd, size)
            os.fsync(fd)
            left = "the cut row was removed"
        except OSError:
            left = "the cut row is left unfinished (the next run drops it)"
        if not isinstance(e, OSError):
            raise
        raise SessionWriteError(
            f"{session.path}: cannot write pose {pid}: {e.strerror or e}; {left}; {session.done} of "
            f"{len(session.poses)} poses are saved: free disk space and run the same command to resume") from None
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
        session: From :func:`open_session` (started).
        reader: An open sensor reader.
        wait: Called with (pose id, position in the list 1-based, q [deg]) before each
            pose; it returns when the robot is there, or False to stop.
        report: Receives the progress lines.

    Returns:
        The number of rows written in this run.

    Raises:
        SensorFault: a fault that outlived its retries (no row is written for that pose).
        SessionWriteError: a row did not reach the disk (it is not counted).
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
