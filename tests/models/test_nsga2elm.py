"""NSGA2ELM: a non-dominated front, a seeded search, and a pick that cannot come out worse than a plain ELM."""

from __future__ import annotations

import numpy as np
import pytest
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting

from gyrocomp.models import ELM, NSGA2ELM
from gyrocomp.models._base import block_split
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
    plain = {"n_hidden": 20, "activation": "sigmoid", "weight_scale": 1.0}
    chosen = plain if fitted.best_index_ is None else fitted.front_[fitted.best_index_]
    est = fitted.estimator_
    assert (est.n_hidden, est.activation, est.weight_scale, est.seed) == (
        chosen["n_hidden"], chosen["activation"], chosen["weight_scale"], fitted.elm_seed_)


def _plain_validation_rmse(model, X, y):
    """Validation RMSE of the plain ELM (``ELM()`` with the search's weights) on the search's split."""
    train, val = block_split(len(y), model.validation_fraction, np.random.default_rng(model.seed))
    plain = ELM(seed=model.elm_seed_).fit(X[train], y[train])
    return np.sqrt(np.mean((plain.predict(X[val]) - y[val]) ** 2))


@pytest.mark.parametrize("noise", [0.02, 0.1, 0.3])
def test_pick_is_never_worse_than_the_plain_elm_on_validation(noise):
    """The safe pick by construction (NSGA2ELM Notes): a front member only when >= min_gain better.

    Eight seeds per noise level, a small search (pop 10, 4 generations): the bound
    does not depend on the search finding anything good. The plain ELM's validation
    RMSE is recomputed here from the split and ``ELM()``.
    """
    kept = 0
    for seed in range(8):
        X, y, _ = oven_run(100 + seed, n=300, noise=noise)
        model = NSGA2ELM(pop_size=10, n_gen=4, seed=seed).fit(X, y)
        plain = _plain_validation_rmse(model, X, y)
        assert model.plain_rmse_ == pytest.approx(plain, rel=1e-9)
        assert model.front_[0]["rmse"] <= plain * (1 + 1e-9)  # the plain ELM was in the population
        if model.best_index_ is None:
            est = model.estimator_
            assert (est.n_hidden, est.activation, est.weight_scale) == (20, "sigmoid", 1.0)
            kept += 1
        else:
            assert model.front_[model.best_index_]["rmse"] < (1 - model.min_gain) * plain, seed
    if noise == 0.02:
        assert kept < 8  # a clean signal: the search does find better networks


def smooth_function(X):
    """An independent smooth drift of the normalised inputs (T', R'): no cubic, no linear rate term."""
    return np.sin(2.5 * X[:, 0]) + 0.5 * np.exp(-((X[:, 0] - 0.3) ** 2) / 0.1) + 0.6 * np.tanh(2 * X[:, 1])


@pytest.mark.parametrize("problem", ["cubic, noise 0.1", "smooth, noise 0.02"])
def test_pick_is_not_worse_than_default_elm_on_held_out_runs(problem):
    """Train on one oven run, test on another with a faster chamber, 8 seeds, the configured search.

    A statistic, not one seed: one seed's pick is only as good as the CPU that rounds
    it (issue #20, where the knee came out 4.8x a default ELM). Pick / default-ELM
    held-out RMSE (default: mean over ELM seeds 0-9), measured here over these 8
    seeds: cubic drift with noise 0.1 (validation RMSE mostly noise), 0.85-1.37,
    median 1.01; the smooth function with noise 0.02, 0.33-1.17, median 0.45. The
    default ELMs themselves spread up to 1.3x their mean. Bounds: the median (robust
    to one seed's draw) at 1.15 and 0.6, no seed at 2x (the degenerate picks of
    issue #20). benchmarks/nsga2elm_pick.py gives the distribution over 50 seeds on
    three problems.
    """
    ratios = []
    for seed in range(8):
        X, y, _ = oven_run(10_000 + seed, noise=0.1)
        X_test, _, target = oven_run(20_000 + seed, tau_s=100.0)
        X_test = np.clip(X_test, X.min(axis=0), X.max(axis=0))  # the pipeline's clip_inputs
        if problem.startswith("smooth"):
            y = smooth_function(X) + np.random.default_rng(30_000 + seed).normal(0, 0.02, len(X))
            target = smooth_function(X_test)

        def error(model):
            return np.sqrt(np.mean((model.predict(X_test) - target) ** 2))

        default = np.mean([error(ELM(seed=s).fit(X, y)) for s in range(10)])
        ratios.append(error(NSGA2ELM(seed=seed).fit(X, y)) / default)
    assert max(ratios) < 2.0, np.round(ratios, 3)
    # where the search has something to find (smooth), it finds it; where not, it costs nothing
    assert np.median(ratios) < (0.6 if problem.startswith("smooth") else 1.15), np.round(ratios, 3)


def test_same_seed_same_front():
    # Both searches run in this process: exact within one machine and one process type. Across
    # CPUs the fronts differ (issue #20): what must hold everywhere is tested over seeds below.
    X, y, _ = oven_run(3, n=200)
    a = NSGA2ELM(pop_size=8, n_gen=3, seed=5).fit(X, y)
    b = NSGA2ELM(pop_size=8, n_gen=3, seed=5).fit(X, y)
    assert a.front_ == b.front_ and a.best_index_ == b.best_index_
    assert np.array_equal(a.predict(X), b.predict(X))


def test_knee_and_min_rmse_picks():
    front = [{"rmse": r, "beta_norm": b} for r, b in [(1.0, 100.0), (1.1, 10.0), (1.5, 5.0), (3.0, 1.0)]]
    assert _pick(front, "min_rmse", 0.05) == 0
    assert _pick(front, "knee", np.inf) == 1  # the whole front; normalised distances: 1.0, 0.10, 0.26, 1.0
    assert _pick(front, "knee", 0.05) == 0  # nobody else within 5 % of the best: the best


def test_knee_only_within_the_rmse_tolerance():
    """Whole front: (0.02, 0.17) is nearest the ideal point; within 5 %, the middle of three."""
    front = [{"rmse": r, "beta_norm": b} for r, b in [(1.0, 100.0), (1.02, 20.0), (1.04, 18.0), (1.5, 5.0), (3.0, 1.0)]]
    assert _pick(front, "knee", np.inf) == 2  # distances 1, 0.192, 0.173, 0.253, 1
    assert _pick(front, "knee", 0.05) == 1  # over the first three: 1, 0.5006, 1
    assert _pick(front, "knee", 0.0) == 0


def test_plain_elm_is_in_the_initial_population():
    """One generation: the plain ELM (20 sigmoid nodes, lambda 1) is on the front or dominated by it."""
    X, y, _ = oven_run(4, n=200)
    model = NSGA2ELM(pop_size=6, n_gen=1, seed=1).fit(X, y)
    assert model.front_[0]["rmse"] <= _plain_validation_rmse(model, X, y) * (1 + 1e-9)


@pytest.mark.parametrize("params, name", [({"pop_size": 1}, "pop_size"), ({"crossover": 2.0}, "crossover"),
                                           ({"hidden_range": (0, 50)}, "hidden_range"),
                                           ({"activations": ("relu",)}, "activations"),
                                           ({"pick": "best"}, "pick"), ({"rmse_tolerance": -0.1}, "rmse_tolerance"),
                                           ({"min_gain": 1.5}, "min_gain"),
                                           ({"validation_fraction": 0.0}, "validation_fraction")])
def test_invalid_parameters_name_themselves(params, name):
    X, y, _ = oven_run(0, n=50)
    with pytest.raises(ValueError, match=name):
        NSGA2ELM(**params).fit(X, y)
