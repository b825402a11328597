"""``periodic`` as a general periodic waveform: a Fourier series whose harmonics the BIC chooses, on constructed cases."""

import numpy as np
import pandas as pd
import pytest

from gyrocomp.diagnose import DiagnoseSettings, problems
from gyrocomp.diagnose.effects import KINDS
from gyrocomp.effects.likelihood import block_means
from gyrocomp.diagnose.select import Search, extend, fit_baseline
from gyrocomp.recordings import recording_from_frame

HOURS = 4
PERIOD_S = 1200.0
WHITE_DPS = 0.01  # per-sample white sigma at 1 Hz


def _problem(shape, seed, amplitude_dps):
    """A 4 h run at 1 Hz: a cubic in a cycling temperature, white noise and `amplitude_dps` times `shape(t)`."""
    rng = np.random.default_rng(seed)
    t = np.arange(HOURS * 3600, dtype=float)
    temperature = 25.0 + 20.0 * np.sin(2 * np.pi * t / (HOURS * 3600.0))
    rate = 2e-3 * (temperature - 25.0) + 1e-5 * (temperature - 25.0) ** 2 + WHITE_DPS * rng.standard_normal(t.size)
    rate = rate + amplitude_dps * shape(t)
    rec = recording_from_frame(pd.DataFrame({"time": t, "rate": rate, "temperature": temperature}), name=f"run{seed}")
    fit_p, _, _ = problems(rec, [], DiagnoseSettings())
    return fit_p


def pulse_train(t, duty=0.1, phase_s=137.0):
    """A pulse train of duty cycle `duty` and period ``PERIOD_S``, zero mean."""
    return (np.mod(t - phase_s, PERIOD_S) < duty * PERIOD_S) - duty


def _fitted_component(problem, model):
    """Block means of the fitted periodic waveform."""
    run = problem.run
    X, names = KINDS["periodic"].columns(run, model.spec["periodic"])
    coef = dict(zip(model.names, model.beta))
    return block_means(X @ np.array([coef[n] for n in names]), run.n_per_block)


def test_a_pulse_train_is_fitted_as_its_fundamental_with_harmonics():
    """A 10 %-duty pulse train: its fundamental carries 22 % of its power, the harmonics the rest; the waveform found
    follows the pulses (a sinusoid alone would correlate 0.46 with them)."""
    p = _problem(pulse_train, 3, 0.02)
    model = extend(p, fit_baseline(p), "periodic")
    spec = model.spec["periodic"]
    assert spec["period_s"] == pytest.approx(PERIOD_S, rel=0.005)
    assert spec["harmonics"] >= 4
    truth = block_means(pulse_train(p.run.time_s), p.run.n_per_block)
    assert np.corrcoef(_fitted_component(p, model), truth)[0, 1] > 0.9
    # Parameters counted honestly: the baseline's, the period and a sine and a cosine per harmonic.
    assert model.n_params == fit_baseline(p).n_params + 1 + 2 * spec["harmonics"]


def test_a_sinusoid_stays_one_harmonic():
    p = _problem(lambda t: np.sin(2 * np.pi * t / PERIOD_S + 0.4), 4, 0.004)
    model = extend(p, fit_baseline(p), "periodic")
    assert model.spec["periodic"]["period_s"] == pytest.approx(PERIOD_S, rel=0.005)
    assert model.spec["periodic"]["harmonics"] == 1
    report = KINDS["periodic"].report(dict(zip(model.names, model.beta)), model.spec["periodic"], model.noise)
    assert report["amplitude_dps"]["value"] == pytest.approx(0.004, rel=0.1)


@pytest.mark.parametrize("seed", range(20, 28))
def test_effect_free_runs_get_no_periodic(seed):
    """White noise and a cubic: the multiharmonic search (up to 8 harmonics at every period) adds nothing."""
    p = _problem(lambda t: 0.0 * t, seed, 0.0)
    search = Search([p], ["periodic"])
    assert search.run().order == ()
    # The best waveform's score change stays well short of the margin it would need.
    assert search.steps[0]["delta"]["periodic"] > -p.settings.bic_margin + 5.0
