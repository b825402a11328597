"""The papers' BP comparator: a small multilayer perceptron trained by scikit-learn.

Both papers compare their drift models with a back-propagation (BP)
network ([1] Fig. 17, [2] Fig. 16) without giving its size; the defaults
follow MATLAB's ``feedforwardnet`` (10 tanh hidden nodes, linear output,
a full-batch second-order trainer), here scikit-learn's ``MLPRegressor``
with L-BFGS.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gyrocomp.errors import InputError
from gyrocomp.models._base import (
    Learner,
    check_choice,
    check_float,
    check_int,
    check_seed,
    check_shape,
    check_X_y,
    finite_array,
)

__all__ = ["BPNetwork"]

HIDDEN_ACTIVATIONS = ("tanh", "logistic", "relu", "identity")
SOLVERS = ("lbfgs", "adam", "sgd")


def _hidden_activation(name: str):
    if name == "tanh":
        return np.tanh
    if name == "logistic":
        from scipy.special import expit

        return expit
    if name == "relu":
        return lambda z: np.maximum(z, 0.0)
    return lambda z: z


class BPNetwork(Learner):
    """MLP regressor with input and output standardisation, exact JSON round trip.

    Parameters
    ----------
    hidden_layer_sizes : tuple of int, default=(10,)
        Nodes per hidden layer (MATLAB ``feedforwardnet`` default: one layer of 10).
    activation : {"tanh", "logistic", "relu", "identity"}, default="tanh"
        Hidden activation (``tansig`` in MATLAB is tanh).
    solver : {"lbfgs", "adam", "sgd"}, default="lbfgs"
        scikit-learn trainer; L-BFGS is full-batch like MATLAB's ``trainlm``.
    alpha : float, default=1e-4
        L2 penalty (scikit-learn's default).
    max_iter : int, default=1000
        Iterations of the trainer.
    seed : int or None, default=None
        ``random_state`` of the initial weights.

    Attributes
    ----------
    coefs_ : list of ndarray
        Weight matrices, layer by layer, of the standardised problem.
    intercepts_ : list of ndarray
        Bias vectors, layer by layer.
    x_mean_, x_scale_ : ndarray, shape (n_features,)
        Inputs are standardised as ``(X - x_mean_) / x_scale_``.
    y_mean_, y_scale_ : float
        Outputs are ``y_mean_ + y_scale_ * network``.
    n_iter_ : int
        Iterations the trainer ran.
    n_features_in_ : int

    Notes
    -----
    ``predict`` runs the forward pass with numpy from the stored weights
    (identity output layer, as ``MLPRegressor``), so a model read back from
    JSON predicts bit for bit what the fitted one did; the test suite checks
    it agrees with ``MLPRegressor.predict`` to rounding.

    References
    ----------
    .. [1] H. Cao et al., IEEE Access 9, 95180 (2021).
    .. [2] Z. Zhang et al., Micromachines 15, 609 (2024).
    """

    kind = "bp"
    _fitted = (
        "n_features_in_",
        "coefs_",
        "intercepts_",
        "x_mean_",
        "x_scale_",
        "y_mean_",
        "y_scale_",
        "n_iter_",
    )
    _arrays = frozenset({"x_mean_", "x_scale_"})

    def __init__(
        self,
        hidden_layer_sizes=(10,),
        activation="tanh",
        solver="lbfgs",
        alpha=1e-4,
        max_iter=1000,
        seed=None,
    ):
        self.hidden_layer_sizes = hidden_layer_sizes
        self.activation = activation
        self.solver = solver
        self.alpha = alpha
        self.max_iter = max_iter
        self.seed = seed

    def fit(self, X: Any, y: Any) -> "BPNetwork":
        """Standardise, train ``MLPRegressor``, keep its weights.

        Returns
        -------
        self
        """
        from sklearn.neural_network import MLPRegressor

        X, y = check_X_y(X, y)
        self._check_params()
        x_mean, x_scale = X.mean(axis=0), X.std(axis=0)
        x_scale[x_scale == 0] = 1.0
        y_mean, y_scale = float(y.mean()), float(y.std()) or 1.0
        mlp = MLPRegressor(
            hidden_layer_sizes=tuple(self.hidden_layer_sizes),
            activation=self.activation,
            solver=self.solver,
            alpha=self.alpha,
            max_iter=self.max_iter,
            random_state=self.seed,
        )
        mlp.fit((X - x_mean) / x_scale, (y - y_mean) / y_scale)
        self.coefs_ = [np.array(w, dtype=np.float64) for w in mlp.coefs_]
        self.intercepts_ = [np.array(b, dtype=np.float64) for b in mlp.intercepts_]
        self.x_mean_, self.x_scale_ = x_mean, x_scale
        self.y_mean_, self.y_scale_ = y_mean, y_scale
        self.n_iter_ = int(mlp.n_iter_)
        self.n_features_in_ = X.shape[1]
        return self

    def _forward(self, X: np.ndarray) -> np.ndarray:
        """Forward pass, in the unit of y."""
        g = _hidden_activation(self.activation)
        a = (X - self.x_mean_) / self.x_scale_
        for w, b in zip(self.coefs_[:-1], self.intercepts_[:-1]):
            a = g(a @ w + b)
        out = a @ self.coefs_[-1] + self.intercepts_[-1]
        return self.y_mean_ + self.y_scale_ * out[:, 0]

    def _check_params(self) -> None:
        owner = "BPNetwork"
        sizes = self.hidden_layer_sizes
        if not isinstance(sizes, (tuple, list)) or not sizes:
            raise InputError(f"{owner}: `hidden_layer_sizes` must be a non-empty tuple, got {sizes!r}")
        for size in sizes:
            check_int(owner, "hidden_layer_sizes", size, 1)
        check_choice(owner, "activation", self.activation, HIDDEN_ACTIVATIONS)
        check_choice(owner, "solver", self.solver, SOLVERS)
        check_float(owner, "alpha", self.alpha, 0.0)
        check_int(owner, "max_iter", self.max_iter, 1)
        check_seed(owner, self.seed)

    def _decode_fitted(self, fitted: dict[str, Any]) -> None:
        owner = "BPNetwork"
        super()._decode_fitted(fitted)
        for name, ndim in (("coefs_", 2), ("intercepts_", 1)):
            layers = fitted[name]
            if not isinstance(layers, list):
                raise InputError(f"{owner}: `{name}` must be a list, got {type(layers).__name__}")
            setattr(self, name, [finite_array(owner, f"{name}[{i}]", v, ndim) for i, v in enumerate(layers)])
        self.y_mean_ = check_float(owner, "y_mean_", self.y_mean_, -math.inf)
        self.y_scale_ = check_float(owner, "y_scale_", self.y_scale_, 0.0, low_open=True)
        self.n_iter_ = check_int(owner, "n_iter_", self.n_iter_, 0)

    def _check_loaded(self) -> None:
        owner = "BPNetwork"
        self._check_params()
        n = self.n_features_in_
        sizes = [n, *self.hidden_layer_sizes, 1]
        if len(self.coefs_) != len(sizes) - 1 or len(self.intercepts_) != len(sizes) - 1:
            raise InputError(
                f"{owner}: {len(self.coefs_)} weight and {len(self.intercepts_)} bias layers; "
                f"`hidden_layer_sizes` implies {len(sizes) - 1}"
            )
        for i, (w, b) in enumerate(zip(self.coefs_, self.intercepts_)):
            check_shape(owner, f"coefs_[{i}]", w, (sizes[i], sizes[i + 1]))
            check_shape(owner, f"intercepts_[{i}]", b, (sizes[i + 1],))
        check_shape(owner, "x_mean_", self.x_mean_, (n,))
        check_shape(owner, "x_scale_", self.x_scale_, (n,))
        if np.any(self.x_scale_ <= 0):
            raise InputError(f"{owner}: `x_scale_` must be > 0, got {self.x_scale_.tolist()}")
