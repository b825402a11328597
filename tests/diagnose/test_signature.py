"""The signature of a noise term (gyrocomp.diagnose.signature) on constructed cases.

Recordings are built here from numpy draws (white noise, a random walk, a
step, a temperature bump, a ramp) and from :func:`gyrocomp.effects.noise.flicker`
(a synthesis by spectral shaping, independent of the likelihood's
Gauss-Markov covariance); the noise term is fitted by
:func:`gyrocomp.diagnose.select.extend` as the diagnosis would.
"""

import dataclasses
import types

import numpy as np
import pytest
from scipy import stats

from gyrocomp.diagnose import DiagnoseSettings
from gyrocomp.diagnose.settings import ChecksSettings
from gyrocomp.diagnose import confirm as cf
from gyrocomp.diagnose import signature as sg
from gyrocomp.diagnose.checks import spectrum
from gyrocomp.diagnose.effects import Run, TemperatureScale
from gyrocomp.effects.likelihood import NoiseBasis
from gyrocomp.diagnose.select import Problem, Search, extend, fit_baseline
from gyrocomp.effects.noise import flicker

N = 0.005  # white rate noise [deg/s/sqrt(Hz)] (0.3 deg/sqrt(h))
K = 1.0 / 3600.0 / 60.0  # rate random walk [deg/s/sqrt(s)] (1 deg/h/sqrt(h))


def _recording(seed, kind="none", amp=0.0, rrw=0.0, bias=0.0, hours=8.0, fs=1.0):
    """Time, rate and temperature of a static gyro in an oven ramping 20 -> 60 -> 20 degC."""
    rng = np.random.default_rng(seed)
    n = int(hours * 3600 * fs)
    t = np.arange(n) / fs
    temp = 20.0 + 40.0 * (1.0 - np.abs(2.0 * t / t[-1] - 1.0))
    x = N * np.sqrt(fs) * rng.standard_normal(n) + 0.002 * (temp - 40.0) / 20.0
    if rrw:
        x += np.cumsum(rrw / np.sqrt(fs) * rng.standard_normal(n))
    if bias:
        x += flicker(n, fs, bias * 3600.0, rng)
    if kind == "step":
        x += amp * (t > 0.37 * t[-1])
    elif kind == "bump":
        x += amp * np.exp(-0.5 * ((temp - 45.0) / 3.0) ** 2)
    elif kind == "temperature_step":
        # a bias discontinuity at 45 degC, crossed heating and cooling: a pulse in time
        x += amp * (temp >= 45.0)
    elif kind == "ramp":
        x += amp * t / t[-1]
    elif kind == "transient":
        # a one-off bump in time, 0.02 of the run wide: a random walk takes it as a burst of wander
        x += amp * np.exp(-0.5 * ((t - 0.7 * t[-1]) / (0.02 * t[-1])) ** 2)
    elif kind == "chirp":
        # a tone whose period grows from 20 to 40 min over the run, its phase at power-on drawn per run
        x += amp * np.sin(2 * np.pi * t[-1] / 1200.0 * np.log1p(t / t[-1]) + rng.uniform(0, 2 * np.pi))
    elif kind == "telegraph":
        # random telegraph levels +-amp/2, exponential dwell of 500 s mean (popcorn noise)
        switches = np.cumsum(rng.exponential(500.0, size=int(4 * t[-1] / 500.0) + 16))
        x += amp * np.where(np.searchsorted(switches, t, side="right") % 2 == 0, 0.5, -0.5)
    return t, x, temp, fs


def _with_checks(**changes):
    """The default settings with the checks' `changes`."""
    return dataclasses.replace(DiagnoseSettings(), checks=dataclasses.replace(ChecksSettings(), **changes))


def _problems(*recordings, block_s=40.0):
    scale = TemperatureScale.of(recordings[0][2])
    return [
        Problem(Run(f"run{k}", t, x, temp, fs, int(block_s * fs), 60.0), DiagnoseSettings(), scale, 3)
        for k, (t, x, temp, fs) in enumerate(recordings)
    ]


def _check(term, kind="none", amp=0.0, seed=0, **noise):
    runs = _problems(_recording(seed, kind, amp, **noise), _recording(seed + 1000, kind, amp, **noise))
    model = extend(runs[0], fit_baseline(runs[0]), term)
    return sg.check(term, runs, model)


@pytest.mark.parametrize("seed", [1, 2])
def test_true_random_walk_passes(seed):
    result = _check("rate_random_walk", rrw=K, seed=seed)
    assert result.ok, result.reasons
    # deg/h/sqrt(h): each run's 95 % interval reaches within a factor 2 of the true 1 (the cubic in
    # temperature takes a share of the wander on this triangular profile, so the level reads low)
    for low, high in result.stats["agreement"]["interval_95"]:
        assert low < 1.0 and high > 0.5


def test_true_flicker_passes():
    result = _check("bias_instability", bias=3.0 / 3600.0, seed=3)
    assert result.ok, result.reasons


@pytest.mark.parametrize(
    ("kind", "amp", "words"),
    [
        ("step", 0.002, "step"),
        ("bump", 0.01, "Allan variance"),
        ("ramp", 0.01, "trend in time"),
    ],
)
def test_slow_deterministic_residual_is_refused(kind, amp, words):
    result = _check("rate_random_walk", kind, amp, seed=10)
    assert not result.ok
    assert any(words in r for r in result.reasons), result.reasons


def test_a_step_at_one_temperature_is_refused_as_a_temperature_effect():
    # a bias discontinuity at 45 degC, crossed heating and cooling (a pulse in time), under a random walk: the
    # temperature test finds it as a step at 45 degC on both runs, sharper than its 8 bins do
    result = _check("rate_random_walk", "temperature_step", 0.002, seed=10)
    assert not result.ok
    assert any("a temperature effect is absorbed" in r for r in result.reasons), result.reasons
    for run in result.stats["runs"]:
        found = run["temperature_absorbed"]
        assert found["by"] == "step" and abs(found["step"]["temperature_c"] - 45.0) < 1.0, found


def test_one_off_transient_is_refused_as_not_stationary():
    # 14 deg/h for about 10 min at 70 % of each run: no step, trend or temperature test sees it (they pass
    # with the stationarity and spectrum tests switched off), but the increments at the taus the walk explains
    # carry their spread in one part of the run; and, at one time after power-on in both runs, its power repeats
    runs = _problems(_recording(10, "transient", 0.004), _recording(1010, "transient", 0.004))
    model = extend(runs[0], fit_baseline(runs[0]), "rate_random_walk")
    off = _with_checks(min_segment_increments=10**6, spectrum_parts=())
    assert sg.check("rate_random_walk", runs, model, off).ok
    result = sg.check("rate_random_walk", runs, model, _with_checks(spectrum_parts=()))
    assert not result.ok and not result.own_ok
    assert any("change their spread" in r for r in result.reasons), result.reasons
    assert all(out["extreme"]["by"] == "stationary" for out in result.stats["runs"])
    tone = sg.check("rate_random_walk", runs, model).stats["spectrum"]
    assert tone["p"] < 1e-4 and tone["window_s"][0] <= 0.7 * 8 * 3600 <= tone["window_s"][1], tone


def test_a_chirp_that_repeats_after_power_on_is_not_flicker():
    # a tone of 2.2 deg/h whose period grows from 20 to 40 min, at a different phase in each run: flicker takes it
    # with every other statistic of its own (they pass with the spectrum test switched off), but its power sits
    # at the same time and period in both runs, where a wander's does not
    runs = _problems(_recording(41, "chirp", 0.0006), _recording(1041, "chirp", 0.0006))
    model = extend(runs[0], fit_baseline(runs[0]), "bias_instability")
    assert sg.check("bias_instability", runs, model, _with_checks(spectrum_parts=())).ok
    result = sg.check("bias_instability", runs, model)
    assert not result.ok and not result.own_ok
    assert len(result.reasons) == 1 and "repeats in every run" in result.reasons[0], result.reasons
    tone = result.stats["spectrum"]
    # the tone's period in the later half of the run: 1200 s (1 + t / T), 1800-2400 s
    assert tone["p"] < 1e-6 and tone["window_s"] == [14400.0, 28800.0] and 1800.0 < tone["period_s"] < 2400.0, tone
    # in one run only it does not repeat
    alone = _problems(_recording(41, "chirp", 0.0006), _recording(1041, "none"))
    assert sg.check("bias_instability", alone, extend(alone[0], fit_baseline(alone[0]), "bias_instability")).stats["spectrum"]["p"] > 0.01


def test_a_flicker_beside_a_tone_that_repeats_is_not_listed():
    # a chirp of 5.4 deg/h beside a true flicker of 2 deg/h in both runs: the flicker earns its place beside the
    # structure the tests find on the fit run in its place, and passes its own tests with that structure taken out
    # of the fit run -- which only lowers the tone's smallest power over the runs; the tone repeats, so it is not listed
    runs = _problems(_recording(41, "chirp", 0.0015, bias=2.0 / 3600.0), _recording(1041, "chirp", 0.0015, bias=2.0 / 3600.0))
    search = Search([runs[0]], [])
    model, v = cf.confirm(search, [("fit", runs[0]), ("holdout", runs[1])], extend(runs[0], search.baseline, "bias_instability"))
    assert model.order == ()
    assert v["present"] and v["unlisted"][0]["effect"] == "bias_instability"
    assert "repeats in every run" in v["unlisted"][0]["reason"] and "nor beside" in v["unlisted"][0]["reason"]


def test_tone_replication_is_calibrated_on_white_innovations():
    # independent white runs (two of one length, three of different lengths): p below 0.05 and 0.01 at those rates
    rng = np.random.default_rng(5)
    for sizes in ([720, 720], [700, 500, 650]):
        p = np.array([sg.tone_replication([rng.standard_normal(n) for n in sizes], (2, 4, 8))["p"] for _ in range(2000)])
        for rate in (0.05, 0.01):
            assert np.mean(p < rate) < rate + 3.0 * np.sqrt(rate * (1.0 - rate) / 2000), (sizes, rate)
        assert np.mean(p < 0.05) > 0.02, sizes  # not blind: Bonferroni over three lengths costs little
    # a tone in every run, each at its own phase, under white innovations of unit variance
    t = np.arange(720)
    tone = [rng.standard_normal(720) + 0.4 * np.sin(2 * np.pi * t / 24.0 + rng.uniform(0, 6)) for _ in range(2)]
    found = sg.tone_replication(tone, (2, 4, 8))
    assert found["p"] < 1e-6 and found["blocks"] / found["bin"] == pytest.approx(24.0, rel=0.05), found


def test_tone_replication_needs_contiguous_blocks_of_one_length():
    # a recording in segments: its block index is not its time, so no periodogram is read from it
    rng = np.random.default_rng(7)
    e = [rng.standard_normal(40) for _ in range(2)]
    steady = NoiseBasis(40, 10.0)
    gapped = NoiseBasis(40, 10.0, np.r_[np.arange(20), np.arange(30, 50)] * 10.0)
    assert steady.contiguous and not gapped.contiguous
    settings = ChecksSettings()
    for bases, compared in [((steady, steady), True), ((steady, gapped), False), ((steady, NoiseBasis(40, 20.0)), False)]:
        runs = [types.SimpleNamespace(basis=b) for b in bases]
        assert (spectrum.test(runs, e, settings) is not None) == compared


def test_bartlett_is_calibrated_on_random_walk_increments():
    # increments of 8-block means of white noise + a random walk (neighbours correlated -0.16): the
    # Satterthwaite degrees of freedom keep the test at its level; a standard deviation doubled in the last part is found
    rng = np.random.default_rng(5)
    n, m = 720, 8
    i = np.arange(n)
    cov = 0.5 * np.eye(n) + 0.02 * np.minimum.outer(i, i) + 0.02
    diff = np.diff(np.kron(np.eye(n // m), np.full((1, m), 1.0 / m)), axis=0)
    cov_d = diff @ cov @ diff.T
    lower = np.linalg.cholesky(cov_d)
    draws = lower @ rng.standard_normal((n // m - 1, 2000))
    p = np.array([sg.bartlett(d, cov_d, 4)["p"] for d in draws.T])
    for level in (0.05, 0.01):
        assert abs(np.mean(p < level) - level) < 3.0 * np.sqrt(level * (1.0 - level) / p.size) + 0.005
    late = draws * np.where(np.arange(n // m - 1) >= 67, 2.0, 1.0)[:, None]
    assert np.mean([sg.bartlett(d, cov_d, 4)["p"] < 0.01 for d in late.T[:200]]) > 0.7  # 0.81 measured


def test_runs_that_disagree_on_the_level_are_refused():
    runs = _problems(_recording(5, rrw=4.0 * K), _recording(6, rrw=0.25 * K))
    model = extend(runs[0], fit_baseline(runs[0]), "rate_random_walk")
    result = sg.check("rate_random_walk", runs, model)
    assert any("disagree" in r for r in result.reasons), result.reasons
    (lo0, hi0), (lo1, hi1) = result.stats["agreement"]["interval_95"]
    assert hi1 < lo0


def test_ljung_box_false_alarm_rate():
    rng = np.random.default_rng(0)
    p = np.array([sg.ljung_box(rng.standard_normal(300), 10)[1] for _ in range(400)])
    assert abs(np.mean(p < 0.05) - 0.05) < 3.0 * np.sqrt(0.05 * 0.95 / 400) + 0.01
    assert sg.ljung_box(np.cumsum(rng.standard_normal(300)), 10)[1] < 1e-6


def test_score_test_is_chi2_under_the_model():
    rng = np.random.default_rng(1)
    n = 200
    X = np.column_stack([np.ones(n), np.linspace(-1, 1, n)])
    G = rng.standard_normal((n, 3))
    q, _ = np.linalg.qr(X)
    stat = []
    for _ in range(500):
        z = rng.standard_normal(n)
        e = z - q @ (q.T @ z)
        stat.append(sg.score_test(e, X, G)[0])
    assert stats.kstest(stat, stats.chi2(3).cdf).pvalue > 0.01


def test_step_scan_false_alarm_rate_and_power():
    rng = np.random.default_rng(2)
    n = 300
    X = np.ones((n, 1))
    lower = np.eye(n)
    hits = 0
    for _ in range(300):
        z = rng.standard_normal(n)
        hits += sg.step_scan(z - z.mean(), X, lower)["p"] < 0.05
    assert hits / 300 <= 0.05 + 3.0 * np.sqrt(0.05 * 0.95 / 300)  # the union bound is conservative
    y = rng.standard_normal(n) + 1.0 * (np.arange(n) >= 120)
    found = sg.step_scan(y - y.mean(), X, lower)
    assert found["p"] < 1e-6 and abs(found["block"] - 120) <= 6 and found["size"] == pytest.approx(1.0, abs=0.3)


def test_telegraph_noise_is_not_flicker():
    # popcorn noise of 10 deg/h between its two levels under the white noise: a flicker fits its spectrum,
    # but its level at the shortest tau flicker explains is bimodal, and its path keeps to two levels
    result = _check("bias_instability", "telegraph", 0.003, seed=21)
    assert not result.ok and not result.own_ok
    assert any("two levels" in r or "bimodal" in r for r in result.reasons), result.reasons
    levels = result.stats["levels"]
    assert levels["p"] < 1e-4 and all(k < -0.5 for k in levels["kurtosis"])
    assert levels["p_kurtosis"] < 1e-4 and levels["two_levels"]["z"] > 5.0


def test_weak_telegraph_noise_is_found_by_its_two_levels():
    # popcorn of 4.3 deg/h, about the white noise's spread on a 40 s mean: too little to make the 40 s
    # levels bimodal, but two levels held for minutes at a time fit the path far better than a Gaussian wander
    result = _check("bias_instability", "telegraph", 0.0012, seed=23)
    levels = result.stats["levels"]
    assert not result.own_ok and any("two levels" in r for r in result.reasons), result.reasons
    assert levels["by"] == "two_levels" and levels["p_kurtosis"] > result.stats["alpha"]
    assert levels["two_levels"]["z"] > 3.5


def test_flicker_levels_pass_at_their_rate():
    # a true flicker's level test on the two runs is N(0, 1) or lighter in its lower tail: p below 0.05 in
    # at most about 5 % of pairs (8 pairs: at most 2), never near the Bonferroni share of 1 %
    p = np.array([_check("bias_instability", bias=3.0 / 3600.0, seed=s).stats["levels"]["p"] for s in range(30, 38)])
    assert np.sum(p < 0.05) <= 2 and p.min() > 1e-3, p


def test_level_test_is_calibrated_on_correlated_gaussian_levels():
    # AR(1) levels (rho 0.8) of 300 means: Q / sd is about N(0, 1) (mean and variance exact), its lower tail no heavier
    rng = np.random.default_rng(4)
    n, phi = 300, 0.8
    cov = phi ** np.abs(np.subtract.outer(np.arange(n), np.arange(n)))
    lower = np.linalg.cholesky(cov)
    z = np.array([sg.level_test(lower @ rng.standard_normal(n), cov)["stat"] for _ in range(2000)])
    assert abs(z.mean()) < 0.1 and 0.85 < z.std() < 1.15
    assert np.mean(z < stats.norm.ppf(0.01)) <= 0.01 + 3.0 * np.sqrt(0.01 * 0.99 / 2000)


def test_unknown_term():
    with pytest.raises(ValueError, match="signature is checked"):
        sg.check("warmup", [], None)
