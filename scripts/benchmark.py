#!/usr/bin/env python3
"""Time calib-pin's estimators on a seeded simulated IRB120 session.

    python scripts/benchmark.py [--repeats 5] [--methods ekf-qibas,lm] [--seed 0]

For each method (default: all nine, M1..M9): median (and min/max) wall time of the
estimate on 96 training poses over repeated runs, iterations, evaluations of the
training residual, peak Python memory of one run (tracemalloc, measured in a separate
untimed run), and the error predicting 1000 fresh poses against the noise-free truth.
Targets on a 2-core machine: EKF-QIBAS <= 0.5 s, LM <= 30 ms. The machine may be
shared and noisy: compare medians and ratios, not single runs.
"""

from __future__ import annotations

import os
import platform
import statistics
import tracemalloc

import numpy as np

import calib_pin as cp
from calib_pin.cli import OneLineParser
from calib_pin.errors import CableModel


def main() -> None:
    parser = OneLineParser(prog="benchmark.py", description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--methods", default=",".join(cp.ESTIMATORS))
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    methods = args.methods.split(",")
    for m in methods:
        try:
            cp.get_estimator(m)
        except cp.CalibPinError as e:
            parser.error(str(e))
    if args.repeats < 1:
        parser.error("--repeats must be at least 1")

    chain = cp.load_chain("irb120")
    params = cp.parameter_model(chain)
    data, truth = cp.simulate(chain, params, 120, seed=args.seed, noise_mm=0.05)
    train, _ = cp.split_rows(len(data), 0.2, args.seed)
    problem = cp.CalibrationProblem(CableModel(chain, params, truth.sensor), data.q, data.lengths).subset(train)
    fresh = cp.random_poses(chain, 1000, np.random.default_rng(args.seed + 1))
    true_fresh = CableModel(chain, params, truth.sensor).predict(truth.x, fresh)
    x0 = np.zeros(len(params.names))

    print(f"calib-pin {cp.__version__} benchmark: IRB120, {len(train)} training poses, "
          f"sigma 0.05 mm, seed {args.seed}, {args.repeats} repeats")
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}")
    print(f"{'method':12s}{'median s':>10s}{'min s':>9s}{'max s':>9s}{'iters':>7s}"
          f"{'evals':>8s}{'peak MiB':>10s}{'fresh RMSE mm':>15s}")
    medians = {}
    for name in methods:
        times, result = [], None
        for _ in range(args.repeats):
            result = cp.run_estimator(name, problem, x0, seed=args.seed)
            times.append(result.time_s)
        tracemalloc.start()
        cp.run_estimator(name, problem, x0, seed=args.seed)
        peak = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
        model = CableModel(chain, params, truth.sensor)
        fresh_rmse = np.sqrt(np.mean((result.predict(model, fresh) - true_fresh) ** 2)) * 1e3
        medians[name] = statistics.median(times)
        print(f"{name:12s}{medians[name]:10.4f}{min(times):9.4f}{max(times):9.4f}"
              f"{result.iterations:7d}{result.nfev:8.0f}{peak:10.2f}{fresh_rmse:15.4f}")
    if "lm" in medians:
        ratios = ", ".join(f"{m} {t / medians['lm']:.1f}x" for m, t in medians.items() if m != "lm")
        print(f"median time relative to LM: {ratios}")


if __name__ == "__main__":
    main()
