"""The previous version's import paths and names: each imports, the ones that moved with a
DeprecationWarning naming the replacement at the caller's line; the real modules stay as they
are (calib_pin/__init__.py's module aliases, calib_pin/util/deprecation.py)."""

from __future__ import annotations

import importlib
import json
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import calib_pin

DATA = Path(__file__).parent / "data" / "previous_version"
#: 0.2.0's module paths and their public names (tests/data/previous_version/README.md).
PREVIOUS = json.loads((DATA / "public_api.json").read_text(encoding="utf-8"))

#: 0.2.0 names removed without a one-to-one replacement (CHANGELOG.md, Removed): what does their work now.
REMOVED = {
    "calib_pin.analysis.noise.NoiseEstimate": "calib_pin.calibration.noise.Noise",
    "calib_pin.analysis.noise.noise_from_data": "calib_pin.calibration.noise.estimate_noise",
    "calib_pin.analysis.noise.residual_noise": "calib_pin.calibration.noise.estimate_noise",
    "calib_pin.multiset.variance_components": "calib_pin.calibration.noise.estimate_noise",
    "calib_pin.multiset.fit_noise_parts": "calib_pin.calibration.noise.estimate_noise",
    "calib_pin.multiset.check_sets": "calib_pin.prepare",
    "calib_pin.multiset.value_unit": "calib_pin.sensors.base.MeasurementModel.value_unit",
    "calib_pin.sensors.contact.LABEL_COLUMNS": "calib_pin.measurements.schema.SCHEMAS",
    "calib_pin.studies.comparison.start_x": "calib_pin.Calibration.start_on",
    "calib_pin.validation.score_registered": "calib_pin.calibration.validation.register_session",
    "calib_pin.validation.same_rows": "calib_pin.calibration.repeats.repeat_error",
}


def _resolve(path: str) -> object:
    """The object at a dotted path: the longest importable module, then attributes."""
    parts = path.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj: object = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for name in parts[cut:]:
            obj = getattr(obj, name)
        return obj
    raise ImportError(path)


def default_env() -> dict[str, str]:
    """This environment with this calib_pin first on the path and Python's default warning filters."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONWARNINGS", "PYTHONDEVMODE")}
    return {**env, "PYTHONPATH": str(Path(calib_pin.__file__).parents[1])}


def _fresh_import(module: str) -> object:
    """``module`` imported anew (a deprecated path warns on its first import only)."""
    sys.modules.pop(module, None)
    __import__(module)  # called from here, as an import statement is
    return sys.modules[module]


@pytest.mark.parametrize("module", sorted(PREVIOUS))
def test_every_previous_path_and_name_imports(module):
    """Each path imports, and each public name is there: as it was, or with one DeprecationWarning
    that names its replacement (the same object); every other warning is an error."""
    deprecated = module.removeprefix("calib_pin.") in calib_pin._MOVED_MODULES
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        if deprecated:
            with pytest.warns(DeprecationWarning, match=rf"^{re.escape(module)} is deprecated: its contents are in "
                              r"calib_pin\.") as seen:
                loaded = _fresh_import(module)
            assert seen[0].filename == __file__  # the caller's line
        else:
            loaded = importlib.import_module(module)
        for name in PREVIOUS[module]:
            if f"{module}.{name}" in REMOVED:
                assert not hasattr(loaded, name)
                _resolve(REMOVED[f"{module}.{name}"])
                continue
            with warnings.catch_warnings(record=True) as seen:
                warnings.simplefilter("always")
                value = getattr(loaded, name)
            assert all(w.category is DeprecationWarning for w in seen), [str(w.message) for w in seen]
            if seen:
                message = str(seen[0].message)
                assert len(seen) == 1 and message.startswith(f"{module}.{name} is deprecated: "), message
                assert seen[0].filename == __file__
                use = re.match(r".* is deprecated: use (calib_pin[\w.]+)$", message)
                if use:
                    assert _resolve(use.group(1)) is value
                else:  # advice in words, naming a public name
                    assert re.search(r"calib_pin\.\w+", message.split(": ", 1)[1]), message


@pytest.mark.parametrize(("statement", "replacement"), [
    ("from calib_pin.pipeline import CalibrationSetup", "calib_pin.calibration.prepare.Calibration"),
    ("from calib_pin.stacked import StackedProblem", "calib_pin.calibration.problem.Problem"),
    ("from calib_pin.problem import CalibrationProblem", "calib_pin.sensors.problem.SetProblem"),
    ("from calib_pin.multiset import SetResult", "calib_pin.calibration.result.SetResult"),
    ("from calib_pin.multiset import StackedSetup", "calib_pin.calibration.prepare.Calibration"),
    ("from calib_pin.multiset import fit_sets", "calib_pin.prepare"),
    ("from calib_pin.validation import as_test_set", "calib_pin.TestSet"),
    ("from calib_pin.sensors.pose import simulate_poses", "calib_pin.simulation.pose.simulate_poses"),
    ("from calib_pin.sensors.contact import simulate_contacts", "calib_pin.simulation.contact.simulate_contacts"),
])
def test_a_moved_name_imports_from_its_old_path_with_a_warning(statement, replacement):
    """The names a 0.2.0 user imports from the old paths, the first of them that moved elsewhere."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the module's own warning, already tested
        importlib.import_module(statement.split()[1])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # pytest.warns passes on any other warning: an error here
        with pytest.warns(DeprecationWarning, match=re.escape(replacement)):
            exec(statement, {})


def test_an_alias_leaves_the_real_module_as_it_is():
    """``calib_pin.pipeline`` is a module of its own: the module it re-exports keeps its name and spec."""
    with pytest.warns(DeprecationWarning):
        alias = _fresh_import("calib_pin.pipeline")
    real = importlib.import_module("calib_pin.calibration.solve")
    assert alias is not real and alias.__name__ == "calib_pin.pipeline"
    assert real.__name__ == real.__spec__.name == "calib_pin.calibration.solve"
    assert alias.solve is real.solve and alias.calibrate is real.calibrate


def test_the_module_warning_shows_under_the_default_filters(tmp_path):
    """A script that imports an old path is told so, at its own line, without -W."""
    script = tmp_path / "old.py"
    script.write_text("from calib_pin.pipeline import calibrate\nfrom calib_pin.sensors.pose import simulate_poses\n")
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, check=True, env=default_env())
    assert f"{script}:1: DeprecationWarning: calib_pin.pipeline is deprecated" in done.stderr
    assert f"{script}:2: DeprecationWarning: calib_pin.sensors.pose.simulate_poses is deprecated" in done.stderr


def test_a_deprecated_keyword_warns_at_the_callers_line_under_the_default_filters(tmp_path):
    """prepare's, calibrate's and compare's deprecated keywords are reported at the script's
    own line (not ``sys:1``), so Python's default filters show them, however deep the check."""
    script = tmp_path / "loose.py"
    script.write_text("import calib_pin as cp\n"
                      "cp.prepare('irb120', tool_mm=(0, 0, 100))\n"
                      "cp.prepare('irb120', compliance='joint_2', payload_kg=1.0)\n"
                      "cp.calibrate('irb120', method='lm', tool_mm=(0, 0, 100))\n"
                      "cp.compare('irb120', methods=['lm'], trials=1, estimate=('anchor',))\n")
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, check=True, env=default_env())
    for line, what in ((2, "tool_mm"), (3, "payload_kg"), (4, "tool_mm"), (5, "estimate")):
        assert f"{script}:{line}: DeprecationWarning: {what} as separate keyword(s) are deprecated" in done.stderr
