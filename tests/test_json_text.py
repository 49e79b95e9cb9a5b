"""dumps_readable: the same JSON value as json.dumps, the structure indented, plain lists on one line."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from calib_pin.report.json_text import dumps_readable

DOC = {
    "robot": "irb120",
    "rows": list(range(1000)),
    "after_mm": [0.1 * k for k in range(1000)],
    "split": ["train", "test"] * 3,
    "flags": [True, False, None],
    "points_mm": [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]],
    "empty": [],
    "nested": [{"name": "a", "xyz": (1, 2, 3)}, {"name": "b", "xyz": (4, 5, 6)}],
    "looks_like_a_placeholder": "@0123456789abcdef:0@",
    "numpy_float": np.float64(0.25),
    "unicode": "Δθ ± 1 µm",
}


def test_it_parses_back_to_what_json_dumps_gives():
    assert json.loads(dumps_readable(DOC)) == json.loads(json.dumps(DOC))


def test_plain_lists_on_one_line_the_structure_indented():
    text = dumps_readable(DOC)
    lines = text.splitlines()
    assert len(lines) < 30  # json.dumps(indent=2) gives over 2 000 lines here
    assert '  "rows": [0, 1, 2, 3, ' in text and '  "split": ["train", "test", "train", ' in text
    assert '    [1.0, 2.0, 3.0],' in lines and '      "xyz": [1, 2, 3]' in lines
    assert '  "empty": [],' in lines and '  "flags": [true, false, null],' in lines
    assert lines[0] == "{" and lines[-1] == "}"


def test_non_finite_numbers_are_refused_as_json_dumps_refuses_them():
    with pytest.raises(ValueError):
        dumps_readable({"a": [1.0, math.nan]})
    with pytest.raises(ValueError):
        dumps_readable({"a": math.inf})
    assert json.loads(dumps_readable({"a": [math.inf]}, allow_nan=True))["a"] == [math.inf]


def test_a_value_json_cannot_hold_is_a_type_error():
    with pytest.raises(TypeError):
        dumps_readable({"a": [object()]})
