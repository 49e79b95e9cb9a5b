"""One measurement given to a calibration twice (calib_pin.calibration.repeats): the same
file again by any name, rows repeated in another set or in the validation session, each
refused naming both files and the rows; repeats inside one file, and a pose list read
again with new readings, accepted."""

from __future__ import annotations

import dataclasses
import os

import numpy as np
import pytest

import calib_pin as cp


@pytest.fixture(scope="module")
def cable(chain, params):
    data, _ = cp.simulate(chain, params, 40, seed=11)
    return data


@pytest.fixture
def files(cable, tmp_path):
    """The cable set written as a.csv; its lines are 8..47."""
    path = tmp_path / "a.csv"
    cp.write_measurements(path, cable)
    return tmp_path, cp.read_measurements(path)


def test_a_copy_or_a_hard_link_of_a_training_file_is_the_same_file(files):
    """A copy (identical contents) and a hard link (one inode) under other names are refused
    as the same file, naming both (they were fitted twice, exit 0)."""
    folder, a = files
    (folder / "copy.csv").write_bytes((folder / "a.csv").read_bytes())
    os.link(folder / "a.csv", folder / "link.csv")
    with pytest.raises(cp.DataError, match=r"copy\.csv: it is a\.csv again \(a file of identical contents\): a row is "
                                           "fitted once"):
        cp.prepare("irb120", [folder / "a.csv", folder / "copy.csv"])
    with pytest.raises(cp.DataError, match=r"link\.csv: it is a\.csv again \(the same file\)"):
        cp.prepare("irb120", [folder / "a.csv", folder / "link.csv"])
    with pytest.raises(cp.DataError, match=r"link\.csv: holds the training set's own rows: it is a\.csv again"):
        cp.calibrate("irb120", folder / "a.csv", method="lm", test_data=folder / "link.csv")


def test_a_second_set_holding_part_of_the_first_ones_rows_is_refused_naming_the_rows(files):
    """Rows 11-20 of a.csv pasted into another session: named by file line in both files;
    the same rows in the validation session too (they were scored as held out)."""
    folder, a = files
    other, _ = cp.simulate(cp.load_chain("irb120"), cp.parameter_model(cp.load_chain("irb120")), 30, seed=12)
    mixed = dataclasses.replace(other, q=np.vstack([a.q[10:20], other.q]),
                                values=np.concatenate([a.values[10:20], other.values]), lines=None)
    cp.write_measurements(folder / "b.csv", mixed)
    with pytest.raises(cp.DataError, match=r"b\.csv: its lines 8-17 repeat a\.csv's lines 18-27 \(the same joint "
                                           r"angles and readings, to the files' precision\)"):
        cp.prepare("irb120", [folder / "a.csv", folder / "b.csv"])
    with pytest.raises(cp.DataError, match=r"b\.csv: holds the training set's own rows: its lines 8-17 repeat a\.csv's "
                                           "lines 18-27"):
        cp.calibrate("irb120", folder / "a.csv", method="lm", test_data=folder / "b.csv")


def test_sets_in_memory_are_named_by_label(cable):
    """One set given twice in memory under two labels: refused, naming the sets."""
    first = dataclasses.replace(cable, source="")
    with pytest.raises(cp.DataError, match=r"set two: its rows 1-40 repeat set one's rows 1-40"):
        cp.prepare("irb120", [cp.FitSet(first, label="one"), cp.FitSet(first, label="two")])


def test_repeats_inside_one_file_and_a_pose_list_read_again_are_accepted(files, chain):
    """Readings repeated at one pose inside one file (a repeatability study) are one set;
    a second session at the same poses with new readings shares joint angles, not rows,
    even where a reading agrees to the file's last digit by chance; subsets of one file
    that share no line are two sets."""
    from calib_pin.calibration.repeats import repeats

    folder, a = files
    repeated = dataclasses.replace(a, q=np.vstack([a.q, a.q[:5]]), values=np.concatenate([a.values, a.values[:5]]),
                                   lines=None, source="")
    cp.prepare("irb120", repeated)
    again = a.values + 0.01e-3 * np.sign(np.arange(len(a)) % 2 - 0.5)
    again[3] = a.values[3]  # one reading agrees by chance
    cp.prepare("irb120", [a, dataclasses.replace(a, values=again, source="")])
    found = repeats(dataclasses.replace(a, values=again), a)
    assert found.a_rows.tolist() == [3] and found.remeasured == len(a) - 1 and not found.refused(len(a), len(a))
    cp.prepare("irb120", [cp.FitSet(a.subset(np.arange(20)), label="first"),
                          cp.FitSet(a.subset(np.arange(20, 40)), label="second")])


def test_rows_agree_to_the_coarser_files_precision(cable):
    """A copy written with 3 decimals where the original has 6 still repeats it: each column
    is compared to the coarser file's last digit (mm and deg, or m and rad, whichever unit
    its numbers are round in)."""
    from calib_pin.calibration.repeats import precision, repeat_error, repeats

    rounded = dataclasses.replace(cable, q=np.deg2rad(np.round(np.rad2deg(cable.q), 3)),
                                  values=np.round(cable.values * 1e3, 3) * 1e-3)
    fine = dataclasses.replace(rounded, q=rounded.q + np.deg2rad(2e-4), values=rounded.values + 2e-7)
    np.testing.assert_allclose(precision(np.rad2deg(rounded.q) * np.pi / 180, (np.rad2deg(1.0), 1.0)),
                               np.deg2rad(1e-3), rtol=1e-9)
    assert len(repeats(fine, rounded).a_rows) == len(cable)
    assert repeat_error(rounded, "a", fine, "b").startswith("its rows 1-40 repeat set a's rows 1-40")
    moved = dataclasses.replace(fine, values=fine.values + 2e-6)  # 2 um: past the 1 um digit
    assert repeat_error(rounded, "a", moved, "b") is None
