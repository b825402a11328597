"""The selected model's 1-sigma uncertainties against the spread of the estimates over independent draws.

Each draw is built here from numpy and the independent benchmark
generator's play operator (``benchmarks/independent_gen.py``, no gyrocomp
code): a 4 h oven run at 1 Hz with a cubic bias, a 10 degC play of
0.005 deg/s and white noise. The model is fitted at the true form (the
width re-estimated on its grid and refined), and the stated sigmas must
match the scatter of the estimates about the truth: the standard deviation
of ``(estimate - truth) / sigma`` over the draws within [0.6, 1.6].
"""

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gyrocomp.diagnose import DiagnoseSettings, problems
from gyrocomp.diagnose.select import extend, fit_baseline
from gyrocomp.diagnose.uncertainty import uncertainties
from gyrocomp.recordings import recording_from_frame

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from independent_gen import play_operator  # noqa: E402

KNOTS = [(0, 25), (1800, 25), (3000, 65), (6000, 65), (8400, 5), (11400, 5), (13200, 35), (14400, 35)]


def _draw(seed, amplitude=0.005, width=10.0, sigma=0.01):
    rng = np.random.default_rng(seed)
    kt, kc = np.array(KNOTS, dtype=float).T
    t = np.arange(kt[-1])
    temperature = np.interp(t, kt, kc)
    rate = 0.02 + 2e-3 * (temperature - 25.0) + amplitude * play_operator(temperature, width, 0.0) + rng.normal(0.0, sigma, t.size)
    rec = recording_from_frame(pd.DataFrame({"time": t, "rate": rate, "temperature": temperature + rng.normal(0.0, 0.01, t.size)}), name="oven")
    fit_p, _, _ = problems(rec, [], DiagnoseSettings())
    model = extend(fit_p, fit_baseline(fit_p), "hysteresis")
    return fit_p, model


def test_stated_sigmas_match_the_scatter_of_the_estimates():
    z = {"amplitude_dps": [], "deadband_c": []}
    truth = {"amplitude_dps": 0.005, "deadband_c": 10.0}
    for seed in range(40, 64):
        fit_p, model = _draw(seed)
        assert model.spec["hysteresis"]["operator"] == "play"
        sig = uncertainties(fit_p, model)["hysteresis"]
        coef = dict(zip(model.names, model.beta))
        est = {"amplitude_dps": coef["hysteresis"], "deadband_c": model.spec["hysteresis"]["deadband_c"]}
        for k in z:
            assert sig[k] is not None and sig[k] > 0.0
            z[k].append((est[k] - truth[k]) / sig[k])
    for k, v in z.items():
        assert 0.6 < np.std(v) < 1.6, (k, np.round(v, 2))
        assert abs(np.mean(v)) < 0.8, (k, np.round(v, 2))



def _two_decays(seed, fast=100.0, slow=2000.0, amplitude=0.02, sigma=0.01):
    """The oven run with a warm-up of two time constants (``amplitude`` each) in place of the play."""
    rng = np.random.default_rng(seed)
    kt, kc = np.array(KNOTS, dtype=float).T
    t = np.arange(kt[-1])
    temperature = np.interp(t, kt, kc)
    rate = 0.02 + 2e-3 * (temperature - 25.0) + amplitude * (np.exp(-t / fast) + np.exp(-t / slow)) + rng.normal(0.0, sigma, t.size)
    rec = recording_from_frame(pd.DataFrame({"time": t, "rate": rate, "temperature": temperature + rng.normal(0.0, 0.01, t.size)}), name="oven")
    fit_p, _, _ = problems(rec, [], DiagnoseSettings())
    return fit_p, extend(fit_p, fit_baseline(fit_p), "warmup")


def test_two_time_constants_state_sigmas_that_match_their_scatter():
    """A warm-up of 100 s and 2000 s: the time constants trade with each other and with their amplitudes; the stated
    sigmas (the whole Hessian of the two, carried to the amplitudes along the profile) match the scatter. With each
    time constant's curvature taken alone and the amplitudes at fixed time constants, the slow amplitude's z spread 2.35."""
    truth = {"tau_s": 100.0, "slow_tau_s": 2000.0, "amplitude_dps": 0.02, "slow_amplitude_dps": 0.02}
    z = {k: [] for k in truth}
    for seed in range(40, 56):
        fit_p, model = _two_decays(seed)
        assert model.spec["warmup"]["form"] == "two_time_constants"
        sig = uncertainties(fit_p, model)["warmup"]
        coef = dict(zip(model.names, model.beta))
        est = {"tau_s": model.spec["warmup"]["tau_s"], "slow_tau_s": model.spec["warmup"]["slow_tau_s"],
               "amplitude_dps": coef["warmup"], "slow_amplitude_dps": coef["warmup_slow"]}
        for k in z:
            z[k].append((est[k] - truth[k]) / sig[k])
    for k, v in z.items():
        assert 0.6 < np.std(v) < 1.6, (k, np.round(v, 2))
        assert abs(np.mean(v)) < 0.8, (k, np.round(v, 2))


def _report(uncertainty):
    params = {"hysteresis": {"amplitude_dps": {"value": 0.0099, "unit": "deg/s", "uncertainty": uncertainty},
                             "operator": {"value": "play", "unit": ""}}}
    regime = {"soak": {"rms_deg_h": 3.0, "expected_rms_deg_h": 2.0}}
    local = {"regime": regime, "timescale": {"adev": [{"tau_s": 1.0, "ratio": 1.0}, {"tau_s": 10.0, "ratio": 1.2}]}}
    return {"selected_effects": ["hysteresis"], "models": {"selected": {"params": params}},
            "localization": {"fit": {"baseline": local, "selected": local}}, "gap": {"baseline": {"fit": 3.0}, "selected": {"fit": 0.2}}}


@pytest.mark.parametrize("uncertainty, shown", [(0.00015, "0.00015"), (None, "not estimated")])
def test_the_report_shows_each_parameter_with_its_sigma(uncertainty, shown):
    from gyrocomp.diagnose.report import selected_rows
    from gyrocomp.plots import gap_figure

    rows = selected_rows(_report(uncertainty))
    assert rows == [("hysteresis", "amplitude_dps", "0.010", shown, "deg/s"), ("hysteresis", "operator", "play", "", "")]
    title = gap_figure(_report(uncertainty))._suptitle.get_text()
    assert "amplitude_dps = 0.010" in title
    assert ("± 0.00015 deg/s" in title) == (uncertainty is not None)
