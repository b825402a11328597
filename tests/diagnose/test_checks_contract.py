"""Contract tests over every registered residual check (in the manner of scikit-learn's ``parametrize_with_checks``).

For each check of :data:`gyrocomp.diagnose.checks.KINDS` that judges one run:

* its p-values are uniform under the model (an exact check: Kolmogorov-Smirnov
  over seeded null draws) or conservative (a bound: ``P(p <= a) <= a`` at
  a = 0.01, 0.05, 0.1 within three binomial standard deviations);
* a structure of its own shape (``Check.shape``), added to a null draw, is
  found (``p < 1e-4``).

The null draws are block means ``y = X beta + noise`` with ``X = [1, T,
T^2]`` (a cubic-like temperature model) and a white plus random-walk noise
of known covariance, on a run that heats and cools twice; the checks see
the innovations under that covariance, as the verdict and the signature do.
The checks of a noise term's timescales and of several runs are covered
through their statistics below (Bartlett, Gaussian levels, the tone
replication, the replication score).
"""

from __future__ import annotations

import types

import numpy as np
import pytest
from scipy import stats

from gyrocomp.diagnose import checks
from gyrocomp.diagnose.checks import KINDS, Frame
from gyrocomp.diagnose.checks._linear import innovations, whiten
from gyrocomp.diagnose.checks.extreme import bartlett
from gyrocomp.diagnose.checks.levels import level_test
from gyrocomp.diagnose.checks.spectrum import tone_replication
from gyrocomp.diagnose.settings import ChecksSettings

N_BLOCKS = 240
BLOCK_S = 60.0
PER_BLOCK = 8
N_DRAWS = 200
RUN_CHECKS = [name for name, c in KINDS.items() if c.scope == "run"]


def _run():
    """Block times [s], temperatures [degC] (two heat-cool cycles, 5-45 degC), design and noise covariance."""
    t = (np.arange(N_BLOCKS) + 0.5) * BLOCK_S
    phase = (t / t[-1] * 2.0) % 1.0
    temp = 5.0 + 40.0 * (1.0 - np.abs(2.0 * phase - 1.0))
    x = (temp - 25.0) / 20.0
    X = np.column_stack([np.ones(N_BLOCKS), x, x**2])
    i = np.arange(1, N_BLOCKS + 1)
    cov = np.eye(N_BLOCKS) + 0.01 * np.minimum.outer(i, i)
    return t, temp, X, cov


T, TEMP, X, COV = _run()
LOWER = np.linalg.cholesky(COV)


def _frame(check, rate, rng):
    """The frame a check sees (the checks' settings, one section for the verdict's and the signature's)."""
    return Frame(LOWER, T, TEMP, BLOCK_S, ChecksSettings(), samples=(rate, PER_BLOCK, 1.0 / BLOCK_S * PER_BLOCK))


def _draw(check, rng, added=None):
    """One p-value of `check` on a null draw (plus the structure `added`: a block-level shape or a sample-spread factor)."""
    y = X @ rng.normal(size=3) + LOWER @ rng.standard_normal(N_BLOCKS)
    rate = rng.standard_normal(N_BLOCKS * PER_BLOCK)
    frame = _frame(check, rate, rng)
    if added is not None:
        if check.level == "sample":
            frame.pairs = frame.pairs * added(frame, rng)
        else:
            y = y + added(frame, rng)
    e, Xw, _ = innovations(y, X, COV)
    found = check.test(frame, e, Xw)
    return 1.0 if found is None else found.pvalue


def _scaled(check):
    """The check's shape, a deterministic one scaled to a whitened size of 20 beyond the design (z = 20)."""
    def added(frame, rng):
        g = check.shape(frame, rng)
        if check.level != "block":
            return g
        gw = whiten(LOWER, g[:, None])
        q, _ = np.linalg.qr(whiten(LOWER, X))
        return 20.0 * g / np.linalg.norm(gw - q @ (q.T @ gw))
    return added


def test_the_registry_holds_every_check_once_with_its_family():
    assert len(set(KINDS)) == len(KINDS) == len({c.test for c in KINDS.values()})
    assert set(checks.RESIDUAL) | set(checks.SIGNATURE) <= set(RUN_CHECKS)
    assert checks.family_size({name: {"p": 0.5} for name in checks.RESIDUAL}) == len(checks.RESIDUAL) == 12
    assert {"allan", "extreme", "levels", "agreement", "replication", "spectrum"} == set(KINDS) - set(RUN_CHECKS)


@pytest.mark.parametrize("name", RUN_CHECKS)
def test_p_values_are_uniform_or_conservative_under_the_model(name):
    check = KINDS[name]
    rng = np.random.default_rng(list(KINDS).index(name))
    p = np.array([_draw(check, rng) for _ in range(N_DRAWS)])
    assert np.all((p >= 0.0) & (p <= 1.0))
    if check.exact:
        assert stats.kstest(p, "uniform").pvalue > 1e-3, f"{name}: p-values not uniform under the model"
    for a in (0.01, 0.05, 0.1):
        assert np.mean(p <= a) <= a + 3.0 * np.sqrt(a * (1 - a) / N_DRAWS) + 1.0 / N_DRAWS, f"{name}: false alarms above {a}"


@pytest.mark.parametrize("name", RUN_CHECKS)
def test_a_structure_of_the_checks_own_shape_is_found(name):
    check = KINDS[name]
    rng = np.random.default_rng(100 + list(KINDS).index(name))
    p = [_draw(check, rng, _scaled(check)) for _ in range(5)]
    assert max(p) < 1e-4, f"{name}: its own shape not found (p = {p})"


def test_bartlett_of_the_extreme_check_is_calibrated_and_finds_a_late_burst():
    rng = np.random.default_rng(7)
    p = np.array([bartlett(rng.standard_normal(120), np.eye(120), 4)["p"] for _ in range(N_DRAWS)])
    assert stats.kstest(p, "uniform").pvalue > 1e-3
    burst = rng.standard_normal(120) * np.repeat([1.0, 1.0, 1.0, 2.5], 30)
    assert bartlett(burst, np.eye(120), 4)["p"] < 1e-4


def test_the_levels_check_is_conservative_and_finds_two_levels():
    rng = np.random.default_rng(8)
    cov = 0.5 ** np.abs(np.subtract.outer(np.arange(200), np.arange(200)))
    root = np.linalg.cholesky(cov)
    p = np.array([level_test(root @ rng.standard_normal(200), cov)["p"] for _ in range(N_DRAWS)])
    for a in (0.01, 0.05, 0.1):
        assert np.mean(p <= a) <= a + 3.0 * np.sqrt(a * (1 - a) / N_DRAWS) + 1.0 / N_DRAWS
    two = rng.choice([-1.0, 1.0], 200) + 0.3 * rng.standard_normal(200)
    assert level_test(two, 1.09 * np.eye(200))["p"] < 1e-4


def test_the_spectrum_check_is_conservative_and_finds_a_tone_repeating_since_power_on():
    rng = np.random.default_rng(9)
    p = np.array([tone_replication([rng.standard_normal(N_BLOCKS) for _ in range(2)], (2, 4, 8))["p"] for _ in range(N_DRAWS)])
    for a in (0.01, 0.05, 0.1):
        assert np.mean(p <= a) <= a + 3.0 * np.sqrt(a * (1 - a) / N_DRAWS) + 1.0 / N_DRAWS
    k = np.arange(N_BLOCKS)
    tone = [rng.standard_normal(N_BLOCKS) + 0.8 * np.sin(2 * np.pi * k / 12.0 + ph) for ph in rng.uniform(0, 2 * np.pi, 2)]
    assert tone_replication(tone, (2, 4, 8))["p"] < 1e-4


def _replication_runs(rng, shared=None):
    runs, whitened, designs = [], [], []
    for name in ("fit", "holdout"):
        y = X @ rng.normal(size=3) + LOWER @ rng.standard_normal(N_BLOCKS) + (0.0 if shared is None else shared)
        basis = types.SimpleNamespace(block_s=BLOCK_S)
        run = types.SimpleNamespace(name=name, temperature_c=TEMP, n_per_block=1)
        runs.append(types.SimpleNamespace(y=y, basis=basis, run=run))
        whitened.append(innovations(y, X, COV))
        designs.append(X)
    return runs, designs, whitened


def test_the_replication_check_is_uniform_and_finds_a_residual_that_repeats():
    check = KINDS["replication"]
    rng = np.random.default_rng(10)
    p = np.array([r.pvalue for _ in range(100) for r in check.test(*_replication_runs(rng), ChecksSettings())])
    assert stats.kstest(p, "uniform").pvalue > 1e-3
    bump = 10.0 * np.exp(-0.5 * ((T - 4000.0) / 900.0) ** 2)
    found = check.test(*_replication_runs(rng, bump), ChecksSettings())
    assert min(r.pvalue for r in found if r.where["of"] == "time") < 1e-4
