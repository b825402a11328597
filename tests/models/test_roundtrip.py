"""The estimator contract of every model: JSON round trip, defaults = configs/models.toml, errors."""

from __future__ import annotations

import inspect
import json
import tomllib

import numpy as np
import pytest

import gyrocomp.models as models
from gyrocomp.config import CONFIG_DIR
from gyrocomp.errors import InputError
from gyrocomp.models import ANFIS, ELM, NSGA2ELM, BPNetwork, NotFittedError, PolynomialDrift

pytestmark = pytest.mark.filterwarnings("ignore:lbfgs failed to converge")

rng = np.random.default_rng(0)
T = rng.uniform(-40, 60, 300)
RATE = rng.uniform(-0.05, 0.05, 300)
X_PHYS = np.column_stack([T, RATE])
X_NORM = np.column_stack([(T - 10) / 50, RATE / 0.05])
Y = 0.01 * (T - 25) + 2e-4 * (T - 25) ** 2 + 1.5 * RATE + rng.normal(0, 0.01, 300)

CASES = [
    (ANFIS(n_mfs=(4, 3), epochs=5, validation_fraction=0.2, seed=1), X_NORM),
    (ANFIS(n_mfs=2, mf="gauss", epochs=5), X_PHYS),
    (ANFIS(n_mfs=3, epochs=5, ridge=1e-3), X_PHYS),
    (ELM(n_hidden=12, activation="radbas", weight_scale=0.5, seed=2), X_NORM),
    (ELM(n_hidden=7, ridge=0.1, seed=3), X_NORM),
    (NSGA2ELM(pop_size=6, n_gen=2, seed=4), X_NORM),
    (BPNetwork(hidden_layer_sizes=(6, 3), max_iter=200, seed=5), X_PHYS),
    (PolynomialDrift(), X_PHYS),
    (PolynomialDrift(degree=2, rate_term=False), X_PHYS),
]
IDS = [f"{type(m).__name__}-{i}" for i, (m, _) in enumerate(CASES)]


@pytest.mark.parametrize("model, X", CASES, ids=IDS)
def test_json_round_trip_predicts_identically(model, X):
    model.fit(X, Y)
    text = json.dumps(model.to_dict(), allow_nan=False)
    again = models.from_dict(json.loads(text))
    assert type(again) is type(model)
    assert again.get_params() == model.get_params()
    assert np.array_equal(again.predict(X), model.predict(X))
    assert json.dumps(again.to_dict(), allow_nan=False) == text


@pytest.mark.parametrize("model, X", CASES, ids=IDS)
def test_same_seed_same_predictions(model, X):
    # Both fits run in this process: exact within one machine and one process type.
    a = type(model)(**model.get_params()).fit(X, Y)
    b = type(model)(**model.get_params()).fit(X, Y)
    assert np.array_equal(a.predict(X), b.predict(X))


@pytest.mark.parametrize("cls", list(models.KINDS.values()))
def test_unfitted_model_refuses_to_predict_and_round_trips(cls):
    model = cls()
    with pytest.raises(NotFittedError, match="not fitted"):
        model.predict(X_PHYS)
    d = json.loads(json.dumps(model.to_dict()))
    assert d["fitted"] is None and d["kind"] == cls.kind
    assert models.from_dict(d).get_params() == model.get_params()


@pytest.mark.parametrize("cls", list(models.KINDS.values()))
def test_init_stores_arguments_unchanged_and_set_params(cls):
    params = cls().get_params()
    assert list(params) == [p for p in inspect.signature(cls.__init__).parameters if p != "self"]
    sentinel = object()
    model = cls(**{next(iter(params)): sentinel})
    assert next(iter(model.get_params().values())) is sentinel
    with pytest.raises(ValueError, match="unknown parameter"):
        cls().set_params(no_such_thing=1)


@pytest.mark.parametrize("kind", list(models.KINDS))
def test_defaults_equal_configs_models_toml(kind):
    """Signature defaults = the shipped TOML table (seed, None by default, is not in TOML)."""
    with open(CONFIG_DIR / "models.toml", "rb") as fh:
        table = tomllib.load(fh)[kind]
    defaults = {k: v for k, v in models.KINDS[kind]().get_params().items() if k != "seed"}
    as_toml = {k: list(v) if isinstance(v, tuple) else v for k, v in defaults.items()}
    assert as_toml == table


def test_paper_presets_build_16_and_4_rule_models():
    with open(CONFIG_DIR / "models.toml", "rb") as fh:
        cfg = tomllib.load(fh)
    for preset, rules in (("anfis_drift", 16), ("anfis_mixed", 4)):
        model = models.make_model("anfis", {**cfg["anfis"], **cfg[preset]}).fit(X_NORM, Y)
        assert model.n_rules_ == rules


def test_make_model_and_from_dict_refuse_unknowns():
    with pytest.raises(InputError, match="unknown model kind"):
        models.make_model("svm")
    with pytest.raises(InputError, match="n_hiden"):
        models.make_model("elm", {"n_hiden": 3}, source="configs/x.toml [model]")
    with pytest.raises(InputError, match="kind"):
        models.from_dict({"kind": "pickle"})
    with pytest.raises(InputError, match="version"):
        ELM.from_dict({"kind": "elm", "version": 99, "params": {}, "fitted": None})


def test_predict_checks_columns_and_finiteness():
    model = ELM(seed=0).fit(X_NORM, Y)
    with pytest.raises(ValueError, match="columns"):
        model.predict(X_NORM[:, :1])
    bad = X_NORM.copy()
    bad[7, 1] = np.nan
    with pytest.raises(ValueError, match="row 7 column 1"):
        model.predict(bad)
    with pytest.raises(ValueError, match="2-D"):
        model.fit(T, Y)


def test_sklearn_clone_works():
    from sklearn.base import clone

    model = ANFIS(n_mfs=(3, 2), epochs=4)
    assert clone(model).get_params() == model.get_params()


def test_from_dict_reads_older_layouts_only_where_they_did_not_change():
    """Layouts 1 and 2 of an ELM still load; NSGA-II-ELM's 1 (``min_gain``) and 2 (no regime check) ask for retraining."""
    elm = ELM(n_hidden=5, seed=0).fit(X_NORM, Y)
    d = json.loads(json.dumps(elm.to_dict()))
    for version in (1, 2):
        d["version"] = version
        np.testing.assert_array_equal(ELM.from_dict(d).predict(X_NORM), elm.predict(X_NORM))
    for version, params in ((1, {"min_gain": 0.1}), (2, {"accept": "sign_test"})):
        old = {"kind": "nsga2elm", "version": version, "params": params, "fitted": None}
        with pytest.raises(InputError, match=r"older gyrocomp.*train the model again"):
            NSGA2ELM.from_dict(old)
