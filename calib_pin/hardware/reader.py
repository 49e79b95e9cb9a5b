"""Reading a drawstring displacement sensor's indicator over a serial line (RS485).

Two protocols, both on pyserial:

- ``modbus``: Modbus RTU through minimalmodbus (framing, CRC and exception responses
  are the library's): slave address, function 03 (holding) or 04 (input registers),
  register address, one or two 16-bit words, signed or not, high or low word first.
- ``ascii``: an indicator that prints lines such as ``+0123.456 mm``; a regular
  expression with one group picks the number.

The raw number times the scale (``scale_mm`` per Modbus count, ``ascii_scale_mm`` per
printed unit) plus ``zero_mm`` is the reading in mm.
A :class:`SensorProfile` holds every setting and can be saved to and loaded from a
small JSON file. Faults raise :class:`SensorFault` subclasses with a clear message;
:func:`read_stable` retries transient faults a bounded number of times and averages
samples once they agree within a tolerance.
"""

from __future__ import annotations

import contextlib
import json
import re
import time
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np

from ..exceptions import CalibPinError
from ..util.atomic import write_text
from ..util.input_files import check_regular
from ..util.optional import require

serial = require("serial")

#: Default ASCII pattern: a signed decimal number, optionally followed by "mm".
DEFAULT_PATTERN = r"\s*([-+]?\d+(?:\.\d*)?)\s*(?:mm)?\s*"


class SensorFault(CalibPinError):
    """The sensor or the line failed; the message says how."""


class SensorTimeout(SensorFault):
    """No (complete) answer within the timeout."""


class BadFrame(SensorFault):
    """A garbled, partial or CRC-failing answer."""


class DeviceException(SensorFault):
    """The indicator answered with a Modbus exception."""


class Disconnected(SensorFault):
    """The port vanished (adapter unplugged, device closed)."""


class OutOfRange(SensorFault):
    """A reading outside the sensor's range."""


class NotSettled(SensorFault):
    """The reading never became stable."""


TRANSIENT = (SensorTimeout, BadFrame, DeviceException, OutOfRange)


@dataclass
class SensorProfile:
    """Everything needed to read one sensor; units in the names.

    Attributes:
        protocol: ``modbus`` or ``ascii``.
        baud, parity (N/E/O), stopbits (1 or 2), bytesize: Serial line settings.
        timeout_s: How long to wait for an answer (a line, a Modbus reply).
        slave: Modbus slave address (1-247).
        function: Modbus function, 3 (holding) or 4 (input registers).
        register: First register address (0-based, as on the wire).
        words: 1 (16-bit) or 2 (32-bit) registers.
        signed: Two's complement value.
        word_order: ``high`` (high word first) or ``low`` (low word first), for 2 words.
        pattern: ASCII protocol: regular expression whose group 1 is the number;
            the whole line must match.
        scale_mm: Modbus: mm per count.
        ascii_scale_mm: ASCII: mm per printed unit (1 for an indicator printing mm).
        zero_mm: Added after scaling, [mm].
        min_mm, max_mm: Sensor range; readings outside are faults.
        samples: Consecutive samples that must agree to count as stable.
        tolerance_mm: Largest spread (max - min) of those samples, [mm].
        max_reads: Samples tried per pose before giving up (never settles).
        interval_s: Pause between samples.
        retries: Consecutive transient faults tolerated before giving up.
    """

    protocol: str = "modbus"
    baud: int = 9600
    parity: str = "N"
    stopbits: int = 1
    bytesize: int = 8
    timeout_s: float = 0.5
    slave: int = 1
    function: int = 3
    register: int = 0
    words: int = 2
    signed: bool = False
    word_order: str = "high"
    pattern: str = DEFAULT_PATTERN
    scale_mm: float = 1.0
    ascii_scale_mm: float = 1.0
    zero_mm: float = 0.0
    min_mm: float = 0.0
    max_mm: float = 5000.0
    samples: int = 5
    tolerance_mm: float = 0.02
    max_reads: int = 50
    interval_s: float = 0.05
    retries: int = 3

    def check(self) -> SensorProfile:
        """Raise CalibPinError naming the first bad setting; return self."""
        for f in fields(self):
            value, kind = getattr(self, f.name), type(getattr(SensorProfile, f.name))
            if not (isinstance(value, kind) or (kind is float and isinstance(value, int))) or (
                    kind is not bool and isinstance(value, bool)):
                raise CalibPinError(f"sensor setting {f.name} = {value!r}: must be a {kind.__name__}")
        problems = [
            (self.protocol in ("modbus", "ascii"), "protocol", "modbus or ascii"),
            (self.baud > 0, "baud", "a positive number"),
            (self.parity in ("N", "E", "O"), "parity", "N, E or O"),
            (self.stopbits in (1, 2), "stopbits", "1 or 2"),
            (self.bytesize in (7, 8), "bytesize", "7 or 8"),
            (self.timeout_s > 0, "timeout_s", "positive"),
            (1 <= self.slave <= 247, "slave", "1 to 247"),
            (self.function in (3, 4), "function", "3 or 4"),
            (0 <= self.register <= 65535, "register", "0 to 65535"),
            (self.words in (1, 2), "words", "1 or 2"),
            (self.word_order in ("high", "low"), "word_order", "high or low"),
            (np.isfinite(self.scale_mm) and self.scale_mm != 0, "scale_mm", "a non-zero number"),
            (np.isfinite(self.ascii_scale_mm) and self.ascii_scale_mm != 0, "ascii_scale_mm", "a non-zero number"),
            (np.isfinite(self.zero_mm), "zero_mm", "a finite number"),
            (self.min_mm < self.max_mm, "min_mm/max_mm", "min below max"),
            (self.samples >= 1, "samples", "at least 1"),
            (self.tolerance_mm >= 0, "tolerance_mm", "non-negative"),
            (self.max_reads >= self.samples, "max_reads", "at least samples"),
            (self.interval_s >= 0, "interval_s", "non-negative"),
            (self.retries >= 0, "retries", "non-negative"),
        ]
        for ok, name, need in problems:
            if not ok:
                raise CalibPinError(f"sensor setting {name} = {getattr(self, name.split('/')[0])!r}: must be {need}")
        try:
            if re.compile(self.pattern).groups < 1:
                raise CalibPinError(f"sensor setting pattern {self.pattern!r}: needs one (group) for the number")
        except re.error as e:
            raise CalibPinError(f"sensor setting pattern {self.pattern!r}: {e}") from None
        return self

    def save(self, path: str | Path) -> Path:
        """Write the profile as JSON."""
        path = Path(path)
        write_text(path, json.dumps(asdict(self), indent=2) + "\n")
        return path

    @classmethod
    def load(cls, path: str | Path) -> SensorProfile:
        """Read a profile saved by :meth:`save` (unknown keys are an error).

        Args:
            path: The profile file.

        Raises:
            CalibPinError: unreadable file, unknown key, or a bad value.
        """
        try:
            check_regular(path)
            doc = json.loads(Path(path).read_text())
        except OSError as e:
            raise CalibPinError(f"{path}: cannot read sensor profile: {e.strerror or e}") from None
        except json.JSONDecodeError as e:
            raise CalibPinError(f"{path}:{e.lineno}: not a JSON sensor profile: {e.msg}") from None
        known = {f.name: f.type for f in fields(cls)}
        if not isinstance(doc, dict):
            raise CalibPinError(f"{path}: a sensor profile is a JSON object")
        for key in doc:
            if key not in known:
                raise CalibPinError(f"{path}: {key}: unknown sensor setting (known: {', '.join(known)})")
        try:
            return cls(**doc).check()
        except TypeError as e:
            raise CalibPinError(f"{path}: {e}") from None
        except CalibPinError as e:
            raise CalibPinError(f"{path}: {e}") from None

    def describe(self) -> str:
        """One line for a file's metadata."""
        line = f"{self.protocol} {self.baud} {self.bytesize}{self.parity}{self.stopbits}"
        if self.protocol == "modbus":
            line += (f", slave {self.slave}, function {self.function}, register {self.register}, "
                     f"{16 * self.words}-bit {'signed' if self.signed else 'unsigned'}, "
                     f"{self.word_order} word first, {self.scale_mm:g} mm/count")
        else:
            line += f", pattern {self.pattern!r}, {self.ascii_scale_mm:g} mm/unit"
        return line + f", zero {self.zero_mm:g} mm"

    @property
    def scale(self) -> float:
        """mm per raw unit of the profile's protocol."""
        return self.scale_mm if self.protocol == "modbus" else self.ascii_scale_mm


class Reader:
    """Reads single raw values from the sensor; subclasses speak one protocol."""

    profile: SensorProfile

    def read_raw(self) -> float:
        """One raw value (counts, or the printed number)."""
        raise NotImplementedError

    def flush(self) -> None:
        """Drop anything buffered (before reading a new pose)."""

    def close(self) -> None:
        """Release the port."""

    def read_mm(self) -> float:
        """One reading in mm, range-checked.

        Raises:
            SensorFault: any fault (see the subclasses).
        """
        raw = self.read_raw()
        value = raw * self.profile.scale + self.profile.zero_mm
        if not self.profile.min_mm <= value <= self.profile.max_mm:
            raise OutOfRange(
                f"reading {value:.3f} mm (raw {raw:g}) is outside the sensor range "
                f"[{self.profile.min_mm:g}, {self.profile.max_mm:g}] mm"
            )
        return value


def _serial_kwargs(profile: SensorProfile) -> dict:
    return {"baudrate": profile.baud, "parity": profile.parity, "stopbits": profile.stopbits,
            "bytesize": profile.bytesize, "timeout": profile.timeout_s}


class ModbusReader(Reader):
    """Modbus RTU over a serial port, through minimalmodbus."""

    def __init__(self, port: str, profile: SensorProfile) -> None:
        minimalmodbus = require("minimalmodbus")
        self.profile = profile
        self._mm = minimalmodbus
        try:
            self.instrument = minimalmodbus.Instrument(port, profile.slave, mode=minimalmodbus.MODE_RTU)
        except (serial.SerialException, OSError) as e:
            raise Disconnected(f"cannot open {port}: {e}") from None
        for key, value in _serial_kwargs(profile).items():
            setattr(self.instrument.serial, key, value)
        self.instrument.clear_buffers_before_each_transaction = True
        self.port = port

    def read_raw(self) -> float:
        p, mm = self.profile, self._mm
        try:
            if p.words == 1:
                return float(self.instrument.read_register(p.register, 0, p.function, p.signed))
            order = mm.BYTEORDER_BIG if p.word_order == "high" else mm.BYTEORDER_LITTLE_SWAP
            return float(self.instrument.read_long(p.register, p.function, p.signed, order))
        except mm.NoResponseError:
            raise SensorTimeout(f"no answer from slave {p.slave} on {self.port} within {p.timeout_s:g} s") from None
        except mm.InvalidResponseError as e:
            raise BadFrame(f"bad answer from slave {p.slave} on {self.port}: {e}") from None
        except mm.SlaveReportedException as e:
            raise DeviceException(f"slave {p.slave} answered with a Modbus exception: {e}") from None
        except (serial.SerialException, OSError) as e:
            raise Disconnected(f"{self.port} failed (adapter unplugged?): {e}") from None

    def flush(self) -> None:
        try:
            self.instrument.serial.reset_input_buffer()
        except (serial.SerialException, OSError) as e:
            raise Disconnected(f"{self.port} failed (adapter unplugged?): {e}") from None

    def close(self) -> None:
        with contextlib.suppress(serial.SerialException, OSError):
            self.instrument.serial.close()


class AsciiReader(Reader):
    """Lines printed by the indicator, parsed by the profile's pattern."""

    def __init__(self, port: str, profile: SensorProfile) -> None:
        self.profile = profile
        self.port = port
        self._pattern = re.compile(profile.pattern)
        try:
            self.serial = serial.Serial(port, **_serial_kwargs(profile))
        except (serial.SerialException, OSError) as e:
            raise Disconnected(f"cannot open {port}: {e}") from None
        self._fresh = True

    def read_raw(self) -> float:
        try:
            if self._fresh:  # after a flush the first line may have lost its start
                self._fresh = False
                self.serial.readline()
            line = self.serial.readline()
        except (serial.SerialException, OSError) as e:
            raise Disconnected(f"{self.port} failed (adapter unplugged?): {e}") from None
        if not line:
            raise SensorTimeout(f"no line from {self.port} within {self.profile.timeout_s:g} s")
        if not line.endswith(b"\n"):
            raise BadFrame(f"partial line from {self.port}: {line[:40]!r}")
        try:
            text = line.decode("ascii").strip("\r\n")
        except UnicodeDecodeError:
            raise BadFrame(f"garbled line from {self.port}: {line[:40]!r}") from None
        match = self._pattern.fullmatch(text)
        if not match:
            raise BadFrame(f"line {text[:40]!r} from {self.port} does not match {self.profile.pattern!r}")
        return float(match.group(1))

    def flush(self) -> None:
        try:
            self.serial.reset_input_buffer()
        except (serial.SerialException, OSError) as e:
            raise Disconnected(f"{self.port} failed (adapter unplugged?): {e}") from None
        self._fresh = True

    def close(self) -> None:
        with contextlib.suppress(serial.SerialException, OSError):
            self.serial.close()


def open_reader(port: str, profile: SensorProfile) -> Reader:
    """A reader for the profile's protocol on ``port`` (a device path such as /dev/ttyUSB0)."""
    profile.check()
    return ModbusReader(port, profile) if profile.protocol == "modbus" else AsciiReader(port, profile)


def read_with_retries(reader: Reader, sleep=time.sleep) -> float:
    """One reading [mm]; transient faults are retried up to ``profile.retries`` times.

    Args:
        reader: An open sensor reader (its ``profile`` sets the retries and the pause).
        sleep: Waits a number of seconds between tries (replaced in tests).

    Raises:
        SensorFault: a disconnect at once; a transient fault once the retries are used,
            with the count in the message.
    """
    failures = 0
    while True:
        try:
            return reader.read_mm()
        except TRANSIENT as e:
            failures += 1
            if failures > reader.profile.retries:
                raise type(e)(f"{e} ({failures} times in a row, giving up)") from None
            reader.flush()
            sleep(reader.profile.interval_s)


@dataclass(frozen=True)
class StableReading:
    """A settled reading.

    Attributes:
        mean_mm: Mean of the agreeing samples, [mm].
        spread_mm: Their max - min, [mm].
        samples: How many were averaged.
        reads: Samples read in all for this pose.
    """

    mean_mm: float
    spread_mm: float
    samples: int
    reads: int


def read_stable(reader: Reader, sleep=time.sleep) -> StableReading:
    """Read until the last ``samples`` readings agree within ``tolerance_mm``; average them.

    Args:
        reader: An open sensor reader (its ``profile`` sets ``samples``, ``tolerance_mm``
            [mm] and ``max_reads``).
        sleep: Waits a number of seconds between samples (replaced in tests).

    Raises:
        NotSettled: no such run within ``max_reads`` readings.
        SensorFault: a fault that outlived its retries.
    """
    p = reader.profile
    window: list[float] = []
    for reads in range(1, p.max_reads + 1):
        window.append(read_with_retries(reader, sleep))
        window = window[-p.samples:]
        if len(window) == p.samples and max(window) - min(window) <= p.tolerance_mm:
            return StableReading(float(np.mean(window)), max(window) - min(window), p.samples, reads)
        sleep(p.interval_s)
    spread = max(window) - min(window)
    raise NotSettled(
        f"reading did not settle: the last {len(window)} of {p.max_reads} samples spread "
        f"{spread:.3f} mm, more than the tolerance {p.tolerance_mm:g} mm"
    )
