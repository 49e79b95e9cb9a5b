"""The sensor readers against a simulated indicator on a pseudo-terminal."""

import dataclasses

import pytest

from calib_pin.exceptions import CalibPinError
from calib_pin.hardware.fake_indicator import FakeIndicator, crc16
from calib_pin.hardware.reader import (
    BadFrame,
    DeviceException,
    Disconnected,
    NotSettled,
    OutOfRange,
    SensorProfile,
    SensorTimeout,
    open_reader,
    read_stable,
    read_with_retries,
)

MODBUS = SensorProfile(protocol="modbus", signed=True, scale_mm=0.001, timeout_s=0.2,
                       interval_s=0.0, retries=2)
ASCII = SensorProfile(protocol="ascii", timeout_s=0.3, interval_s=0.0, retries=2)


@pytest.fixture
def modbus():
    with FakeIndicator("modbus", 1234.567) as fake:
        reader = open_reader(fake.path, MODBUS)
        yield fake, reader
        reader.close()


@pytest.fixture
def ascii_line():
    with FakeIndicator("ascii", 987.654, period_s=0.005) as fake:
        reader = open_reader(fake.path, ASCII)
        reader.flush()
        yield fake, reader
        reader.close()


def test_crc16_known_frame():
    """The fake's CRC is Modbus's: read 2 holding registers from 0 of slave 1."""
    assert crc16(bytes([1, 3, 0, 0, 0, 2])) == bytes([0xC4, 0x0B])


@pytest.mark.parametrize(
    "settings, value",
    [
        ({"words": 2, "signed": True, "word_order": "high"}, -12.345),
        ({"words": 2, "signed": False, "word_order": "low"}, 3456.789),
        ({"words": 1, "signed": False, "word_order": "high", "scale_mm": 0.1}, 4321.0),
        ({"words": 1, "signed": True, "word_order": "high", "scale_mm": 0.1, "function": 4}, -321.5),
    ],
)
def test_modbus_encodings(settings, value):
    """16/32-bit, signed or not, either word order, functions 3 and 4, scaled to mm."""
    fake_settings = {k: v for k, v in settings.items() if k != "function"}
    fake_settings.setdefault("scale_mm", 0.001)
    with FakeIndicator("modbus", value, **fake_settings) as fake:
        profile = dataclasses.replace(MODBUS, min_mm=-1000.0, **settings)
        reader = open_reader(fake.path, profile)
        assert reader.read_mm() == pytest.approx(value, abs=1e-9)
        reader.close()


def test_modbus_stable_reading_averages_noise(modbus):
    fake, reader = modbus
    fake.noise_mm = 0.002
    reading = read_stable(reader)
    assert reading.mean_mm == pytest.approx(1234.567, abs=0.003)
    assert reading.spread_mm <= MODBUS.tolerance_mm and reading.samples == 5


@pytest.mark.parametrize(
    "fault, error, text",
    [
        ("silence", SensorTimeout, "no answer from slave 1"),
        ("crc", BadFrame, "Checksum error"),
        ("garbled", BadFrame, "bad answer"),
        ("exception", DeviceException, "Modbus exception"),
    ],
)
def test_modbus_faults_retried_then_reported(modbus, fault, error, text):
    """A transient fault is retried; past the retries it is reported, with the count."""
    fake, reader = modbus
    fake.inject(fault, 2)
    assert read_with_retries(reader) == pytest.approx(1234.567)
    fake.inject(fault, 5)
    with pytest.raises(error, match=text) as info:
        read_with_retries(reader)
    assert "3 times in a row, giving up" in str(info.value)


def test_modbus_delay_within_timeout_is_fine(modbus):
    fake, reader = modbus
    fake.delay_s = 0.05
    fake.inject("delay")
    assert reader.read_mm() == pytest.approx(1234.567)


def test_out_of_range_and_never_settling(modbus):
    fake, reader = modbus
    fake.value_mm = 6000.0
    with pytest.raises(OutOfRange, match=r"6000.000 mm .* outside the sensor range \[0, 5000\] mm"):
        read_with_retries(reader)
    fake.value_mm = 1000.0
    fake.drift_mm_per_s = 5.0
    with pytest.raises(NotSettled, match="did not settle"):
        read_stable(reader)


def test_modbus_disconnect(modbus):
    """An unplugged adapter is reported at once, not retried."""
    fake, reader = modbus
    fake.inject("disconnect")
    with pytest.raises(Disconnected, match="adapter unplugged"):
        read_with_retries(reader)


def test_open_missing_port():
    with pytest.raises(Disconnected, match="cannot open /dev/nonexistent-tty"):
        open_reader("/dev/nonexistent-tty", MODBUS)


def test_ascii_stream(ascii_line):
    fake, reader = ascii_line
    assert read_stable(reader).mean_mm == pytest.approx(987.654)
    fake.value_mm = -12.5
    reader.flush()
    with pytest.raises(OutOfRange):
        read_with_retries(reader)


@pytest.mark.parametrize("fault, error", [("garbled", BadFrame), ("crc", BadFrame), ("silence", SensorTimeout)])
def test_ascii_faults(ascii_line, fault, error):
    """Garbled and partial lines and silence are faults; a few are retried."""
    fake, reader = ascii_line
    fake.delay_s = 0.5
    reader.read_mm()
    fake.inject(fault)
    with pytest.raises(error):
        for _ in range(200):
            reader.read_mm()
    reader.flush()
    fake.inject("garbled", 2)
    assert read_with_retries(reader) == pytest.approx(987.654)


def test_ascii_custom_pattern():
    with FakeIndicator("ascii", 55.25, period_s=0.005) as fake:
        profile = dataclasses.replace(ASCII, pattern=r"\s*([-+]?\d+\.\d+) mm", scale_mm=0.001,
                                      ascii_scale_mm=2.0, zero_mm=10.0)
        reader = open_reader(fake.path, profile)
        reader.flush()
        assert reader.read_mm() == pytest.approx(120.5)  # Modbus's scale_mm does not apply
        reader.close()


def test_profile_round_trip_and_errors(tmp_path):
    path = dataclasses.replace(MODBUS, slave=7, word_order="low").save(tmp_path / "s.json")
    assert SensorProfile.load(path) == dataclasses.replace(MODBUS, slave=7, word_order="low")
    (tmp_path / "bad.json").write_text('{"slave": 7, "speed": 9}')
    with pytest.raises(CalibPinError, match="bad.json: speed: unknown sensor setting"):
        SensorProfile.load(tmp_path / "bad.json")
    (tmp_path / "bad2.json").write_text('{"function": 6}')
    with pytest.raises(CalibPinError, match="bad2.json: sensor setting function = 6: must be 3 or 4"):
        SensorProfile.load(tmp_path / "bad2.json")
    (tmp_path / "bad3.json").write_text('{"slave": ')
    with pytest.raises(CalibPinError, match="bad3.json:1: not a JSON sensor profile"):
        SensorProfile.load(tmp_path / "bad3.json")
