"""The independent benchmark generator (``benchmarks/independent_gen.py``) against physics and peer libraries.

Nothing here uses gyrocomp: the lag is checked against scipy's continuous-time
simulation and a regression, the noise against allantools' Allan deviation
and the IEEE 952 slopes, the amplitudes against the t-statistic of an
ordinary least-squares fit.
"""

import subprocess
import sys

import allantools
import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import optimize, signal

import independent_gen as gen


def _profile(fs_hz=1.0, hours=4.0):
    """Room soak, a 2 degC/min ramp to 60, a soak, a 1 degC/min ramp to -20, a soak (piecewise linear)."""
    t = np.arange(int(hours * 3600 * fs_hz)) / fs_hz
    knots_t = np.array([0, 1800, 1800 + 1050, 6000, 6000 + 4800, 20000, 1e6])
    knots_c = np.array([25, 25, 60, 60, -20, -20, -20])
    return t, np.interp(t, knots_t, knots_c)


def test_first_order_lag_matches_scipy_lsim_and_its_time_constant_is_recovered():
    t, x = _profile()
    tau = 600.0
    y = gen.first_order_lag(x, t, tau)
    _, ref, _ = signal.lsim(([1.0], [tau, 1.0]), x, t, X0=[x[0] * tau])  # state = tau * y for this realisation
    assert_allclose(y, ref, atol=1e-6)
    # tau dy/dt = x - y: the slope of (x - y) on dy/dt is tau (central differences, 1 s steps)
    dydt = np.gradient(y, t)
    moving = np.abs(dydt) > 1e-3
    slope = np.polyfit(dydt[moving], (x - y)[moving], 1)[0]
    assert_allclose(slope, tau, rtol=0.01)


def test_two_parallel_lags_step_response_gives_both_time_constants():
    t = np.arange(0.0, 40000.0)
    x = np.where(t >= 100.0, 1.0, 0.0)
    fast, slow, w = 240.0, 5400.0, 0.35
    y = w * gen.first_order_lag(x, t, fast) + (1 - w) * gen.first_order_lag(x, t, slow)
    after = t >= 101.0

    def model(s, a, t1, t2):
        return 1.0 - a * np.exp(-s / t1) - (1 - a) * np.exp(-s / t2)

    p, _ = optimize.curve_fit(model, t[after] - 100.0, y[after], p0=[0.5, 100.0, 3000.0])
    assert_allclose(p, [w, fast, slow], rtol=0.02)


def _triangle(lo=-20.0, hi=60.0, rate_c_per_s=1 / 60, cycles=2):
    """Temperature on a 1 s grid: from the middle up to `hi`, down to `lo`, ..."""
    legs = [hi, lo] * cycles
    temps, now = [], (lo + hi) / 2
    for target in legs:
        n = int(abs(target - now) / rate_c_per_s)
        temps.append(np.linspace(now, target, n, endpoint=False))
        now = target
    return np.concatenate(temps + [[now]])


def test_relay_switches_one_width_after_each_reversal():
    temp = _triangle()
    width = 5.0
    out = gen.relay_sum(temp, [width], [1.0])
    switches = np.flatnonzero(np.diff(out) != 0) + 1
    # up at start (heating): stays up until 60 - 5 on the way down, then down until -20 + 5 on the way up, ...
    assert_allclose(temp[switches], [55.0, -15.0, 55.0], atol=0.02)
    assert set(np.unique(out)) == {-1.0, 1.0}


def test_preisach_spread_opens_over_its_widths_and_saturates():
    temp = _triangle()
    widths = np.exp(np.linspace(np.log(1.0), np.log(12.0), 40))
    out = gen.relay_sum(temp, widths, np.ones(40))
    top = int(np.argmax(temp))  # first turn at 60 degC
    after = out[top:top + int(20 * 60)]  # 20 degC of cooling
    fell = 60.0 - temp[top:top + after.size]
    assert after[fell < 0.99].min() == 1.0          # no relay narrower than 1 degC
    assert after[fell > 12.01].max() == -1.0        # all relays switched after 12 degC
    mid = (fell > 3.0) & (fell < 5.0)
    assert np.all((after[mid] > -1.0) & (after[mid] < 1.0))  # partly switched in between: a gradual loop


def test_play_operator_crosses_zero_half_a_width_after_a_reversal():
    temp = _triangle()
    out = gen.play_operator(temp, 8.0, 1.0)
    top = int(np.argmax(temp))
    crossing = top + int(np.argmax(out[top:] <= 0.0))
    assert_allclose(60.0 - temp[crossing], 4.0, atol=0.05)
    assert_allclose([out.max(), out.min()], [1.0, -1.0])


def _oadev(x, fs_hz, taus):
    t, ad, _, _ = allantools.oadev(x, rate=fs_hz, data_type="freq", taus=taus)
    return t, ad


def test_kasdin_flicker_has_a_flat_allan_floor_at_0664_b():
    """IEEE 952 Annex C: flicker rate noise of coefficient B has Allan deviation 0.664 B, slope 0."""
    b = 0.01
    x = gen.kasdin_flicker(2**18, b, np.random.default_rng(3))
    taus = np.logspace(1, 3, 9)
    t, ad = _oadev(x, 1.0, taus)
    slope = np.polyfit(np.log(t), np.log(ad), 1)[0]
    assert abs(slope) < 0.1
    assert_allclose(np.median(ad) / (0.664 * b), 1.0, rtol=0.15)


def test_random_walk_allan_slope_and_level():
    """IEEE 952: a rate random walk K has Allan deviation K sqrt(tau / 3), slope +1/2; it meets the white line at ``cross_s``."""
    run = gen.RunState("fit", np.arange(2**20, dtype=float), None, None, 1.0, 1e-3, (0, 1), (0, 1), np.random.default_rng(5))
    p = {"cross_s": 100.0}
    x = gen._random_walk(run, p) + run.rng.standard_normal(run.t.size) * run.arw
    k = gen._noise_level_rw(run, p)
    t, ad = _oadev(x, 1.0, [1000.0, 2000.0, 4000.0])
    assert_allclose(ad, k * np.sqrt(t / 3.0), rtol=0.2)
    assert 0.35 < np.polyfit(np.log(t), np.log(ad), 1)[0] < 0.65
    t, ad = _oadev(x, 1.0, [100.0])  # the crossing: white and walk add in variance
    assert_allclose(ad, np.sqrt(2.0) * run.arw / np.sqrt(100.0), rtol=0.1)


def test_gauss_markov_statistics_and_allan_peak():
    """A first-order Gauss-Markov process: std sigma, autocorrelation e^-1 at its correlation time, Allan peak 0.437 sigma at 1.89 T."""
    sigma, tau = 2.0, 50.0
    x = gen.gauss_markov(2**20, sigma, tau, 1.0, np.random.default_rng(8))
    assert_allclose(x.std(), sigma, rtol=0.05)
    lag = int(tau)
    assert_allclose(np.corrcoef(x[:-lag], x[lag:])[0, 1], np.exp(-1.0), atol=0.03)
    t, ad = _oadev(x, 1.0, np.logspace(1, 3, 41))
    assert_allclose(ad.max() / sigma, gen._GM_PEAK, rtol=0.08)
    assert_allclose(t[np.argmax(ad)] / tau, 1.89, rtol=0.25)


def test_telegraph_dwell_time():
    t = np.arange(0.0, 2e6)
    x = gen.telegraph(t, 500.0, np.random.default_rng(2))
    n_switches = np.count_nonzero(np.diff(x))  # Poisson, 4000 +- 63
    assert_allclose(t[-1] / n_switches, 500.0, rtol=0.05)
    assert set(np.unique(x)) == {-0.5, 0.5}


def test_plan_covers_every_form_and_rate():
    plan = gen.case_plan(gen.TUNING_SEED, speed_twins=1)
    keys = {c["key"] for c in plan}
    assert keys >= set(gen.FORMS)
    for effect in gen.VOCABULARY:
        forms = [f for f in gen.FORMS.values() if f.effect == effect]
        assert {f.category for f in forms} == {"sim_form", "real_form"}
        assert sum(f.category == "real_form" for f in forms) >= 2
    oov = [f for f in gen.FORMS.values() if f.category == "oov"]
    assert len(oov) >= 6 and {f.kind for f in oov} == {"shape", "sigma"}
    assert sum(c["category"] == "none" for c in plan) >= 4
    assert {c["fs_hz"] for c in plan} == {1.0, 2.0, 10.0, 100.0}


@pytest.mark.parametrize("key", ["temp_rate/linear", "bias_step/mode_hop", "periodic/square_wave"])
def test_amplitude_gives_the_drawn_visibility(key):
    """The OLS t-statistic of the exact shape beside offset + cubic averages the drawn z (t ~ N(z, 1) per run)."""
    case = gen.draw_case(1, 0, key, fs_hz=1.0, duration_s=4 * 3600.0) | {"z_target": 6.0}
    form = gen.FORMS[key]
    stats = []
    for s in range(24):
        runs, realised = gen.generate_pair(case | {"seed": 100 + s})
        fit = runs["fit"]
        state = gen.RunState("fit", fit["time"], None, None, 1.0, 0.0, (0, 1), (0, 1), np.random.default_rng(0))
        housing = gen.first_order_lag(np.interp(fit["time"], *gen.chamber(case["profiles"]["fit"], case["duration_s"])),
                                      fit["time"], case["gyro"]["housing_tau_s"])
        state.housing_c, state.rate_c_per_s = housing, np.gradient(housing, fit["time"])
        x = (fit["temperature"] - 25.0) / 50.0
        X = np.column_stack([np.ones_like(x), x, x**2, x**3, form.make(state, case["params"])])
        coef, res, *_ = np.linalg.lstsq(X, fit["rate"], rcond=None)
        s2 = res[0] / (x.size - X.shape[1])
        stats.append(coef[-1] / np.sqrt(s2 * np.linalg.inv(X.T @ X)[-1, -1]))
    assert_allclose(np.mean(np.abs(stats)), 6.0, atol=0.7)


def test_profiles_differ_overlap_and_reverse():
    for index in range(6):
        case = gen.draw_case(3, index, gen.NONE, fs_hz=1.0)
        runs, realised = gen.generate_pair(case)
        fit, hold = runs["fit"], runs["holdout"]
        assert fit["time"].size == hold["time"].size == 28800
        lo, hi = realised["span_c"]["fit"]
        hlo, hhi = realised["span_c"]["holdout"]
        assert lo - 0.2 <= hlo and hhi <= hi + 0.2          # the holdout stays inside the fit run's range
        assert not np.allclose(fit["temperature"], hold["temperature"])
        for r in (fit, hold):
            slope = np.gradient(np.convolve(r["temperature"], np.ones(300) / 300, "valid"))  # degC/s over 5 min
            assert slope.max() > 0.1 / 60 and slope.min() < -0.1 / 60    # heats and cools
            assert np.ptp(r["temperature"][:1200]) < 1.0                  # a soak at power-on
            lsb = case["gyro"]["sensor_lsb_c"]
            assert_allclose(r["temperature"] / lsb, np.round(r["temperature"] / lsb), atol=1e-6)


@pytest.mark.parametrize("key", ["hysteresis/play_operator", "hysteresis/two_branch_relay", "hysteresis/preisach_width_spread"])
def test_the_power_on_oracle_is_the_branch_at_power_on_until_every_start_agrees(key):
    """At power-on the effect less its midway start is the amplitude times the start itself (a play's output, the
    relay's branch, the mean of the relays' branches); once the temperature has swept the widest width both ways,
    every start agrees and nothing is left."""
    case = gen.draw_case(5, 2, key, fs_hz=1.0, duration_s=8 * 3600.0)
    runs, realised = gen.generate_pair(case, power_on_oracle=True)
    unknown, a = realised["power_on_unknown_dps"], realised["amplitude"]
    start = case["params"]["initial"]["holdout"]
    widest = max(case["params"].get(k, 0.0) for k in ("width_c", "narrowest_c", "widest_c"))
    if key.endswith("relay"):
        start = 1.0 if start >= 0 else -1.0
    elif key.endswith("spread"):  # the relays below `start` on a linear scale from -1 to 1 are up
        up = np.linspace(-1, 1, case["params"]["relays"]) < start
        start = float(np.mean(np.where(up, 1.0, -1.0)))
    assert unknown[0] == pytest.approx(a * start, abs=1e-12)
    t = runs["holdout"]["time"]
    T = gen.first_order_lag(np.interp(t, *gen.chamber(case["profiles"]["holdout"], case["duration_s"])), t, case["gyro"]["housing_tau_s"])
    swept = np.flatnonzero((np.maximum.accumulate(T) - T > 2 * widest) & (T - np.minimum.accumulate(T) > 2 * widest))
    assert swept.size and np.all(unknown[swept[0]:] == 0.0)
    _, plain = gen.generate_pair(case)
    assert "power_on_unknown_dps" not in plain


def test_same_case_same_bytes_other_seed_other_noise():
    case = gen.draw_case(5, 2, "hysteresis/play_operator", fs_hz=1.0, duration_s=7200.0)
    a, _ = gen.generate_pair(case)
    b, _ = gen.generate_pair(case)
    c, _ = gen.generate_pair(case | {"seed": 6})
    assert a["fit"]["rate"].tobytes() == b["fit"]["rate"].tobytes()
    assert not np.array_equal(a["fit"]["rate"], c["fit"]["rate"])


def test_the_generator_does_not_load_gyrocomp():
    code = ("import sys; sys.path.insert(0, 'benchmarks'); import independent_gen as g; "
            "g.generate_pair(g.draw_case(1, 0, 'thermal_lag/first_order', fs_hz=1.0, duration_s=3600.0)); "
            "print(sorted(m for m in sys.modules if m.startswith('gyrocomp')))")
    root = gen.HERE.parent
    out = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
