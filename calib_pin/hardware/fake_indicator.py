"""A simulated drawstring indicator on a pseudo-terminal, for tests and dry runs.

:class:`FakeIndicator` opens a pseudo-terminal pair; the collector opens its device
path (``indicator.path``, e.g. ``/dev/pts/5``) exactly like a real serial port. It
serves Modbus RTU (functions 03/04 on one register block, with a hand-written CRC:
this is the test double, the collector itself uses minimalmodbus) or prints an ASCII
line stream (``+0123.456 mm``). Faults can be injected for the next N answers:
``delay``, ``silence``, ``crc``, ``garbled`` (a truncated frame or line), ``exception``
(Modbus exception 04), and ``disconnect`` (the device goes away). ``noise_mm`` adds
Gaussian noise to each answer and ``drift_mm_per_s`` makes the value creep.

The value served is ``value_mm``, or, with ``follow``, ``values_mm[k]`` where k is the
number of data rows already in the collector's output file: the robot "moves" to the
next pose once the previous one is saved. That makes a dry run without hardware.
"""

from __future__ import annotations

import contextlib
import os
import select
import threading
import time
import tty
from pathlib import Path

import numpy as np

from ..exceptions import CalibPinError

FAULTS = ("delay", "silence", "crc", "garbled", "exception", "disconnect")


def crc16(frame: bytes) -> bytes:
    """Modbus RTU CRC-16 (polynomial 0xA001), low byte first."""
    crc = 0xFFFF
    for byte in frame:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return bytes([crc & 0xFF, crc >> 8])


def _rows_in(path: Path) -> int:
    """Data rows of a measurement CSV (lines after the header that are not comments)."""
    try:
        lines = [ln for ln in path.read_text().splitlines() if ln.strip() and not ln.startswith("#")]
    except OSError:
        return 0
    return max(len(lines) - 1, 0)


def _check_settings(value_mm, values_mm, slave, register, words, signed, scale_mm, zero_mm,
                    noise_mm, drift_mm_per_s) -> None:
    """Refuse a setting the server thread could not serve (before it starts, with one line).

    Raises:
        CalibPinError: naming the first bad setting.
    """
    numbers = {"scale_mm": scale_mm, "zero_mm": zero_mm, "noise_mm": noise_mm, "drift_mm_per_s": drift_mm_per_s}
    for name, value in numbers.items():
        if not np.isfinite(value):
            raise CalibPinError(f"fake indicator setting {name} = {value!r}: must be a finite number")
    if scale_mm == 0 or noise_mm < 0:
        raise CalibPinError(f"fake indicator setting {'scale_mm' if scale_mm == 0 else 'noise_mm'}: "
                            "must be non-zero (scale) or non-negative (noise)")
    for name, value, low, high in (("slave", slave, 1, 247), ("register", register, 0, 65535), ("words", words, 1, 2)):
        if not low <= value <= high:
            raise CalibPinError(f"fake indicator setting {name} = {value!r}: must be {low} to {high}")
    bits = 16 * words
    low, high = (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if signed else (0, (1 << bits) - 1)
    for value in [value_mm, *(values_mm if values_mm is not None else [])]:
        counts = (value - zero_mm) / scale_mm if np.isfinite(value) else np.inf
        if not low <= counts <= high:
            raise CalibPinError(f"fake indicator value {value:g} mm does not fit in {bits} bits at "
                                f"{scale_mm:g} mm per count ({'signed' if signed else 'unsigned'})")


class FakeIndicator:
    """A simulated indicator serving one value over a pseudo-terminal.

    Args:
        protocol: ``modbus`` or ``ascii``.
        value_mm: Value served (settable while running).
        slave, register, words, signed, word_order, scale_mm, zero_mm: Modbus encoding,
            as in :class:`calib_pin.hardware.reader.SensorProfile`.
        period_s: ASCII: time between printed lines.
        noise_mm: Gaussian noise added to each answer (1 sigma).
        drift_mm_per_s: Creep of the value over time.
        values_mm, follow: Serve ``values_mm[rows in follow]`` (see the module docstring).
        delay_s: Delay of a ``delay`` fault.
        seed: Seed of the noise.
    """

    def __init__(
        self, protocol: str = "modbus", value_mm: float = 1000.0, *, slave: int = 1,
        register: int = 0, words: int = 2, signed: bool = True, word_order: str = "high",
        scale_mm: float = 0.001, zero_mm: float = 0.0, period_s: float = 0.01,
        noise_mm: float = 0.0, drift_mm_per_s: float = 0.0, values_mm=None,
        follow: str | Path | None = None, delay_s: float = 1.0, seed: int = 0,
    ) -> None:
        if protocol not in ("modbus", "ascii"):
            raise ValueError(f"protocol must be modbus or ascii, got {protocol!r}")
        _check_settings(value_mm, values_mm, slave, register, words, signed, scale_mm, zero_mm,
                        noise_mm, drift_mm_per_s)
        self.protocol = protocol
        self.value_mm = value_mm
        self.slave, self.register, self.words = slave, register, words
        self.signed, self.word_order = signed, word_order
        self.scale_mm, self.zero_mm = scale_mm, zero_mm
        self.period_s, self.noise_mm, self.drift_mm_per_s = period_s, noise_mm, drift_mm_per_s
        self.values_mm = None if values_mm is None else list(values_mm)
        self.follow = Path(follow) if follow else None
        self.delay_s = delay_s
        self.requests = 0
        self._faults: list[str] = []
        self._rng = np.random.default_rng(seed)
        self._t0 = time.monotonic()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.master, self._slave_fd = os.openpty()
        self._fds_open = True
        tty.setraw(self._slave_fd)
        self.path = os.ttyname(self._slave_fd)

    # -- control -------------------------------------------------------------------
    def inject(self, fault: str, count: int = 1) -> None:
        """Apply ``fault`` to the next ``count`` answers (or lines)."""
        if fault not in FAULTS:
            raise ValueError(f"unknown fault {fault!r} (valid: {', '.join(FAULTS)})")
        with self._lock:
            self._faults += [fault] * count

    def _next_fault(self) -> str | None:
        with self._lock:
            return self._faults.pop(0) if self._faults else None

    def current_mm(self) -> float:
        """The value an answer carries now (noise and drift included)."""
        value = self.value_mm
        if self.values_mm is not None and self.follow is not None:
            value = self.values_mm[min(_rows_in(self.follow), len(self.values_mm) - 1)]
        value += self.drift_mm_per_s * (time.monotonic() - self._t0)
        if self.noise_mm:
            value += self._rng.normal(scale=self.noise_mm)
        return value

    def start(self) -> FakeIndicator:
        """Serve in a background thread."""
        self._thread = threading.Thread(target=self.serve_forever, daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread:
            self._thread.join(timeout=2)
        self._close()

    def _close(self) -> None:
        with self._lock:
            fds, self._fds_open = (self.master, self._slave_fd) if self._fds_open else (), False
        for fd in fds:  # once only: a descriptor number closed twice may be someone else's
            with contextlib.suppress(OSError):
                os.close(fd)

    def __enter__(self) -> FakeIndicator:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    # -- serving -------------------------------------------------------------------
    def serve_forever(self) -> None:
        try:
            if self.protocol == "modbus":
                self._serve_modbus()
            else:
                self._serve_ascii()
        except OSError:  # the pty went away (disconnect fault, or stop)
            pass

    def _disconnect(self) -> None:
        self._stop.set()
        self._close()

    def _registers(self) -> bytes:
        counts = int(round((self.current_mm() - self.zero_mm) / self.scale_mm))
        bits = 16 * self.words
        counts &= (1 << bits) - 1  # two's complement for negative values
        data = counts.to_bytes(2 * self.words, "big")
        if self.words == 2 and self.word_order == "low":
            data = data[2:] + data[:2]
        return data

    def _serve_modbus(self) -> None:
        buffer = b""
        while not self._stop.is_set():
            ready, _, _ = select.select([self.master], [], [], 0.05)
            if not ready:
                buffer = b""  # a silent gap ends a frame (RTU framing)
                continue
            buffer += os.read(self.master, 256)
            while len(buffer) >= 8:
                frame, buffer = buffer[:8], buffer[8:]
                if crc16(frame[:6]) != frame[6:]:
                    buffer = b""
                    break
                self._answer(frame)

    def _answer(self, frame: bytes) -> None:
        slave, function = frame[0], frame[1]
        start, count = int.from_bytes(frame[2:4], "big"), int.from_bytes(frame[4:6], "big")
        if slave != self.slave:
            return
        self.requests += 1
        fault = self._next_fault()
        if fault == "silence":
            return
        if fault == "disconnect":
            self._disconnect()
            return
        if fault == "delay":
            time.sleep(self.delay_s)
        if function not in (3, 4):
            body = bytes([slave, function | 0x80, 1])
        elif fault == "exception" or start != self.register or count != self.words:
            body = bytes([slave, function | 0x80, 4 if fault == "exception" else 2])
        else:
            data = self._registers()
            body = bytes([slave, function, len(data)]) + data
        reply = body + crc16(body)
        if fault == "crc":
            reply = reply[:-1] + bytes([reply[-1] ^ 0xFF])
        elif fault == "garbled":
            reply = reply[: len(reply) // 2]
        os.write(self.master, reply)

    def _serve_ascii(self) -> None:
        os.set_blocking(self.master, False)
        while not self._stop.is_set():
            self.requests += 1  # lines printed
            fault = self._next_fault()
            line = f"{self.current_mm():+010.3f} mm\r\n"
            if fault == "disconnect":
                self._disconnect()
                return
            if fault == "silence":
                time.sleep(self.delay_s)
                continue
            if fault == "delay":
                time.sleep(self.delay_s)
            if fault == "garbled":
                line = "+01#3.4\x7f? mm\r\n"
            elif fault in ("crc", "exception"):
                line = line[:5]  # a partial line, then the next one
            try:
                os.write(self.master, line.encode("ascii"))
            except BlockingIOError:
                pass  # nobody reads: the line is lost, as on a real line
            time.sleep(self.period_s)
