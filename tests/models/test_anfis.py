"""ANFIS against Jang (1993): Mackey-Glass prediction, analytic gradients, step-size rules."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from gyrocomp.models import ANFIS
from gyrocomp.models import anfis as anfis_module


def mackey_glass(n_t: int = 1124, tau: float = 17.0, dt: float = 0.1, x0: float = 1.2) -> np.ndarray:
    """x(t) at integer t of dx/dt = 0.2 x(t-tau)/(1 + x(t-tau)^10) - 0.1 x(t).

    RK4 with step 0.1 and x(t) = 0 for t < 0, the delayed value held over a
    step (MathWorks "Predict Chaotic Time-Series using ANFIS"; REFERENCES.md 2.3).
    """
    lag, steps = int(round(tau / dt)), int(round(n_t / dt))
    x = np.zeros(steps + 1)
    x[0] = x0

    def f(xt: float, xl: float) -> float:
        return 0.2 * xl / (1.0 + xl**10) - 0.1 * xt

    for i in range(steps):
        xl = x[i - lag] if i >= lag else 0.0
        k1 = f(x[i], xl)
        k2 = f(x[i] + dt / 2 * k1, xl)
        k3 = f(x[i] + dt / 2 * k2, xl)
        k4 = f(x[i] + dt * k3, xl)
        x[i + 1] = x[i] + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x[:: int(round(1 / dt))]


@pytest.fixture(scope="module")
def mg_pairs():
    """Inputs x(t-18), x(t-12), x(t-6), x(t); target x(t+6); t = 118..1117 (Jang 1993)."""
    x = mackey_glass()
    t = np.arange(118, 1118)
    X = np.column_stack([x[t - 18], x[t - 12], x[t - 6], x[t]])
    return X[:500], x[t + 6][:500], X[500:], x[t + 6][500:]


def _check_rmse(model, X, y):
    return float(np.sqrt(np.mean((model.predict(X) - y) ** 2)))


def test_mackey_glass_16_rules_104_parameters(mg_pairs):
    """Jang (1993): 2 gbell MFs per input, 16 rules, 104 parameters; checking RMSE <= 0.005.

    The paper reports about 0.0015 after 500 epochs; 10 epochs reach ~0.0023 here.
    Hybrid learning has no random step (no seed); the bound is 2x the measured value.
    """
    X, y, X_test, y_test = mg_pairs
    model = ANFIS(n_mfs=2, mf="gbell", epochs=10, step_size=0.1).fit(X, y)
    n_premise = sum(p.size for p in model.premises_)
    assert (model.n_rules_, n_premise, model.consequents_.size) == (16, 24, 80)
    assert _check_rmse(model, X_test, y_test) <= 0.005


@pytest.mark.slow
def test_mackey_glass_500_epochs(mg_pairs):
    """500 epochs as Jang (1993): training ~0.0014 (paper 0.0016), checking ~0.0021 (paper 0.0015)."""
    X, y, X_test, y_test = mg_pairs
    model = ANFIS(n_mfs=2, epochs=500, step_size=0.1).fit(X, y)
    assert model.train_rmse_.min() <= 0.0016
    assert _check_rmse(model, X_test, y_test) <= 0.0025


@pytest.mark.parametrize("mf", ["gbell", "gauss"])
def test_premise_gradient_matches_finite_differences(mf):
    """The analytic dE/d(premise) equals central differences of E = sum (f - y)^2."""
    rng = np.random.default_rng(3)
    Z = rng.uniform(0, 1, (60, 2))
    y = np.sin(3 * Z[:, 0]) + Z[:, 1] ** 2
    n_mfs = (3, 2)
    premises = [anfis_module._initial_premises(m, mf) + rng.normal(0, 0.02, (m, 3 if mf == "gbell" else 2))
                for m in n_mfs]
    consequents = rng.normal(size=(6, 3))

    def energy(ps):
        return float(np.sum((anfis_module._predict(Z, ps, consequents, mf) - y) ** 2))

    log_mu = [anfis_module._log_mu(p, Z[:, j], mf) for j, p in enumerate(premises)]
    wbar = anfis_module._normalised_firing(log_mu)
    Za = np.column_stack([Z, np.ones(len(Z))])
    rule_out = Za @ consequents.T
    f = np.einsum("nr,nr->n", wbar, rule_out)
    grads = anfis_module._premise_gradients(Z, premises, log_mu, wbar, rule_out, f - y, n_mfs, mf)
    h = 1e-6
    for j, p in enumerate(premises):
        numeric = np.zeros_like(p)
        for idx in np.ndindex(p.shape):
            plus = [q.copy() for q in premises]
            minus = [q.copy() for q in premises]
            plus[j][idx] += h
            minus[j][idx] -= h
            numeric[idx] = (energy(plus) - energy(minus)) / (2 * h)
        assert_allclose(grads[j], numeric, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("mf", ["gbell", "gauss"])
def test_forward_is_the_rule_grid_of_the_paper(mf):
    """_predict against [2] eqs. (18), (23)-(25) written out rule by rule, 3 inputs with 3 x 2 x 4 MFs.

    Inside the unit box against the plain products mu_1 mu_2 mu_3 / sum (1e-12);
    far outside (memberships below 1e-300, where the plain products underflow)
    against the log-domain NumPy path of training.
    """
    rng = np.random.default_rng(7)
    n_mfs = (3, 2, 4)
    premises = [anfis_module._initial_premises(m, mf) + rng.normal(0, 0.02, (m, 3 if mf == "gbell" else 2)) for m in n_mfs]
    consequents = rng.normal(size=(24, 4))

    def mu(p, x):
        if mf == "gbell":
            return 1.0 / (1.0 + np.abs((x - p[2]) / p[0]) ** (2 * p[1]))
        return np.exp(-((x - p[0]) ** 2) / (2 * p[1] ** 2))

    Z = rng.uniform(-0.5, 1.5, (200, 3))
    expected = []
    for z in Z:
        w, f = [], []
        for a in range(3):
            for b in range(2):
                for c in range(4):
                    w.append(mu(premises[0][a], z[0]) * mu(premises[1][b], z[1]) * mu(premises[2][c], z[2]))
                    f.append(consequents[len(f)] @ np.append(z, 1.0))
        expected.append(np.dot(w, f) / np.sum(w))
    assert_allclose(anfis_module._predict(Z, premises, consequents, mf), expected, rtol=1e-12, atol=1e-14)
    beyond = rng.uniform(-1e100, 1e100, 200) if mf == "gbell" else rng.uniform(9.0, 11.0, 200)  # every mu of input 1 < exp(-600)
    far = np.column_stack([beyond, rng.uniform(0, 1, 200), rng.uniform(-3.0, 3.0, 200)])
    wbar = anfis_module._normalised_firing([anfis_module._log_mu(p, far[:, j], mf) for j, p in enumerate(premises)])
    numpy_path = np.einsum("nr,nr->n", wbar, far @ consequents[:, :-1].T + consequents[:, -1])
    got = anfis_module._predict(far, premises, consequents, mf)
    assert np.isfinite(got).all()
    assert_allclose(got, numpy_path, rtol=1e-12, atol=1e-12 * np.max(np.abs(numpy_path)))


@pytest.mark.parametrize("mf", ["gbell", "gauss"])
def test_forward_equals_the_log_domain_path_on_random_inputs(mf):
    """_predict (memberships per input, the rules summed input by input) against the log-domain NumPy path of training, 4 x 4 and 2 x 3 x 2 MFs.

    Random premises around the initial grid, random consequents, inputs
    over [-1, 2] (inside and well outside the unit box): equal to 1e-12 of
    the output's scale (the output crosses zero, so not of each value).
    """
    rng = np.random.default_rng(19)
    for n_mfs in ((4, 4), (2, 3, 2)):
        width = 3 if mf == "gbell" else 2
        premises = [anfis_module._initial_premises(m, mf) * rng.uniform(0.8, 1.25, (m, width)) for m in n_mfs]
        consequents = rng.normal(size=(int(np.prod(n_mfs)), len(n_mfs) + 1))
        Z = rng.uniform(-1.0, 2.0, (5000, len(n_mfs)))
        wbar = anfis_module._normalised_firing([anfis_module._log_mu(p, Z[:, j], mf) for j, p in enumerate(premises)])
        numpy_path = np.einsum("nr,nr->n", wbar, Z @ consequents[:, :-1].T + consequents[:, -1])
        got = anfis_module._predict(Z, premises, consequents, mf)
        assert_allclose(got, numpy_path, rtol=0, atol=1e-12 * np.max(np.abs(numpy_path)))


def test_forward_gives_each_row_the_same_bits_wherever_it_falls(monkeypatch):
    """A row's output does not depend on the rows around it: block edges (blocks of 256 rows here), offsets and order agree bit for bit."""
    monkeypatch.setattr(anfis_module, "PREDICT_BLOCK", 256)
    rng = np.random.default_rng(3)
    premises = [anfis_module._initial_premises(m, "gbell") + rng.normal(0, 0.02, (m, 3)) for m in (4, 2)]
    consequents = rng.normal(size=(8, 3))
    Z = rng.uniform(-0.2, 1.2, (1000, 2))
    whole = anfis_module._predict(Z, premises, consequents, "gbell")
    for start in (1, 2, 3, 255, 257):
        part = anfis_module._predict(Z[start:], premises, consequents, "gbell")
        np.testing.assert_array_equal(part, whole[start:])
    for start, size in ((0, 1), (5, 2), (999, 1), (700, 3)):  # blocks of a few rows
        np.testing.assert_array_equal(anfis_module._predict(Z[start : start + size], premises, consequents, "gbell"), whole[start : start + size])
    np.testing.assert_array_equal(anfis_module._predict(Z[::-1], premises, consequents, "gbell"), whole[::-1])
    np.testing.assert_array_equal(anfis_module._predict(np.asfortranarray(Z), premises, consequents, "gbell"), whole)


def test_forward_equals_the_compiled_kernel_it_replaced():
    """The outputs of the numba kernel of 7aa942e (fdlibm exp and log, rule by rule) on the PE-LCD-ANFIS drift premises: to 1e-12 of the scale.

    Premises and consequents of ``benchmarks/_data/model_pe-lcd-anfis.json``'s
    drift segment (rounded to 4 digits), inputs on a grid over the unit box
    and beyond it; the expected values were printed by that kernel.
    """
    premises = [
        np.array([[0.2547, 1.9993, 0.0346], [0.1561, 2.0212, 0.2480], [0.1825, 2.0123, 0.7462], [0.2961, 1.9907, 0.9556]]),
        np.array([[0.1667, 2.0, 0.0], [0.1667, 2.0, 0.3333], [0.1667, 2.0, 0.6667], [0.1667, 2.0, 1.0]]),
    ]
    consequents = np.linspace(-2.0, 2.0, 48).reshape(16, 3) ** 3
    Z = np.array([[-0.5, -0.5], [0.0, 0.0], [0.1, 0.9], [0.37, 0.52], [0.5, 0.5], [0.99, 0.01], [1.0, 1.0], [1.7, -0.3], [40.0, -25.0]])
    expected = [
        1.2473032423040988, -5.264921020455645, -1.9366301854558394, -1.1168318485931823, 1.0808124236570487,
        2.576325723862507, 17.345628831362248, 3.0948802163243387, -1.8718774423132274,
    ]
    got = anfis_module._predict(Z, premises, consequents, "gbell")
    assert_allclose(got, expected, rtol=0, atol=1e-12 * np.max(np.abs(expected)))


def test_jang_step_size_rules():
    """+10 % after four reductions in a row, -10 % after up-down-up-down, else unchanged."""
    update = anfis_module._update_step
    assert update(1.0, [5, 4, 3, 2, 1], 1.1, 0.9) == pytest.approx(1.1)
    assert update(1.0, [1, 2, 1, 2, 1], 1.1, 0.9) == pytest.approx(0.9)
    assert update(1.0, [2, 1, 2, 1, 2], 1.1, 0.9) == 1.0
    assert update(1.0, [4, 3, 2, 1], 1.1, 0.9) == 1.0


def test_initial_mfs_spread_over_range_and_cross_at_half():
    X = np.column_stack([np.linspace(-40, 60, 50), np.linspace(-0.02, 0.03, 50)])
    for mf in ("gbell", "gauss"):
        model = ANFIS(n_mfs=(4, 3), mf=mf, epochs=1).fit(X, X[:, 0])
        for j, m in enumerate((4, 3)):
            p = model.premises_[j]
            centres = p[:, 2] if mf == "gbell" else p[:, 0]
            assert_allclose(centres, np.linspace(0, 1, m))
            mid = np.array([(centres[0] + centres[1]) / 2])
            assert_allclose(np.exp(anfis_module._log_mu(p, mid, mf))[0, :2], [0.5, 0.5])


def test_validation_history_and_best_epoch():
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (400, 2))
    y = np.sin(2 * X[:, 0]) * X[:, 1] + rng.normal(0, 0.05, 400)
    model = ANFIS(n_mfs=3, epochs=15, validation_fraction=0.2, seed=1).fit(X, y)
    assert model.train_rmse_.shape == model.val_rmse_.shape == model.step_sizes_.shape == (15,)
    assert model.best_epoch_ == int(np.argmin(model.val_rmse_))
    plain = ANFIS(n_mfs=3, epochs=15).fit(X, y)
    assert plain.val_rmse_.size == 0 and plain.best_epoch_ == int(np.argmin(plain.train_rmse_))


def test_predict_far_outside_training_range_is_finite():
    X = np.linspace(0, 1, 100).reshape(-1, 1)
    for mf in ("gbell", "gauss"):
        model = ANFIS(n_mfs=3, mf=mf, epochs=5).fit(X, X[:, 0] ** 2)
        assert np.all(np.isfinite(model.predict(np.array([[-1e6], [1e6]]))))


def test_n_mfs_length_must_match_columns():
    with pytest.raises(ValueError, match="n_mfs"):
        ANFIS(n_mfs=(2, 2, 2)).fit(np.zeros((10, 2)) + np.arange(10)[:, None], np.arange(10.0))


def _cooling_band(n=600, seed=0):
    """Inputs on a band (rate rises with temperature): the (cold, heating) corner never fires in training."""
    rng = np.random.default_rng(seed)
    t = rng.uniform(0, 1, n)
    rate = 0.2 * t + rng.normal(0, 0.02, n)
    X = np.column_stack([t, rate])
    y = np.sin(3 * t) + 0.5 * rate + rng.normal(0, 0.01, n)
    return X, y


def _design(model, X):
    """Normalised strengths and design matrix of eq. (28) with the premises at their start."""
    Z = (X - model.input_offset_) / model.input_scale_
    init = [anfis_module._initial_premises(len(p), model.mf) for p in model.premises_]
    wbar = anfis_module._normalised_firing([anfis_module._log_mu(p, Z[:, j], model.mf) for j, p in enumerate(init)])
    Za = np.column_stack([Z, np.ones(len(Z))])
    return wbar, (wbar[:, :, None] * Za[:, None, :]).reshape(len(Z), -1)


def test_ridge_zero_is_jangs_least_squares():
    """One epoch (premises at their start): ridge = 0 is exactly numpy's lstsq on the design of eq. (28)."""
    X, y = _cooling_band()
    model = ANFIS(n_mfs=2, epochs=1, ridge=0.0).fit(X, y)
    _, design = _design(model, X)
    assert np.array_equal(model.consequents_, np.linalg.lstsq(design, y, rcond=None)[0].reshape(4, 3))
    tiny = ANFIS(n_mfs=2, epochs=1, ridge=1e-12).fit(X, y)
    assert_allclose(tiny.predict(X), model.predict(X), atol=1e-6)


def test_ridge_equals_augmented_least_squares():
    """The normal equations agree with the augmented system [A; sqrt(n lambda) I] theta = [y - mean y; 0]."""
    X, y = _cooling_band()
    lam = 1e-3
    model = ANFIS(n_mfs=2, epochs=1, ridge=lam).fit(X, y)
    _, design = _design(model, X)
    p = design.shape[1]
    A = np.vstack([design, np.sqrt(len(y) * lam) * np.eye(p)])
    theta = np.linalg.lstsq(A, np.concatenate([y - y.mean(), np.zeros(p)]), rcond=None)[0].reshape(4, 3)
    theta[:, -1] += y.mean()
    assert_allclose(model.consequents_, theta, rtol=1e-8, atol=1e-10)


def test_ridge_shrinks_the_consequents_of_a_barely_firing_rule():
    """3 x 3 rules on a band of inputs: rule (cold, heating) carries 0.5 % of the strength.

    Plain least squares gives it consequents of norm ~100 and predicts -40 at
    that corner for a target in [-0.1, 1.1]; a small ridge pulls its output
    to the mean target at almost no cost in training error.
    """
    X, y = _cooling_band()
    plain = ANFIS(n_mfs=3, epochs=1).fit(X, y)
    ridged = ANFIS(n_mfs=3, epochs=1, ridge=1e-6).fit(X, y)
    wbar, _ = _design(plain, X)
    share = wbar.mean(axis=0)
    rare = int(np.argmin(share))
    assert rare == 2 and share[rare] < 0.01  # input 0 MF 0 (cold), input 1 MF 2 (heating)
    assert np.linalg.norm(ridged.consequents_[rare]) < 0.02 * np.linalg.norm(plain.consequents_[rare])
    corner = np.array([[X[:, 0].min(), X[:, 1].max()]])
    assert abs(plain.predict(corner)[0]) > 10
    assert abs(ridged.predict(corner)[0] - y.mean()) < 0.5
    assert ridged.train_rmse_[0] < 1.1 * plain.train_rmse_[0]


def test_ridge_must_be_non_negative():
    with pytest.raises(ValueError, match="ridge"):
        ANFIS(ridge=-1.0).fit(*_cooling_band(50))
