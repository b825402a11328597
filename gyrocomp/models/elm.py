"""Extreme learning machine: a random hidden layer and least-squares output weights.

Huang, Zhu and Siew [1]: the hidden layer H = g(X W + b) has random input
weights W and biases b that are never trained; the output weights are the
minimum-norm least-squares solution beta = H^+ y ([1] eqs. (4)-(6); Zhang
et al. [2] eqs. (17)-(20)). Zhang et al. draw W in lambda * [-1, 1] with a
scale lambda in [0, 1] ([2] eq. (24)).
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from gyrocomp.models._base import (
    Learner,
    check_choice,
    check_float,
    check_int,
    check_seed,
    check_shape,
    check_X_y,
)

__all__ = ["ELM", "ACTIVATIONS", "activation"]


def _sigmoid(z: np.ndarray) -> np.ndarray:
    from scipy.special import expit  # on first use: importing scipy.special costs every command a third of a second

    return expit(z)


def _hardlim(z: np.ndarray) -> np.ndarray:
    return (z >= 0).astype(np.float64)


def _tribas(z: np.ndarray) -> np.ndarray:
    return np.maximum(1.0 - np.abs(z), 0.0)


def _radbas(z: np.ndarray) -> np.ndarray:
    return np.exp(-(z**2))


ACTIVATIONS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "sigmoid": _sigmoid,
    "sin": np.sin,
    "hardlim": _hardlim,
    "tribas": _tribas,
    "radbas": _radbas,
}
"""The five activations of [2] section 3.6, named (and defined) as in MATLAB."""


def activation(name: str) -> Callable[[np.ndarray], np.ndarray]:
    """The activation function g called `name`: 1/(1+e^-z), sin z, [z >= 0], max(1-|z|, 0), e^(-z^2)."""
    return ACTIVATIONS[check_choice("ELM", "activation", name, tuple(ACTIVATIONS))]


class ELM(Learner):
    """Single-hidden-layer extreme learning machine for regression.

    Parameters
    ----------
    n_hidden : int, default=20
        Hidden nodes L (20 in the SinC example of [1]).
    activation : {"sigmoid", "sin", "hardlim", "tribas", "radbas"}, default="sigmoid"
        Hidden activation g ([2] section 3.6).
    weight_scale : float, default=1.0
        lambda of [2] eq. (24): input weights and hidden biases are drawn
        uniformly in lambda * [-1, 1]; lambda in [0, 1].
    ridge : float, default=0.0
        Tikhonov term C: beta minimises ||H beta - y||^2 + C ||beta||^2.
        0 gives the Moore-Penrose solution of [1] eq. (6).
    seed : int or None, default=None
        Seeds the random input weights and biases.

    Attributes
    ----------
    input_weights_ : ndarray, shape (n_features, n_hidden)
        W, in lambda * [-1, 1].
    biases_ : ndarray, shape (n_hidden,)
        b, in lambda * [-1, 1].
    beta_ : ndarray, shape (n_hidden,)
        Output weights.
    n_features_in_ : int

    Notes
    -----
    No internal input scaling: lambda only means something on inputs of a
    known range, so feed inputs normalised to about [-1, 1] (the pipeline
    does, and stores that normalisation in model.json). The SinC example
    of [1] uses raw x in [-10, 10].

    Node i draws its weights and bias together (row i of one uniform
    draw), so with one seed the first L nodes of a larger network are the
    L nodes of a smaller one, and changing lambda rescales them: the
    NSGA-II search compares hyper-parameters on common random numbers.

    beta comes from ``numpy.linalg.lstsq`` on H (the minimum-norm solution,
    H^+ y), or with a ridge from the thin SVD of H; H (n_samples x
    n_hidden) is the largest dense matrix formed. Singular values below
    ``max(n_samples, n_hidden) * eps * s_max`` are cut in both.

    References
    ----------
    .. [1] G.-B. Huang, Q.-Y. Zhu, C.-K. Siew, "Extreme learning machine:
       theory and applications", Neurocomputing 70, 489-501 (2006).
    .. [2] Z. Zhang et al., "Temperature compensation for a dual-mass MEMS
       gyroscope based on ICEEMDAN-SE-TFPF and NSGA II-ELM", Micromachines
       15, 609 (2024).

    Examples
    --------
    >>> import numpy as np
    >>> X = np.linspace(-1, 1, 100).reshape(-1, 1)
    >>> model = ELM(n_hidden=10, seed=0).fit(X, X[:, 0] ** 2)
    >>> bool(np.abs(model.predict(X) - X[:, 0] ** 2).max() < 1e-3)
    True
    """

    kind = "elm"
    _fitted = ("n_features_in_", "input_weights_", "biases_", "beta_")
    _arrays = frozenset({"input_weights_", "biases_", "beta_"})

    def __init__(self, n_hidden=20, activation="sigmoid", weight_scale=1.0, ridge=0.0, seed=None):
        self.n_hidden = n_hidden
        self.activation = activation
        self.weight_scale = weight_scale  # lambda in Zhang et al. (2024)
        self.ridge = ridge
        self.seed = seed

    def fit(self, X: Any, y: Any) -> "ELM":
        """Draw the hidden layer and solve the output weights.

        Parameters
        ----------
        X : array_like, shape (n_samples, n_features)
        y : array_like, shape (n_samples,)

        Returns
        -------
        self
        """
        X, y = check_X_y(X, y, min_samples=1)
        self._check_params()
        rng = np.random.default_rng(self.seed)
        draw = self.weight_scale * rng.uniform(-1.0, 1.0, (self.n_hidden, X.shape[1] + 1))
        self.input_weights_ = np.ascontiguousarray(draw[:, :-1].T)
        self.biases_ = draw[:, -1].copy()
        self.beta_ = _output_weights(self._hidden(X), y, float(self.ridge))
        self.n_features_in_ = X.shape[1]
        return self

    def _forward(self, X: np.ndarray) -> np.ndarray:
        """H(X) beta, in the unit of y."""
        return self._hidden(X) @ self.beta_

    @property
    def beta_norm_(self) -> float:
        """||beta||_2, the second objective of [2] eq. (25)."""
        self._check_fitted()
        return float(np.linalg.norm(self.beta_))

    def _hidden(self, X: np.ndarray) -> np.ndarray:
        return activation(self.activation)(X @ self.input_weights_ + self.biases_)

    def _check_loaded(self) -> None:
        self._check_params()
        shapes = {
            "input_weights_": (self.n_features_in_, self.n_hidden),
            "biases_": (self.n_hidden,),
            "beta_": (self.n_hidden,),
        }
        for name, shape in shapes.items():
            check_shape("ELM", name, getattr(self, name), shape)

    def _check_params(self) -> None:
        check_int("ELM", "n_hidden", self.n_hidden, 1)
        activation(self.activation)
        check_float("ELM", "weight_scale", self.weight_scale, 0.0, 1.0)
        check_float("ELM", "ridge", self.ridge, 0.0)
        check_seed("ELM", self.seed)


def _output_weights(H: np.ndarray, y: np.ndarray, ridge: float) -> np.ndarray:
    """beta = H^+ y by ``lstsq``; with a ridge C, V diag(s / (s^2 + C)) U^T y from the thin SVD."""
    if ridge == 0.0:
        return np.linalg.lstsq(H, y, rcond=None)[0]
    U, s, Vt = np.linalg.svd(H, full_matrices=False)
    keep = s > max(H.shape) * np.finfo(np.float64).eps * (s[0] if s.size else 0.0)
    s, U, Vt = s[keep], U[:, keep], Vt[keep]
    return Vt.T @ ((s / (s**2 + ridge)) * (U.T @ y))
