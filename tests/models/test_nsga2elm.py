"""NSGA2ELM: a non-dominated front, a seeded search, and a pick that beats a default ELM."""

from __future__ import annotations

import numpy as np
import pytest
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting

from gyrocomp.models import ELM, NSGA2ELM
from gyrocomp.models.nsga2elm import _pick


def oven_run(seed: int, n: int = 600, noise: float = 0.1, tau_s: float = 150.0):
    """A synthetic oven test: 60 -> -40 degC in 10 degC steps through a first-order chamber.

    Drift = cubic in (T - 25) + 3 s * dT/dt plus white noise; inputs normalised
    (T - 10)/50 and (dT/dt)/0.2 as the pipeline does. Returns X, noisy y, clean drift.
    """
    rng = np.random.default_rng(seed)
    dt = 10.0
    setpoint = np.repeat(np.arange(60, -41, -10.0), n // 11 + 1)[:n]
    tau = tau_s * (1 + 0.1 * rng.normal())
    T = np.empty(n)
    T[0] = 60.0
    for i in range(1, n):
        T[i] = T[i - 1] + (setpoint[i] - T[i - 1]) * dt / tau
    rate = np.gradient(T, dt)
    drift = 0.02 * (T - 25) + 4e-4 * (T - 25) ** 2 - 1e-5 * (T - 25) ** 3 + 3.0 * rate
    X = np.column_stack([(T - 10) / 50, rate / 0.2])
    return X, drift + rng.normal(0, noise, n), drift


@pytest.fixture(scope="module")
def fitted():
    X, y, _ = oven_run(1)
    return NSGA2ELM(pop_size=20, n_gen=8, seed=0).fit(X, y)


def test_front_is_non_dominated(fitted):
    F = np.array([[m["rmse"], m["beta_norm"]] for m in fitted.front_])
    assert len(NonDominatedSorting().do(F, only_non_dominated_front=True)) == len(F)
    for i, a in enumerate(F):  # brute force: nobody is at least as good in both and better in one
        dominated = np.all(F <= a, axis=1) & np.any(F < a, axis=1)
        assert not dominated.any(), f"front member {i} is dominated"
    assert [m["rmse"] for m in fitted.front_] == sorted(m["rmse"] for m in fitted.front_)
    for m in fitted.front_:
        assert 1 <= m["n_hidden"] <= 50 and 0 <= m["weight_scale"] <= 1
        assert m["activation"] in ("sigmoid", "sin", "hardlim", "tribas", "radbas")


def test_picked_member_is_the_refitted_estimator(fitted):
    chosen = fitted.front_[fitted.best_index_]
    est = fitted.estimator_
    assert (est.n_hidden, est.activation, est.weight_scale, est.seed) == (
        chosen["n_hidden"], chosen["activation"], chosen["weight_scale"], fitted.elm_seed_)


def test_knee_pick_beats_default_elm_on_held_out_run(fitted):
    """Train on one oven run, test on another with a faster chamber (Zhang 2024 Fig. 16 claim).

    The least-RMSE member overfits (||beta|| ~ 1e6); the knee keeps beta small.
    """
    X_test, _, drift_test = oven_run(2, tau_s=100.0)
    X, y, _ = oven_run(1)

    def error(model):
        return np.sqrt(np.mean((model.predict(X_test) - drift_test) ** 2))

    default = np.mean([error(ELM(seed=s).fit(X, y)) for s in range(10)])
    assert error(fitted) < 0.8 * default


def test_same_seed_same_front():
    X, y, _ = oven_run(3, n=200)
    a = NSGA2ELM(pop_size=8, n_gen=3, seed=5).fit(X, y)
    b = NSGA2ELM(pop_size=8, n_gen=3, seed=5).fit(X, y)
    assert a.front_ == b.front_ and a.best_index_ == b.best_index_
    assert np.array_equal(a.predict(X), b.predict(X))


def test_knee_and_min_rmse_picks():
    front = [{"rmse": r, "beta_norm": b} for r, b in [(1.0, 100.0), (1.1, 10.0), (1.5, 5.0), (3.0, 1.0)]]
    assert _pick(front, "min_rmse") == 0
    assert _pick(front, "knee") == 1  # normalised distances: 1.0, 0.10, 0.26, 1.0


@pytest.mark.parametrize("params, name", [({"pop_size": 1}, "pop_size"), ({"crossover": 2.0}, "crossover"),
                                           ({"hidden_range": (0, 50)}, "hidden_range"),
                                           ({"activations": ("relu",)}, "activations"),
                                           ({"pick": "best"}, "pick"),
                                           ({"validation_fraction": 0.0}, "validation_fraction")])
def test_invalid_parameters_name_themselves(params, name):
    X, y, _ = oven_run(0, n=50)
    with pytest.raises(ValueError, match=name):
        NSGA2ELM(**params).fit(X, y)


def test_paper_settings_pick_beats_default_elm():
    """The defaults of Zhang (2024): pop 40, 15 generations, crossover 0.8, mutation 0.15."""
    X, y, _ = oven_run(1, n=1500)
    X_test, _, drift_test = oven_run(2, n=1500, tau_s=100.0)
    model = NSGA2ELM(seed=0).fit(X, y)
    default = np.mean([np.sqrt(np.mean((ELM(seed=s).fit(X, y).predict(X_test) - drift_test) ** 2))
                       for s in range(10)])
    assert np.sqrt(np.mean((model.predict(X_test) - drift_test) ** 2)) < default
