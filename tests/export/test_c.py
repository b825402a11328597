"""The C99 header compiles strictly and reproduces ``compensate --mode causal`` for every model kind."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest

from gyrocomp.config import apply_overrides, load_config
from gyrocomp.export import ExportOptions, export_model
from gyrocomp.export.c import recursive_rate
from gyrocomp.pipeline import rate as rate_estimator
from gyrocomp.pipeline.compensate import load_model
from gyrocomp.pipeline.settings import RateSettings
from gyrocomp.pipeline.train import train_direct

CC = shutil.which("cc")
FLAGS = ["-std=c99", "-Wall", "-Werror", "-pedantic"]

KINDS = {
    "polynomial": ("polynomial", []),
    "elm": ("elm", ["model.max_samples=500", "model.drift.ridge=1e-6"]),
    "elm_unregularised": ("elm", ["model.max_samples=500"]),
    "nsga2elm": ("elm", ["model.max_samples=300", 'model.drift={learner="nsga2elm", pop_size=8, n_gen=2, pick="min_rmse", ridge=1e-6}']),
    "anfis": ("elm", ["model.max_samples=300", 'model.drift={learner="anfis", n_mfs=[3, 3], epochs=5}']),
    "anfis_gaussian": ("elm", ["model.max_samples=300", 'model.drift={learner="anfis", n_mfs=[2, 2], mf="gauss", epochs=5}']),
    "bp": ("bp", ["model.max_samples=300", "model.drift.max_iter=100"]),
    "elm_sin": ("elm", ["model.max_samples=300", 'model.drift={learner="elm", activation="sin", n_hidden=12, ridge=1e-6}']),
}

PROGRAM = r"""
#define GYROCOMP_TEST_VECTORS
#include <stdio.h>
#include "model.h"
int main(void) {
    gyrocomp_state s;
    long i;
    double worst = 0, worst_rel = 0;
    gyrocomp_init(&s);
    for (i = 0; i < GYROCOMP_N_VECTORS; ++i) {
        double y = (double)gyrocomp_update(&s, (gyrocomp_real)gyrocomp_vector_temperature_c[i], (gyrocomp_real)gyrocomp_vector_rate_dps[i]);
        double e = gyrocomp_vector_compensated_dps[i];
        double scale = fabs(e) > fabs(gyrocomp_vector_drift_dps[i]) ? fabs(e) : fabs(gyrocomp_vector_drift_dps[i]);
        double err = fabs(y - e);
        if (err > worst) worst = err;
        if (scale > 0 && err / scale > worst_rel) worst_rel = err / scale;
    }
    printf("%.3e %.3e\n", worst, worst_rel);
    return 0;
}
"""


@pytest.fixture(scope="module")
def models(sample_train):
    out = {}
    for key, (config, overrides) in KINDS.items():
        out[key] = load_model(train_direct(sample_train, apply_overrides(load_config(config), overrides), source=key, seed=0))
    return out


def _build_and_run(tmp_path, header: str, real: str) -> tuple[float, float]:
    (tmp_path / "model.h").write_text(header)
    (tmp_path / "main.c").write_text(PROGRAM)
    exe = tmp_path / f"check_{real}"
    subprocess.run([CC, *FLAGS, f"-DGYROCOMP_REAL={real}", "-o", str(exe), str(tmp_path / "main.c"), "-lm"], check=True, capture_output=True, text=True)
    worst, worst_rel = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split()
    return float(worst), float(worst_rel)


@pytest.mark.skipif(CC is None, reason="no C compiler")
@pytest.mark.parametrize("key", list(KINDS))
def test_header_reproduces_the_test_vectors(key, models, sample_test, tmp_path):
    """1e-9 deg/s in double, 1e-4 relative in float, on the held-out run (first 2048 s) and on the synthetic sweep.

    An ELM solved without regularisation (ridge = 0, the paper's
    Moore-Penrose solution) sums hidden outputs with weights |beta| ~ 1e5 to
    a drift of 0.1 deg/s: its own rounding is eps * sum |beta_h g_h|, which
    is the bound it is held to (measured 3e-9 deg/s double, 6e-4 float).
    """
    learner = models[key].learners["drift"][0]
    learner = getattr(learner, "estimator_", learner)
    spread = float(np.sum(np.abs(learner.beta_)) * models[key].learners["drift"][4]) if hasattr(learner, "beta_") else 0.0
    for vectors in (sample_test, None):
        header, summary = export_model(models[key], "c", ExportOptions(vectors=vectors, n_vectors=2048))
        assert summary["n_vectors"] == 2048
        worst, _ = _build_and_run(tmp_path, header, "double")
        assert worst < max(1e-9, 64 * np.finfo(np.float64).eps * spread), f"{key}: {worst:.3g} deg/s"
        worst_float, worst_rel = _build_and_run(tmp_path, header, "float")
        assert worst_rel < 1e-4 or worst_float < 64 * np.finfo(np.float32).eps * spread, f"{key} float: {worst_rel:.3g}"


def test_the_sweep_vectors_leave_both_ranges(models):
    """The default vectors exercise clamping: temperature and dT/dt both go beyond their training ranges."""
    from gyrocomp.export import reference_vectors

    model = models["polynomial"]
    v = reference_vectors(model)
    (t_lo, t_hi), (r_lo, r_hi) = model.temperature_range_c, model.rate_range_c_per_s
    assert v["temperature_c"].min() < t_lo and v["temperature_c"].max() > t_hi
    assert v["temperature_rate_c_per_s"].min() < r_lo and v["temperature_rate_c_per_s"].max() > r_hi


@pytest.mark.parametrize("fs_hz, polyorder", [(1.0, 1), (0.2, 1), (100.0, 1), (10.0, 2)])
def test_moment_recursion_equals_the_fir(fs_hz, polyorder):
    """The header's O(1) recursion against the stored FIR (np.convolve) and, for a local line, exact integer arithmetic.

    The readings are quantised to 1/16 degC, so the integer reference is
    exact; np.convolve's own rounding reaches 1e-11 of the largest rate over
    6001 taps, the recursion (re-summed every window) stays within 1e-12.
    """
    rng = np.random.default_rng(7)
    temperature = np.round((20 + np.cumsum(rng.normal(0, 0.02, 20000))) * 16) / 16
    settings = RateSettings(window_s=60.0, polyorder=polyorder)
    fir = rate_estimator.temperature_rate(temperature, fs_hz, settings, causal=True)
    window = rate_estimator.window_samples(settings, fs_hz)
    recursive = recursive_rate(temperature, window, polyorder, fs_hz)
    window_fir_tolerance = 1e-12 if window <= 61 else 1e-10
    assert np.max(np.abs(recursive - fir)) <= (window_fir_tolerance if polyorder == 1 else 1e-9) * np.max(np.abs(fir))
    if polyorder == 1:
        steps = np.round(np.concatenate([np.full(window - 1, temperature[0]), temperature]) * 16).astype(np.int64)
        u = np.arange(window) - (window - 1) // 2
        exact = np.convolve(steps, u[::-1], mode="valid") / 16 / (window * (window**2 - 1) // 12) * fs_hz
        assert np.max(np.abs(recursive - exact)) <= 1e-12 * np.max(np.abs(exact))


def test_per_sample_work_does_not_depend_on_the_window(models):
    """The update step is the same code for a 61-tap and a 6001-tap FIR: only the ring's size changes."""
    import copy
    import re

    from gyrocomp.export.c import c_header
    from gyrocomp.export.plain import plain_model

    plain = plain_model(models["polynomial"], centred=True)
    wide = copy.deepcopy(plain)
    wide["rate_estimator"]["window_samples"] = 6001
    wide["fs_hz"] = 100.0
    wide["rate_estimator"]["causal_coefficients"] = rate_estimator.causal_coefficients(RateSettings(window_s=60.0), 100.0).tolist()

    def update(text):
        body = text[text.index("static inline gyrocomp_real gyrocomp_update(") :]
        return re.sub(r"[-0-9.e+]+", "#", body[: body.index("\n}\n")])

    assert update(c_header(plain)) == update(c_header(wide))
    assert "< GYROCOMP_WINDOW" not in update(c_header(plain))  # the window only wraps indices; no loop runs over it


@pytest.mark.skipif(CC is None, reason="no C compiler")
def test_a_three_axis_header_has_one_block_per_axis(models, tmp_path):
    """Three axes in one header: names prefixed per axis, each reproducing its own vectors."""
    header, summary = export_model({"gx": models["polynomial"], "gy": models["elm"], "gz": models["anfis"]}, "c")
    assert summary["prefixes"] == 3
    program = PROGRAM.replace('#include "model.h"', '#include "model.h"').replace("gyrocomp_", "gyrocomp_gy_").replace("GYROCOMP_N_VECTORS", "GYROCOMP_GY_N_VECTORS")
    (tmp_path / "model.h").write_text(header)
    (tmp_path / "main.c").write_text(program)
    exe = tmp_path / "check"
    subprocess.run([CC, *FLAGS, "-o", str(exe), str(tmp_path / "main.c"), "-lm"], check=True, capture_output=True, text=True)
    worst, _ = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split()
    assert float(worst) < 1e-9
