"""NSGA2ELM: a non-dominated front, a seeded search, and a pick that cannot come out worse than a plain ELM."""

from __future__ import annotations

import numpy as np
import pytest
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting

from gyrocomp.models import ELM, NSGA2ELM
from gyrocomp.models._base import block_split
from gyrocomp.models._nsga2elm_accept import cv_rmse as _cv_rmse, regime_rmse as _regime_rmse, regimes as _regimes
from gyrocomp.models._nsga2elm_accept import sign_test as _sign_test, significant_everywhere as _significant_everywhere
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
    """Validation RMSE of the plain individual (``ELM()``'s hyper-parameters, the search's ridge and weights)."""
    train, val = block_split(len(y), model.validation_fraction, np.random.default_rng(model.seed))
    plain = ELM(ridge=model.ridge, seed=model.elm_seed_).fit(X[train], y[train])
    return np.sqrt(np.mean((plain.predict(X[val]) - y[val]) ** 2))


def test_cross_validation_blocks_are_interleaved_into_folds():
    """40 samples, 2 folds: 8 blocks of 5, fold 0 = blocks 0, 2, 4, 6; each block predicted by a fit on the other fold."""
    rng = np.random.default_rng(0)
    X, y = rng.uniform(-1, 1, (40, 2)), rng.normal(size=40)
    params = {"n_hidden": 5, "activation": "sin", "weight_scale": 0.7}
    fold0 = np.r_[0:5, 10:15, 20:25, 30:35]
    fold1 = np.setdiff1d(np.arange(40), fold0)
    prediction = np.empty(40)
    for held, rest in ((fold0, fold1), (fold1, fold0)):
        prediction[held] = ELM(5, "sin", 0.7, seed=3).fit(X[rest], y[rest]).predict(X[held])
    expected = [np.sqrt(np.mean((prediction[j : j + 5] - y[j : j + 5]) ** 2)) for j in range(0, 40, 5)]
    np.testing.assert_allclose(_cv_rmse(params, X, y, 2, 0.0, 3), expected, rtol=1e-12)
    with pytest.raises(ValueError, match="cv_folds"):
        _cv_rmse(params, X, y, 11, 0.0, 3)


def test_sign_test_against_the_binomial_tail():
    """P(at least w of 20 fair coin flips): 16 -> 6196/2^20 = 0.00591, 17 -> 1351/2^20, 18 -> 211/2^20; ties and losses are not wins."""
    plain = np.ones(20)
    assert _sign_test(np.array([plain, np.r_[np.full(18, 0.9), np.full(2, 1.1)]])) == pytest.approx(211 / 2**20)
    assert _sign_test(np.array([plain, np.r_[np.full(17, 0.9), np.full(3, 1.1)]])) == pytest.approx(1351 / 2**20)
    assert _sign_test(np.array([plain, np.r_[np.full(16, 0.9), np.full(4, 1.1)]])) == pytest.approx(6196 / 2**20)
    assert _sign_test(np.array([plain, np.r_[np.full(15, 0.9), np.ones(5)]])) == pytest.approx(21700 / 2**20)
    assert _sign_test(np.array([plain, plain])) == 1.0


def oven_profile(n_soak: int = 60, n_ramp: int = 40) -> np.ndarray:
    """A hand-made oven temperature [degC]: soak 25, heat to 45, soak, cool to 5, soak (straight ramps)."""
    return np.concatenate([
        np.full(n_soak, 25.0), np.linspace(25, 45, n_ramp + 2)[1:-1], np.full(n_soak, 45.0),
        np.linspace(45, 5, 2 * n_ramp + 2)[1:-1], np.full(n_soak, 5.0),
    ])


def test_regimes_of_a_constructed_oven_profile():
    """Soak, heating, soak, cooling, soak; the same labels after any increasing affine map of the column."""
    T = oven_profile()  # 60 soak, 40 heating, 60 soak, 80 cooling, 60 soak: 300 samples, smoothing 3
    labels = _regimes(T, 0.01, 0.1)
    expected = np.concatenate([np.zeros(60), np.ones(40), np.zeros(60), -np.ones(80), np.zeros(60)])
    inside = np.ones(300, dtype=bool)
    for corner in (60, 100, 160, 240):  # smoothing over 3 then a central difference reach 2 samples either side
        inside[corner - 2 : corner + 2] = False
    np.testing.assert_array_equal(labels[inside], expected[inside])
    assert set(labels[~inside]) <= {-1, 0, 1}
    np.testing.assert_array_equal(_regimes((T - 10) / 50, 0.01, 0.1), labels)  # the pipeline's normalisation
    np.testing.assert_array_equal(_regimes(-T, 0.01, 0.1), -labels)  # a falling column heats no more
    # the threshold is relative to the steepest ramps: after a cooling ramp 4x as steep as the heating one
    # (2 against 0.5 degC a sample), soak_fraction 0.5 calls the heating ramp a soak, 0.1 still heating
    T_fast = np.r_[T[:160], np.linspace(45, -35, 42)[1:-1], np.full(60, -35.0)]
    assert np.sum(_regimes(T_fast, 0.01, 0.5) == 1) == 0 and np.sum(_regimes(T_fast, 0.01, 0.5) == -1) >= 38
    assert np.sum(_regimes(T_fast, 0.01, 0.1) == 1) >= 38
    assert np.array_equal(_regimes(np.full(50, 20.0), 0.01, 0.1), np.zeros(50))  # one regime


def test_regime_rmse_holds_each_regime_out_whole():
    """Each regime predicted by the ELM fitted on the samples of the others; none with one regime."""
    rng = np.random.default_rng(0)
    T = oven_profile()
    X = np.column_stack([(T - 25) / 20, rng.uniform(-1, 1, len(T))])
    y = np.sin(2 * X[:, 0]) + rng.normal(0, 0.05, len(T))
    labels = _regimes(T, 0.01, 0.1)
    params = {"n_hidden": 7, "activation": "sigmoid", "weight_scale": 0.6}
    expected = []
    for regime in (-1, 0, 1):  # cooling, soak, heating
        held = labels == regime
        fit = ELM(7, "sigmoid", 0.6, 1e-8, seed=4).fit(X[~held], y[~held])
        expected.append(np.sqrt(np.mean((fit.predict(X[held]) - y[held]) ** 2)))
    np.testing.assert_allclose(_regime_rmse(params, X, y, labels, 1e-8, 4), expected, rtol=1e-12)
    assert _regime_rmse(params, X, y, np.zeros(len(y), dtype=int), 1e-8, 4).shape == (0,)


def test_the_default_level_asks_for_18_of_20_blocks():
    """alpha = 0.1 % (set for a family of 150 decisions, NSGA2ELM Notes rule 3): 18 of 20 blocks pass (p = 2.0e-4),
    17 (p = 1.3e-3) and 16 (p = 5.9e-3, enough at the former 1 %) do not; the regimes all won in each case."""
    alpha = NSGA2ELM().alpha
    assert alpha == 0.001
    plain_blocks, won_all = np.ones(20), np.array([[1.0, 0.5], [0.9, 0.4]])
    verdicts = {
        wins: _significant_everywhere(_sign_test(np.array([plain_blocks, np.r_[np.full(wins, 0.8), np.full(20 - wins, 1.2)]])),
                                      alpha, won_all)
        for wins in (15, 16, 17, 18, 19, 20)
    }
    assert verdicts == {15: False, 16: False, 17: False, 18: True, 19: True, 20: True}


def test_a_candidate_that_loses_one_regime_is_not_taken():
    """Rules 3 and 4 on constructed errors: 18 of 20 blocks (p = 2e-4) is not enough when one regime is lost."""
    plain_blocks = np.ones(20)
    blocks = np.array([plain_blocks, np.r_[np.full(18, 0.8), np.full(2, 1.2)]])
    p = _sign_test(blocks)
    assert p == pytest.approx(211 / 2**20)
    won_all = np.array([[1.0, 0.5, 2.0], [0.9, 0.4, 1.5]])  # cooling, soak, heating
    lost_heating = np.array([[1.0, 0.5, 2.0], [0.9, 0.4, 8.0]])
    tie_soak = np.array([[1.0, 0.5, 2.0], [0.9, 0.5, 1.5]])
    assert _significant_everywhere(p, 0.01, won_all)
    assert not _significant_everywhere(p, 0.01, lost_heating)
    assert not _significant_everywhere(p, 0.01, tie_soak)  # a tie is not a win
    assert _significant_everywhere(p, 0.01, None)  # regime_holdout false: the sign test alone
    assert _significant_everywhere(p, 0.01, np.empty((2, 0)))  # a run with one regime: nothing to hold out
    assert not _significant_everywhere(_sign_test(np.array([plain_blocks, np.r_[np.full(15, 0.8), np.full(5, 1.2)]])), 0.01, won_all)


@pytest.mark.parametrize("noise", [0.02, 0.1, 0.3])
def test_candidate_replaces_the_plain_elm_only_on_a_significant_sign_test(noise):
    """The safe pick by construction (NSGA2ELM Notes, rules 1-4), eight seeds per noise level.

    A small search (pop 10, 4 generations): the rule does not depend on the search
    finding anything good. The plain ELM's validation RMSE and both rows of
    ``cv_rmse_`` are recomputed here from the split, ``ELM()`` and the candidate.
    """
    kept = 0
    for seed in range(8):
        X, y, _ = oven_run(100 + seed, n=300, noise=noise)
        model = NSGA2ELM(pop_size=10, n_gen=4, seed=seed).fit(X, y)
        assert model.plain_rmse_ == pytest.approx(_plain_validation_rmse(model, X, y), rel=1e-9)
        assert model.front_[0]["rmse"] <= model.plain_rmse_ * (1 + 1e-9)  # the plain ELM was in the population
        assert model.candidate_index_ == _pick(model.front_, "knee", model.rmse_tolerance)
        candidate = {k: model.front_[model.candidate_index_][k] for k in ("n_hidden", "activation", "weight_scale")}
        plain = {"n_hidden": 20, "activation": "sigmoid", "weight_scale": 1.0}
        # the plain ELM is ELM() itself (Moore-Penrose); the candidate has the search's ridge
        labels = _regimes(X[:, 0], 0.01, 0.1)
        assert model.regimes_ == ["cooling", "soak"]  # this oven run only cools (10 degC steps) and soaks
        for row, (params, ridge) in enumerate(((plain, 0.0), (candidate, model.ridge))):
            assert np.array_equal(model.cv_rmse_[row], _cv_rmse(params, X, y, 5, ridge, model.elm_seed_))
            assert np.array_equal(model.regime_rmse_[row], _regime_rmse(params, X, y, labels, ridge, model.elm_seed_))
        wins = int(np.sum(model.cv_rmse_[1] < model.cv_rmse_[0]))
        regimes_won = bool(np.all(model.regime_rmse_[1] < model.regime_rmse_[0]))
        est = model.estimator_
        if model.best_index_ is None:
            assert (est.n_hidden, est.activation, est.weight_scale, est.ridge) == (20, "sigmoid", 1.0, 0.0)
            assert wins < 18 or not regimes_won, seed  # 18 of 20 blocks: p = 2.0e-4 < alpha = 0.001 (17: 1.3e-3)
            kept += 1
        else:
            assert model.best_index_ == model.candidate_index_
            assert (est.n_hidden, est.activation, est.weight_scale, est.ridge) == (*candidate.values(), model.ridge)
            assert wins >= 18 and regimes_won, seed
    # the plain ELM is the default: kept on 8 / 7 / 8 of these 8 seeds (noise 0.02 / 0.1 / 0.3) and on
    # 30 / 29 / 30 of seeds 0-29 at alpha 0.1 % (7 / 5 / 6 and 27 / 23 / 23 at the former 1 %); at a keep
    # rate of 0.77, fewer than 3 of 8 has probability 0.3 %
    assert kept >= 3


def test_accept_always_deploys_the_candidate():
    X, y, _ = oven_run(7, n=200)
    model = NSGA2ELM(pop_size=8, n_gen=3, seed=2, accept="always").fit(X, y)
    assert model.best_index_ == model.candidate_index_


def smooth_function(X):
    """An independent smooth drift of the normalised inputs (T', R'): no cubic, no linear rate term."""
    return np.sin(2.5 * X[:, 0]) + 0.5 * np.exp(-((X[:, 0] - 0.3) ** 2) / 0.1) + 0.6 * np.tanh(2 * X[:, 1])


@pytest.mark.parametrize("problem", ["cubic, noise 0.1", "smooth, noise 0.02"])
def test_pick_is_not_worse_than_the_default_elm_on_held_out_runs(problem):
    """Train on one oven run, test on another with a faster chamber, 8 seeds, the configured search.

    A statistic over seeds, not one seed: one seed's front is only as good as the CPU
    that rounds it (issue #20, where the knee came out 4.8x a default ELM). The
    default ELM is ``ELM()`` with the pick's random weights (``ELM(seed=elm_seed_)``),
    trained on the same run: what NSGA2ELM returns when it keeps the plain ELM.
    Pick / default held-out RMSE measured over these 8 seeds (tuning seeds 0-7 of
    benchmarks/nsga2elm_pick.py): cubic drift with noise 0.1, 1.0 on all 8 (the plain
    ELM kept); smooth function with noise 0.02, 0.34-1.0, median 0.57. Over 50 tuning
    seeds the worst is 1.0 on both, over 50 check seeds 1.08 and 1.0, the medians
    1.0 and 0.58-0.72. Bounds: no seed above 1.1 (issue #20's goal), medians at 1.02
    (the plain ELM kept or a better candidate) and 0.8.
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

        model = NSGA2ELM(seed=seed).fit(X, y)
        ratios.append(error(model) / error(ELM(seed=model.elm_seed_).fit(X, y)))
    assert max(ratios) <= 1.1, np.round(ratios, 3)
    # where the search has something to find (smooth), it finds it; where not, it costs nothing
    assert np.median(ratios) < (0.8 if problem.startswith("smooth") else 1.02), np.round(ratios, 3)


def test_a_round_off_change_of_the_inputs_keeps_the_front_and_the_model():
    """Inputs times 1 + 1e-12 u, eight seeds, a small search on the smooth drift (NSGA2ELM Notes, stability).

    Measured with the candidates' ridge of 1e-10: the same front on 8 of 8 seeds,
    predictions moved by at most 8.3e-10 of std(y). With ridge 0 (Moore-Penrose
    candidates) the same check gave the same front on 5 of 8 and moves up to 3.4e-5:
    this test fails there. Bounds: 7 of 8 (one near-tie of two objectives may fall
    either way on another CPU) and 1e-7, 100x the measured move.
    """
    same, moved = 0, []
    for seed in range(8):
        X, y, _ = oven_run(200 + seed, n=300)
        y = smooth_function(X) + np.random.default_rng(seed).normal(0, 0.02, len(X))
        X_moved = X * (1 + 1e-12 * np.random.default_rng(seed).uniform(-1, 1, X.shape))
        a = NSGA2ELM(pop_size=20, n_gen=6, seed=seed).fit(X, y)
        b = NSGA2ELM(pop_size=20, n_gen=6, seed=seed).fit(X_moved, y)
        members = [[(m["n_hidden"], m["activation"], m["weight_scale"]) for m in fit.front_] for fit in (a, b)]
        if members[0] == members[1] and a.best_index_ == b.best_index_:
            same += 1
            moved.append(np.max(np.abs(a.predict(X) - b.predict(X))) / np.std(y))
    assert same >= 7
    assert max(moved) < 1e-7, moved


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
                                           ({"accept": "sometimes"}, "accept"), ({"cv_folds": 1}, "cv_folds"),
                                           ({"alpha": 0.0}, "alpha"), ({"regime_holdout": "yes"}, "regime_holdout"),
                                           ({"temperature_column": 2}, "temperature_column"),
                                           ({"regime_window": 1.5}, "regime_window"),
                                           ({"soak_fraction": -0.1}, "soak_fraction"),
                                           ({"validation_fraction": 0.0}, "validation_fraction")])
def test_invalid_parameters_name_themselves(params, name):
    X, y, _ = oven_run(0, n=50)
    with pytest.raises(ValueError, match=name):
        NSGA2ELM(**params).fit(X, y)
