"""Benchmark the learners of `gyrocomp.models` against scikit-learn's MLPRegressor.

1. ANFIS, 16 rules (4 x 4 gbell MFs on 2 inputs), 10^4 samples, 100 epochs
   of Jang's hybrid rule (one least-squares solve of a 10^4 x 48 design
   and one analytic premise gradient per epoch).
2. ELM, 50 sigmoid nodes, 10^5 samples (one 10^5 x 50 least-squares solve).
3. The reference: scikit-learn's MLPRegressor (the BP comparator, 10 tanh
   nodes, L-BFGS, as BPNetwork) on the same data, for ratios.
4. NSGA2ELM with the paper's settings (40 x 15) on 2000 samples.

Best of 3 (1 for the long ones), the BLAS limited to one thread (these solves are
small; two spinning threads only cost time on a shared machine). Timings are noisy
while other jobs share the CPU: compare the ratios measured in one run.
Writes benchmarks/results/models.json.
"""

import time
from pathlib import Path

import provenance

import numpy as np
from sklearn.neural_network import MLPRegressor
from threadpoolctl import threadpool_limits

from gyrocomp.models import ANFIS, ELM, NSGA2ELM

HERE = Path(__file__).resolve().parent


def _best(fn, repeat=3):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def _drift_data(n, seed=0):
    rng = np.random.default_rng(seed)
    T = rng.uniform(-40, 60, n)
    rate = rng.uniform(-0.05, 0.05, n)
    y = 0.02 * (T - 25) + 4e-4 * (T - 25) ** 2 - 1e-5 * (T - 25) ** 3 + 3.0 * rate + rng.normal(0, 0.02, n)
    return np.column_stack([(T - 10) / 50, rate / 0.05]), y


def main():
    results = {"note": "single BLAS thread; machine shared with other jobs: compare ratios"}
    X4, y4 = _drift_data(10_000)
    anfis_s = _best(lambda: ANFIS(n_mfs=4, epochs=100).fit(X4, y4), repeat=1)
    mlp4_s = _best(lambda: MLPRegressor(hidden_layer_sizes=(10,), activation="tanh", solver="lbfgs", max_iter=1000,
                                        random_state=0).fit(X4, y4), repeat=1)
    print(f"ANFIS 16 rules, 1e4 samples, 100 epochs: {anfis_s:.2f} s ({anfis_s * 10:.1f} ms/epoch); "
          f"MLPRegressor(10) same data: {mlp4_s:.2f} s; ratio ANFIS/MLP {anfis_s / mlp4_s:.2f}")
    X5, y5 = _drift_data(100_000, seed=1)
    elm_s = _best(lambda: ELM(n_hidden=50, seed=0).fit(X5, y5))
    mlp5_s = _best(lambda: MLPRegressor(hidden_layer_sizes=(10,), activation="tanh", solver="lbfgs", max_iter=1000,
                                        random_state=0).fit(X5, y5), repeat=1)
    print(f"ELM 50 hidden, 1e5 samples: {elm_s:.3f} s; MLPRegressor(10) same data: {mlp5_s:.2f} s; "
          f"speed-up x{mlp5_s / elm_s:.0f}")
    X2, y2 = _drift_data(2000, seed=2)
    nsga_s = _best(lambda: NSGA2ELM(seed=0).fit(X2, y2), repeat=1)
    print(f"NSGA2ELM 40 x 15 (about 600 ELM fits), 2000 samples: {nsga_s:.2f} s")
    results.update(
        anfis={"rules": 16, "n_samples": 10_000, "epochs": 100, "seconds": anfis_s},
        mlp_on_anfis_data={"hidden": [10], "n_samples": 10_000, "seconds": mlp4_s},
        anfis_over_mlp=anfis_s / mlp4_s,
        elm={"n_hidden": 50, "n_samples": 100_000, "seconds": elm_s},
        mlp_on_elm_data={"hidden": [10], "n_samples": 100_000, "seconds": mlp5_s},
        mlp_over_elm=mlp5_s / elm_s,
        nsga2elm={"pop_size": 40, "n_gen": 15, "n_samples": 2000, "seconds": nsga_s},
    )
    provenance.write("models", results)


if __name__ == "__main__":
    with threadpool_limits(limits=1, user_api="blas"):
        main()
