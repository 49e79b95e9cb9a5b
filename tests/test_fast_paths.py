"""What a command imports: a user's command pays only for what it uses.

Run in a fresh interpreter (a subprocess), since the test session has imported everything:
``simulate`` and ``calibrate --no-html`` work without the ``[hardware]`` extra (serial and
Modbus made unimportable), import neither matplotlib nor scipy.stats nor scipy.ndimage
(filterpy's Kalman filters come without them: :mod:`calib_pin.estimators.filterpy_import`) nor tqdm; and the
calibration they give is the one the test session computes in process.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

SCRIPT = """
import json, sys
sys.modules['serial'] = None; sys.modules['minimalmodbus'] = None  # no [hardware] extra
from calib_pin.cli import command
codes = [command('simulate')(['irb120', '--poses', '30', '--out', 's', '--force']),
         command('calibrate')(['irb120', '--data', 's', '--method', 'ekf-qibas', '--no-html', '--out', 'o'])]
loaded = [m for m in ('matplotlib', 'scipy.stats', 'scipy.ndimage', 'tqdm', 'serial', 'filterpy.stats.stats',
                      'filterpy.discrete_bayes.discrete_bayes') if sys.modules.get(m)]
print(json.dumps({'codes': codes, 'loaded': loaded}))
"""


def test_simulate_and_calibrate_import_only_what_they_use(tmp_path):
    run = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout.strip().splitlines()[-1])
    assert out == {"codes": [0, 0], "loaded": []}, run.stderr
    import calib_pin as cp

    again = cp.calibrate("irb120", str(tmp_path / "s"), method="ekf-qibas", seed=0)
    report = json.loads((tmp_path / "o" / "report.json").read_text())
    assert report["test"]["after"]["rmse_mm"] == again.metrics["test"]["after"].rmse_mm
    assert report["test"]["after"]["rmse_mm"] < report["test"]["before"]["rmse_mm"] / 5


def test_deferred_filterpy_stats_loads_on_use():
    """The stand-in filterpy.stats gives the real logpdf (and every other name) when used."""
    import filterpy.stats as stats

    from calib_pin.estimators import filterpy_import

    assert filterpy_import.kalman().ExtendedKalmanFilter.__name__ == "ExtendedKalmanFilter"
    np.testing.assert_allclose(stats.logpdf([1.0], [0.0], [[1.0]]), -0.5 * np.log(2 * np.pi) - 0.5)
    assert callable(stats.multivariate_gaussian)


def test_deferred_filterpy_discrete_bayes_loads_on_use():
    """The stand-in filterpy.discrete_bayes gives the real functions when used."""
    from calib_pin.estimators import filterpy_import

    filterpy_import.kalman()
    import filterpy.discrete_bayes as discrete_bayes

    np.testing.assert_allclose(discrete_bayes.normalize(np.array([1.0, 3.0])), [0.25, 0.75])
    assert callable(discrete_bayes.predict)


LM_SCRIPT = """
import json, sys
from calib_pin.cli import command
calibrate = command('calibrate')  # as scripts/calibrate.py: the thread limit before numpy loads
from calib_pin.sensors import position
fits = []
real = position.fit_device
position.fit_device = lambda *a, **k: fits.append(len(a[2])) or real(*a, **k)
code = calibrate(['ur5', '--data', 'u.csv', '--method', 'lm', '--no-html', '--test-fraction', '0',
                             '--out', 'o'])
loaded = [m for m in ('yaml', 'calib_pin.export.yaml', 'calib_pin.export.dh', 'threadpoolctl', 'matplotlib',
                      'filterpy', 'scipy.stats', 'tqdm', 'calib_pin.report.html') if m in sys.modules]
print(json.dumps({'code': code, 'loaded': loaded, 'fits': fits}))
"""


def test_a_no_html_lm_run_imports_only_what_it_uses(tmp_path, monkeypatch):
    """``calibrate --no-html --method lm`` (issue 24, the whole process): no PyYAML nor the
    DH table's module (only the URDF is exported), no threadpoolctl (the thread limit is set
    in the environment before any BLAS loads), no matplotlib, filterpy or the HTML report;
    the device frame is fitted once when every row trains; and its outputs are the ones the
    library writes in this process."""
    import calib_pin as cp

    ur5 = cp.load_chain("ur5")
    data = cp.simulate_positions(ur5, cp.parameter_model(ur5), 40, 0)[0]
    cp.write_measurements(tmp_path / "u.csv", data)
    run = subprocess.run([sys.executable, "-c", LM_SCRIPT], capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout.strip().splitlines()[-1])
    assert out == {"code": 0, "loaded": [], "fits": [len(data)]}, run.stderr
    monkeypatch.chdir(tmp_path)  # the files name the data as the command was given it
    result = cp.calibrate("ur5", "u.csv", method="lm", test_fraction=0)
    written = cp.write_outputs(result, tmp_path / "lib", html=False, inputs={"--data": "u.csv"})
    for name in ("ur5_calibrated.urdf", "ur5_calibration.json"):
        assert (tmp_path / "o" / name).read_bytes() == (tmp_path / "lib" / name).read_bytes()
    assert json.loads((tmp_path / "o" / "report.json").read_text())["train"] == written.report["train"]


def test_version_and_export_writers_load_on_first_use():
    """``calib_pin.__version__`` and the export writers are read when first asked for, and
    are what the distribution and the writer modules give."""
    code = ("import sys, calib_pin, calib_pin.export as e; before = 'importlib.metadata' in sys.modules; "
            "from importlib.metadata import version; from calib_pin.export.yaml import write_joint_origins_yaml; "
            "print(before, calib_pin.__version__ == version('calib-pin'), "
            "e.write_joint_origins_yaml is write_joint_origins_yaml, 'write_dh_table' in dir(e) or "
            "callable(e.write_dh_table))")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["False", "True", "True", "True"]
