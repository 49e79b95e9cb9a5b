"""What a command imports: a user's command pays only for what it uses.

Run in a fresh interpreter (a subprocess), since the test session has imported everything:
``simulate`` and ``calibrate --no-html`` work without the ``[hardware]`` extra (serial and
Modbus made unimportable), import neither matplotlib nor scipy.stats (filterpy's Kalman
filters come without it: :mod:`calib_pin.estimators.filterpy_import`) nor tqdm; and the
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
loaded = [m for m in ('matplotlib', 'scipy.stats', 'tqdm', 'serial', 'filterpy.stats.stats') if sys.modules.get(m)]
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
