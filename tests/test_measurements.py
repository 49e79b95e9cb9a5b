"""Measurement CSVs: round trip, units, and one clear error per kind of bad input."""

from pathlib import Path

import numpy as np
import pytest

import calib_pin as cp
from calib_pin.measurements import write_poses

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
HEADER = "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,length_mm"
META = "# robot: irb120\n# anchor_mm: 600, 200, -100\n# tool_mm: 0, 0, 50\n"
ROW = "10,20,-30,40,-50,60,812.5"


def _write(tmp_path, text, name="s.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_round_trip(tmp_path, chain, session):
    """Writing then reading a set gives the same angles (1e-9 deg) and readings (1 nm)."""
    data, _ = session
    path = tmp_path / "set.csv"
    cp.write_measurements(path, data)
    back = cp.read_measurements(path, chain)
    np.testing.assert_allclose(back.q, data.q, atol=1e-10)
    np.testing.assert_allclose(back.lengths, data.lengths, atol=1e-9)
    np.testing.assert_allclose(back.anchor, data.anchor)
    np.testing.assert_allclose(back.tool, data.tool)
    assert back.robot == "irb120" and back.lines[0] == 8  # 6 metadata lines, header, then data


def test_units_in_column_names(tmp_path, chain):
    """_rad and _m columns are read as such; _deg and _mm converted to SI."""
    deg = cp.read_measurements(_write(tmp_path, META + HEADER + "\n" + ROW + "\n"), chain)
    rad_row = ",".join(str(np.deg2rad(v)) for v in (10, 20, -30, 40, -50, 60)) + ",0.8125"
    rad = cp.read_measurements(
        _write(tmp_path, META + HEADER.replace("_deg", "_rad").replace("_mm", "_m") + "\n" + rad_row + "\n", "r.csv"),
        chain,
    )
    np.testing.assert_allclose(deg.q, rad.q)
    np.testing.assert_allclose(deg.lengths, [0.8125])
    np.testing.assert_allclose(deg.anchor, [0.6, 0.2, -0.1])


@pytest.mark.parametrize(
    "header, row, message",
    [
        (HEADER.replace("q4_deg,", ""), "10,20,-30,-50,60,812.5", r"s.csv:4: missing column q4_deg"),
        (HEADER + ",length_cm", ROW + ",21", r"s.csv:4: length_cm: unit 'cm' is not read"),
        (HEADER, ROW.replace("-30", "abc"), r"s.csv:5: q3_deg: 'abc' is not a number"),
        (HEADER, ROW.replace("812.5", "nan"), r"s.csv:5: length_mm: 'nan' is not a finite number"),
        (HEADER, ROW.replace("20", "inf"), r"s.csv:5: q2_deg: 'inf' is not a finite number"),
        (HEADER.replace(",length_mm", ",q7_deg,length_mm"), "10,20,-30,40,-50,60,0,812.5", r"s.csv:4: has joint column q7 but robot 'irb120' has 6 joints"),
        (HEADER, ROW.replace("-30", "75"), r"s.csv:5: q3_deg: 75 is outside the limits of joint_3 \[-110, 70\] deg"),
        (HEADER, ROW.replace("812.5", "-1"), r"s.csv:5: length_mm: -1 is negative"),
        (HEADER, "10,20,-30,40,-50,60", r"s.csv:5: has 6 fields, the header has 7"),
        (HEADER.replace("q1_deg", "q1_deg,q1_deg"), "1," + ROW, r"s.csv:4: q1_deg: column appears twice"),
    ],
)
def test_bad_rows_and_columns(tmp_path, chain, header, row, message):
    """Each kind of bad input is one error naming file, line and field."""
    path = _write(tmp_path, META + header + "\n" + row + "\n")
    with pytest.raises(cp.DataError, match=message):
        cp.read_measurements(path, chain)


@pytest.mark.parametrize(
    "text, message",
    [
        ("", r"s.csv: no header line"),
        (META + HEADER + "\n", r"s.csv: has a header but no data rows"),
        ("# anchor_mm: 1, 2\n" + HEADER + "\n" + ROW + "\n", r"s.csv:1: anchor_mm: needs 3 numbers"),
        ("# robot: ur5\n" + HEADER + "\n" + ROW + "\n", r"s.csv: robot: is for robot 'ur5', not 'irb120'"),
    ],
)
def test_bad_files_and_metadata(tmp_path, chain, text, message):
    """Empty files, bad metadata and a file for another robot are refused."""
    with pytest.raises(cp.DataError, match=message):
        cp.read_measurements(_write(tmp_path, text), chain)


@pytest.mark.parametrize(
    "header, row",
    [
        (HEADER, "200,20,-30,40,-50,60,812.5"),  # joint_1 of irb120 stops at 165 deg
        (HEADER.replace("q6_deg", "q6_deg,q7_deg"), "10,20,-30,40,-50,60,0,812.5"),  # a 7-joint arm
    ],
    ids=["outside-the-limits", "seven-joints"],
)
def test_another_robots_file_is_named_by_its_robot_line(tmp_path, chain, header, row):
    """A file of another robot is refused for its robot line, before its joints are read as
    this robot's (a joint-limit breach, a joint too many)."""
    path = _write(tmp_path, "# robot: panda\n" + header + "\n" + row + "\n")
    with pytest.raises(cp.DataError, match=r"^.*s\.csv: robot: is for robot 'panda', not 'irb120'"):
        cp.read_measurements(path, chain)


def test_a_urdfs_robot_name_names_its_robot(tmp_path):
    """A file's robot line may give a URDF's <robot name> as well as its file stem."""
    urdf = tmp_path / "gen3lite.urdf"
    urdf.write_text(cp.load_chain("irb120").description.urdf.read_text().replace('name="abb_irb120"', 'name="kinova"'))
    chain = cp.load_chain(str(urdf))
    for name in ("kinova", "gen3lite", str(urdf)):
        data = cp.read_measurements(_write(tmp_path, f"# robot: {name}\n" + HEADER + "\n" + ROW + "\n"), chain)
        assert data.robot == name
    with pytest.raises(cp.DataError, match=r"is for robot 'kinova2', not 'gen3lite' \(nor 'kinova', its URDF's"):
        cp.read_measurements(_write(tmp_path, "# robot: kinova2\n" + HEADER + "\n" + ROW + "\n"), chain)


def test_missing_file(tmp_path, chain):
    """A missing file is named."""
    with pytest.raises(cp.DataError, match="nope.csv: no such file"):
        cp.read_measurements(tmp_path / "nope.csv", chain)


def test_too_few_rows_for_the_parameters(tmp_path):
    """Rows that identify (nearly) nothing are refused before estimating: 20 readings of
    one pose identify 1 direction (counted against the directions, not the 24 unknowns)."""
    path = _write(tmp_path, META + HEADER + "\n" + "\n".join([ROW] * 20) + "\n")
    with pytest.raises(cp.DataError, match=r"s.csv: the training poses identify only 1 of 24 directions: all 20 rows "
                                           "are at 1 distinct pose"):
        cp.calibrate("irb120", path)


def test_missing_sensor_geometry(tmp_path):
    """Without anchor_mm the anchor is pre-fitted (tests/test_cable_prefit.py), which one
    pose cannot do; without tool_mm calibration says where to give it."""
    path = _write(tmp_path, "# tool_mm: 0,0,50\n" + HEADER + "\n" + "\n".join([ROW] * 40) + "\n")
    with pytest.raises(cp.DataError, match=r"1 distinct pose"):
        cp.calibrate("irb120", path)
    path = _write(tmp_path, HEADER + "\n" + "\n".join([ROW] * 40) + "\n")
    with pytest.raises(cp.DataError, match=r"tool_mm: no tool point: .* or estimate it \(--estimate tool\)"):
        cp.calibrate("irb120", path)


def test_pose_list_and_duplicate_pose(tmp_path, chain):
    """A pose list has no length column; a pose number may appear only once."""
    path = tmp_path / "p.csv"
    write_poses(path, np.zeros((3, 6)), robot="irb120")
    poses = cp.read_measurements(path, chain, readings=False)
    assert poses.pose_ids.tolist() == [1, 2, 3] and poses.kind == "poses" and len(poses) == 3
    with pytest.raises(cp.DataError, match="missing column length_mm"):
        cp.read_measurements(path, chain)
    path.write_text(path.read_text().replace("\n3,", "\n2,"))
    with pytest.raises(cp.DataError, match=r"p.csv:5: pose: pose 2 appears twice"):
        cp.read_measurements(path, chain, readings=False)


# --- real files (issue 20, 3): extra columns, ';' and decimal commas --------------------

EXTRA = HEADER + ",temp_C,sigma_mm,time,comment"
EXTRA_ROWS = [ROW + ",21.5,0.012,2024-05-01T10:00:00,first", ROW.replace("10,", "11,", 1) + ",21.7,0.011,,"]


def test_extra_columns_are_kept_and_reported(tmp_path, chain):
    """Columns that are not calib-pin's are read into ``extra`` (numbers as floats, the rest
    as text), named by ``ignored_note``, kept by ``subset`` and written back."""
    data = cp.read_measurements(_write(tmp_path, META + EXTRA + "\n" + "\n".join(EXTRA_ROWS) + "\n"), chain)
    assert list(data.extra) == ["temp_C", "sigma_mm", "time", "comment"]
    np.testing.assert_array_equal(data.extra["temp_C"], [21.5, 21.7])
    np.testing.assert_array_equal(data.extra["sigma_mm"], [0.012, 0.011])
    assert data.extra["time"].tolist() == ["2024-05-01T10:00:00", ""] and data.extra["comment"].tolist() == ["first", ""]
    assert data.ignored_note() == "ignored columns: temp_C, sigma_mm, time, comment (in s.csv; read and kept, not used)"
    assert data.subset(np.array([1])).extra["temp_C"].tolist() == [21.7]
    cp.write_measurements(tmp_path / "back.csv", data)
    back = cp.read_measurements(tmp_path / "back.csv", chain)
    assert back.extra["time"].tolist() == data.extra["time"].tolist()
    np.testing.assert_array_equal(back.extra["temp_C"], data.extra["temp_C"])
    np.testing.assert_array_equal(back.q, data.q)
    plain = cp.read_measurements(_write(tmp_path, META + HEADER + "\n" + ROW + "\n", "p.csv"), chain)
    assert plain.extra == {} and plain.ignored_note() is None


@pytest.mark.parametrize(
    "header, extra, message",
    [
        (HEADER.replace("length_mm", "lenght_mm"), "", r"s.csv:4: lenght_mm: unknown column; did you mean length_mm\?"),
        (HEADER.replace("q3_deg", "q3_dge"), "", r"s.csv:4: q3_dge: unit 'dge' is not read"),
        (HEADER.replace("q3_deg", "Q3_deg"), "", r"s.csv:4: Q3_deg: unknown column; did you mean q3_deg\?"),
        (HEADER.replace("q3_deg", "q3"), "", r"s.csv:4: q3: give the unit in the name \(q3_deg, q3_rad"),
        (HEADER + ",q7_deg", ",0", r"s.csv:4: has joint column q7 but robot 'irb120' has 6 joints"),
        (HEADER + ",length_m", ",0.8", r"two length columns"),
        (HEADER + ",q1_rad", ",0", r"joint 1 has two columns"),
        (HEADER + ",Length", ",0.8", r"s.csv:4: Length: give the unit in the name \(length_mm"),
        (HEADER + ",temp,temp", ",1,2", r"s.csv:4: temp: column appears twice"),
    ],
)
def test_columns_like_ours_must_be_valid(tmp_path, chain, header, extra, message):
    """A column named like one of calib-pin's (a joint, a length, a coordinate, pose,
    point_id: with another unit, no unit, other case or a typo of a missing one) is refused."""
    with pytest.raises(cp.DataError, match=message):
        cp.read_measurements(_write(tmp_path, META + header + "\n" + ROW + extra + "\n"), chain)


def _dialect(text: str, sep: str, decimal: str) -> str:
    """Rows of ``text`` written with separator ``sep`` and decimal mark ``decimal``."""
    return "\n".join(line if line.startswith("#") else line.replace(",", sep).replace(".", decimal)
                     for line in text.splitlines()) + "\n"


@pytest.mark.parametrize(
    "sep, decimal, meta",
    [
        (";", ",", "# anchor_mm: 600,5; 200; -100\n# tool_mm: 0 0 50,25\n# length_offset_mm: 1,5\n"),
        (";", ",", "# anchor_mm: 600,5, 200, -100\n# tool_mm: 0,0,50.25\n# length_offset_mm: 1,5\n"),
        (";", ".", "# anchor_mm: 600.5; 200; -100\n# tool_mm: 0, 0, 50.25\n# length_offset_mm: 1.5\n"),
        ("\t", ",", "# anchor_mm: 600,5; 200; -100\n# tool_mm: 0; 0; 50,25\n# length_offset_mm: 1,5\n"),
        ("\t", ".", "# anchor_mm: 600.5 200 -100\n# tool_mm: 0, 0, 50.25\n# length_offset_mm: 1.5\n"),
    ],
)
def test_other_csv_dialects_read_the_same_numbers(tmp_path, chain, sep, decimal, meta):
    """';' or tab separators with decimal commas or points give exactly the standard file's numbers."""
    rows = [ROW.replace("812.5", f"812.{k}5").replace("20,", f"20.{k}25,", 1) for k in range(5)]
    standard = cp.read_measurements(_write(tmp_path, "# robot: irb120\n# anchor_mm: 600.5, 200, -100\n"
                                           "# tool_mm: 0, 0, 50.25\n# length_offset_mm: 1.5\n"
                                           + EXTRA.replace(",comment", "") + "\n"
                                           + "\n".join(r + ",21.5,0.012,10:00" for r in rows) + "\n"), chain)
    other = cp.read_measurements(_write(tmp_path, "# robot: irb120\n" + meta + _dialect(
        EXTRA.replace(",comment", "") + "\n" + "\n".join(r + ",21.5,0.012,10:00" for r in rows), sep, decimal),
        "o.csv"), chain)
    np.testing.assert_array_equal(other.q, standard.q)
    np.testing.assert_array_equal(other.lengths, standard.lengths)
    np.testing.assert_array_equal(other.anchor, standard.anchor)
    np.testing.assert_array_equal(other.tool, standard.tool)
    assert other.length_offset == standard.length_offset
    np.testing.assert_array_equal(other.extra["sigma_mm"], standard.extra["sigma_mm"])
    assert other.extra["time"].tolist() == ["10:00"] * 5


@pytest.mark.parametrize(
    "text, message",
    [
        (META + HEADER.replace(",", ";") + "\n" + ROW.replace(",", ";").replace(".", ",") + "\n"
         + ROW.replace(",", ";") + "\n", r"s.csv:6: length_mm: decimal point in '812.5', but line 5 has a decimal comma"),
        (META + HEADER.replace(",", ";") + "\n" + ROW + "\n", r"s.csv:5: has 1 field separated by ';' as the header"),
        (META + HEADER.replace("q2_deg,", "q2_deg;") + "\n" + ROW + "\n", r"s.csv:4: the header mixes ',' and ';'"),
        ("# csv: decimal=,\n" + META + HEADER + "\n" + ROW + "\n", r"s.csv:1: csv: a decimal comma needs ';' or tab"),
        ("# csv: sep=|\n" + META + HEADER + "\n" + ROW + "\n", r"s.csv:1: csv: 'sep=|' is not"),
        (META.replace("600, 200, -100", "600,5 200,-100") + HEADER.replace(",", ";") + "\n"
         + ROW.replace(",", ";").replace(".", ",") + "\n", r"s.csv:2: anchor_mm: needs 3 numbers"),
    ],
)
def test_ambiguous_dialects_are_refused(tmp_path, chain, text, message):
    """Mixed decimal marks, mixed separators and a bad ``# csv:`` line are one error each."""
    with pytest.raises(cp.DataError, match=message):
        cp.read_measurements(_write(tmp_path, text), chain)


def test_every_numeric_metadata_value_follows_the_files_dialect(tmp_path, chain):
    """A 6-D pose set with decimal commas gives its noise_deg as it gives its noise_mm, and
    reads as the standard file does; a noise_deg that is no number names its line."""
    shipped = (Path(__file__).parent.parent / "robots" / "irb120_pose_example.csv").read_text()
    meta = [line.replace(".", ",") if line.startswith(("# noise_mm", "# noise_deg")) else line
            for line in shipped.splitlines() if line.startswith("#")]
    assert "# noise_deg: 0,01" in meta and "# noise_mm: 0,050000" in meta
    rows = [line for line in shipped.splitlines() if not line.startswith("#")]
    standard = cp.read_measurements(_write(tmp_path, shipped, "p.csv"), chain)
    other = cp.read_measurements(_write(tmp_path, "\n".join(meta) + "\n" + _dialect("\n".join(rows), ";", ","),
                                        "e.csv"), chain)
    assert other.notes["noise_deg"] == standard.notes["noise_deg"] == "0.01" and other.noise == standard.noise
    np.testing.assert_array_equal(other.values, standard.values)
    with pytest.raises(cp.DataError, match=r"e\.csv:4: noise_deg: '0,01x' is not a number"):
        cp.read_measurements(_write(tmp_path, "\n".join(meta).replace("0,01", "0,01x") + "\n"
                                    + _dialect("\n".join(rows), ";", ","), "e.csv"), chain)


def test_csv_line_overrides_the_detection(tmp_path, chain):
    """``# csv: sep=, decimal=.`` reads a header that holds a ';' inside a column name."""
    text = "# csv: sep=,\n" + META + HEADER + ",note;x\n" + ROW + ",a\n"
    data = cp.read_measurements(_write(tmp_path, text), chain)
    assert data.extra["note;x"].tolist() == ["a"]
    assert "csv" not in data.notes  # describes this file's text only: never written back


# --- reading a column at a time (issue 24): the row-by-row numbers, to the bit ----------


def _both_ways(path, chain, monkeypatch, **options):
    """The set read a column at a time (the fast path) and row by row (the reference)."""
    from calib_pin.measurements import csv_reader

    fast = cp.read_measurements(path, chain, **options)
    with monkeypatch.context() as m:
        m.setattr(csv_reader, "_rows_at_once", lambda *args, **kwargs: None)
        slow = cp.read_measurements(path, chain, **options)
    return fast, slow


def test_columns_at_once_give_the_row_by_row_numbers(tmp_path, chain, session, monkeypatch):
    """Degrees and mm, radians and m, a ';' file with decimal commas, positions, a pose list:
    the same angles and values to the bit as row by row."""
    data, _ = session
    cp.write_measurements(tmp_path / "set.csv", data)
    rng = np.random.default_rng(3)
    rad = rng.uniform(0.9 * np.asarray(chain.lower), 0.9 * np.asarray(chain.upper), (40, 6))
    deg = np.rad2deg(rad)
    rad_rows = "\n".join(",".join(repr(float(v)) for v in row) + f",{float(rng.uniform(0.5, 1.5))!r}" for row in rad)
    comma_rows = "\n".join(";".join(f"{v:.7f}".replace(".", ",") for v in row) + f";{rng.uniform(500, 900):.4f}"
                           .replace(".", ",") for row in deg)
    files = [tmp_path / "set.csv",
             _write(tmp_path, META + HEADER.replace("_deg", "_rad").replace("_mm", "_m") + "\n" + rad_rows + "\n", "r.csv"),
             _write(tmp_path, META.replace(", ", "; ") + HEADER.replace(",", ";") + "\n" + comma_rows + "\n", "c.csv")]
    for path in files:
        fast, slow = _both_ways(path, chain, monkeypatch)
        assert fast.q.tobytes() == slow.q.tobytes() and fast.values.tobytes() == slow.values.tobytes()
        assert fast.q.shape == slow.q.shape and fast.values.shape == slow.values.shape
    ur5 = cp.load_chain("ur5")
    positions = cp.simulate_positions(ur5, cp.parameter_model(ur5), 30, 1)[0]
    cp.write_measurements(tmp_path / "p.csv", positions)
    fast, slow = _both_ways(tmp_path / "p.csv", ur5, monkeypatch)
    assert fast.values.tobytes() == slow.values.tobytes() and fast.q.tobytes() == slow.q.tobytes()
    write_poses(tmp_path / "poses.csv", rad[:5], robot="irb120")
    fast, slow = _both_ways(tmp_path / "poses.csv", chain, monkeypatch, readings=False)
    assert np.isnan(fast.values).all() and fast.q.tobytes() == slow.q.tobytes()


def test_a_bad_row_is_named_as_row_by_row(tmp_path, chain, monkeypatch):
    """A field that is no number, a NaN, an angle beyond the limits, a negative length: the
    same one-line error naming its line and column as the row-by-row reading gives."""
    from calib_pin.measurements import csv_reader

    rows = [ROW] * 5
    for bad, message in ((ROW.replace("20", "2O"), ":8: q2_deg: '2O' is not a number"),
                         (ROW.replace("-30", "nan"), ":8: q3_deg: 'nan' is not a finite number"),
                         (ROW.replace("10,", "400,", 1), ":8: q1_deg: 400 is outside the limits"),
                         (ROW.replace("812.5", "-1"), ":8: length_mm: -1 is negative")):
        path = _write(tmp_path, META + HEADER + "\n" + "\n".join(rows[:3] + [bad] + rows[3:]) + "\n")
        with pytest.raises(cp.DataError) as fast:
            cp.read_measurements(path, chain)
        with monkeypatch.context() as m, pytest.raises(cp.DataError) as slow:
            m.setattr(csv_reader, "_rows_at_once", lambda *args, **kwargs: None)
            cp.read_measurements(path, chain)
        assert message in str(fast.value) and str(fast.value) == str(slow.value)


def test_a_pose_read_again_stays_on_one_side_of_a_split(tmp_path):
    """Without a pose column, rows of the same joint angles are one pose (read three times):
    a split keeps them together, so a held-out pose was never trained on."""
    rows = [line for line in (ROBOTS / "irb120_default.csv").read_text().splitlines()[7:47]]
    path = _write(tmp_path, META + HEADER + "\n" + "\n".join(r for r in rows for _ in range(3)) + "\n")
    calibration = cp.prepare("irb120", path)
    assert calibration.data.describe_rows() == "120 rows at 40 poses"
    train, test = calibration.split(0.2, 0)
    groups = calibration.data.groups
    assert len(test) == 24 and not set(groups[train]) & set(groups[test])
