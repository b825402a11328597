"""ANFIS: first-order Takagi-Sugeno fuzzy inference trained by Jang's hybrid rule.

The network of Jang [1] (Cao et al. [2] eqs. (21)-(26)) with a grid
partition of the inputs: input j has ``n_mfs[j]`` membership functions and
every combination of one membership function per input is a rule, so
``prod(n_mfs)`` rules (4 x 4 = 16 on the drift output and 2 x 2 = 4 on the
mixed output in [2]). Each epoch of the hybrid learning rule ([1] section
IV, [2] eqs. (27)-(29)) first solves the consequents by least squares with
the premises fixed (forward pass), then moves the premises one step of
gradient descent with the consequents fixed (backward pass).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from gyrocomp.errors import InputError
from gyrocomp.models._base import (
    Learner,
    block_split,
    check_choice,
    check_float,
    check_int,
    check_seed,
    check_shape,
    check_X_y,
    finite_array,
    rmse,
    scaled_columns,
)

__all__ = ["ANFIS"]

MF_SHAPES = ("gbell", "gauss")
"""Membership-function shapes: generalised bell ([1] eq. (18)) and Gaussian."""

_MIN_WIDTH = 1e-6
"""Floor of the gbell width a and the Gaussian sigma, in unit-scaled input."""
_MIN_SLOPE = 1e-2
"""Floor of the gbell slope b (keeps the membership function bell-shaped)."""
_TINY = 1e-300
"""Stands in for |u| = 0 inside the logarithm of the gbell membership and its derivative."""
PREDICT_BLOCK = 1 << 14
"""Rows :func:`_predict` evaluates at once: its arrays of that many rows (128 KiB each) stay in the L2 cache."""
SHIFT_ABOVE = 600.0
"""Smallest exponent s (or q) of an input's largest membership from which nu comes from shifted logarithms."""
FAR_TOTAL = 1e-200
"""A row whose memberships of an input sum below this is checked for the shifted path (> n_mfs exp(-SHIFT_ABOVE))."""
_EXP_ARG = 708.0
"""Exponents are held in +-_EXP_ARG before exp: exp(708) = 3e307 stays finite, so no membership is exactly 0."""


class ANFIS(Learner):
    """Adaptive-network-based fuzzy inference system (first-order Sugeno).

    Parameters
    ----------
    n_mfs : int or tuple of int, default=2
        Membership functions per input (one int for all inputs, or one per
        input). Rules = product over inputs: ``(4, 4)`` gives the 16 rules of
        the drift model of [2], ``(2, 2)`` the 4 of its mixed model.
    mf : {"gbell", "gauss"}, default="gbell"
        Membership shape. ``gbell``: mu = 1 / (1 + |(x - c)/a|^(2b)) with
        premise parameters (a, b, c) ([1] eq. (18)); ``gauss``:
        mu = exp(-(x - c)^2 / (2 sigma^2)) with (c, sigma).
    epochs : int, default=50
        Epochs of hybrid learning (50 in [2] Figs. 14-15).
    step_size : float, default=0.01
        Initial step size k of gradient descent: the premises move by
        eta * grad E with eta = k / ||grad E||_2 ([1] eq. (12)), i.e. a step
        of length k in the space of the premise parameters (of unit-scaled
        inputs).
    step_increase : float, default=1.1
        k is multiplied by this after four error reductions in a row ([1]
        section V, rule 1).
    step_decrease : float, default=0.9
        k is multiplied by this after two consecutive combinations of one
        increase and one reduction of the error, i.e. the last four changes
        were up, down, up, down ([1] section V, rule 2).
    validation_fraction : float, default=0.0
        Share of the samples held out as contiguous blocks (see Notes) to
        compute a validation RMSE each epoch. 0 disables validation.
    ridge : float, default=0.0
        Tikhonov weight lambda of the consequent step (dimensionless): the
        least squares of [2] eq. (28) become
        min (1/n) ||A theta - (y - mean y)||^2 + lambda ||theta||^2, so a
        rule that hardly fires in training keeps consequents near zero
        (its output near the mean target) instead of whatever the least
        squares needs from a column of near-zeros. 0 is Jang's exact
        least-squares estimate.
    seed : int or None, default=None
        Seeds the choice of validation blocks; ANFIS has no other random
        step (the premises start on an even grid).

    Attributes
    ----------
    input_offset_, input_scale_ : ndarray, shape (n_features,)
        The inputs are mapped to ``(X - input_offset_) / input_scale_``,
        i.e. [0, 1] over the training range; all premise and consequent
        parameters are in these unit-scaled inputs.
    premises_ : list of ndarray, one per input, shape (n_mfs[j], 3) or (n_mfs[j], 2)
        Rows are membership functions, columns (a, b, c) for gbell and
        (c, sigma) for gauss.
    consequents_ : ndarray, shape (n_rules, n_features + 1)
        Rule r outputs ``consequents_[r, :-1] @ x + consequents_[r, -1]``
        ([2] eq. (25)). Rules are numbered in C order over the inputs' MFs
        (input 0 varies slowest).
    train_rmse_, val_rmse_ : ndarray, shape (epochs,)
        RMSE after each epoch's least-squares step, in the unit of y
        (``val_rmse_`` is empty without validation).
    step_sizes_ : ndarray, shape (epochs,)
        The step size k used at each epoch.
    best_epoch_ : int
        Epoch (from 0) whose parameters the model keeps: the least validation
        RMSE when validating, else the least training RMSE (as MATLAB's
        ``anfis`` returns the FIS of minimum error).
    n_features_in_ : int

    Notes
    -----
    Input convention for the drift models: column 0 temperature [degC],
    column 1 temperature rate [degC/s]; ANFIS scales its inputs itself, so
    the stored model is self-contained.

    Membership functions start evenly spread over each input's range:
    centres on a uniform grid, widths such that neighbours cross at 0.5
    (a single MF sits mid-range with half-range width), gbell slope b = 2.

    The consequents are solved by ``numpy.linalg.lstsq`` on the
    (n_samples x n_rules * (n_features + 1)) design matrix A of [2] eq. (28),
    the one dense matrix of that size; Jang's sequential LSE gives the same
    solution. With ``ridge > 0`` they solve the regularised normal equations
    (A^T A + n lambda I) theta = A^T (y - mean y) by Cholesky (A^T A is
    parameters x parameters), then add mean y to every rule's constant:
    the normalised strengths sum to 1, so the model output shifts by
    mean y, and the penalty, like scikit-learn's ``Ridge``, leaves the
    overall level of y free. The n in n lambda makes lambda independent of
    the number of samples. The firing strengths are normalised in the log domain, and
    the analytic gradient uses d E / d log mu, so memberships that
    underflow far outside the training range stay finite.

    References
    ----------
    .. [1] J.-S. R. Jang, "ANFIS: Adaptive-network-based fuzzy inference
       system", IEEE Trans. Syst., Man, Cybern. 23(3), 665-685 (1993).
    .. [2] H. Cao et al., "A temperature compensation approach for dual-mass
       MEMS gyroscope based on PE-LCD and ANFIS", IEEE Access 9, 95180 (2021).

    Examples
    --------
    >>> import numpy as np
    >>> X = np.linspace(-1, 1, 200).reshape(-1, 1)
    >>> model = ANFIS(n_mfs=3, epochs=20).fit(X, X[:, 0] ** 3)
    >>> bool(model.train_rmse_[-1] < 1e-2)
    True
    """

    kind = "anfis"
    _fitted = (
        "n_features_in_",
        "input_offset_",
        "input_scale_",
        "premises_",
        "consequents_",
        "train_rmse_",
        "val_rmse_",
        "step_sizes_",
        "best_epoch_",
    )
    _arrays = frozenset(
        {"input_offset_", "input_scale_", "consequents_", "train_rmse_", "val_rmse_", "step_sizes_"}
    )
    _may_be_empty = frozenset({"val_rmse_"})

    def __init__(
        self,
        n_mfs=2,
        mf="gbell",
        epochs=50,
        step_size=0.01,
        step_increase=1.1,
        step_decrease=0.9,
        validation_fraction=0.0,
        ridge=0.0,
        seed=None,
    ):
        self.n_mfs = n_mfs
        self.mf = mf
        self.epochs = epochs
        self.step_size = step_size
        self.step_increase = step_increase
        self.step_decrease = step_decrease
        self.validation_fraction = validation_fraction
        self.ridge = ridge
        self.seed = seed

    @property
    def n_rules_(self) -> int:
        """Number of rules, ``prod(n_mfs)``."""
        self._check_fitted()
        return int(self.consequents_.shape[0])

    def fit(self, X: Any, y: Any) -> "ANFIS":
        """Train by Jang's hybrid rule for ``epochs`` epochs.

        Parameters
        ----------
        X : array_like, shape (n_samples, n_features)
        y : array_like, shape (n_samples,)

        Returns
        -------
        self
        """
        X, y = check_X_y(X, y)
        n_mfs = self._check_params(X.shape[1])
        rng = np.random.default_rng(self.seed)
        offset = X.min(axis=0)
        scale = X.max(axis=0) - offset
        scale[scale == 0] = 1.0
        Z = (X - offset) / scale
        if self.validation_fraction > 0:
            train, val = block_split(len(y), self.validation_fraction, rng)
            Z_val, y_val = Z[val], y[val]
            Z, y = Z[train], y[train]
        premises = [_initial_premises(m, self.mf) for m in n_mfs]
        Za = np.column_stack([Z, np.ones(len(Z))])
        k = float(self.step_size)
        train_hist: list[float] = []
        val_hist: list[float] = []
        steps: list[float] = []
        best = (np.inf, 0, premises, None)
        for epoch in range(self.epochs):
            log_mu = [_log_mu(p, Z[:, j], self.mf) for j, p in enumerate(premises)]
            wbar = _normalised_firing(log_mu)
            design = (wbar[:, :, None] * Za[:, None, :]).reshape(len(Z), -1)
            consequents = _consequents(design, y, wbar.shape[1], self.ridge)
            rule_out = Za @ consequents.T
            f = np.einsum("nr,nr->n", wbar, rule_out)
            train_hist.append(rmse(f, y))
            steps.append(k)
            score = train_hist[-1]
            if self.validation_fraction > 0:
                val_hist.append(rmse(_predict(Z_val, premises, consequents, self.mf), y_val))
                score = val_hist[-1]
            if score < best[0]:
                best = (score, epoch, [p.copy() for p in premises], consequents)
            if epoch == self.epochs - 1:
                break
            grads = _premise_gradients(Z, premises, log_mu, wbar, rule_out, f - y, n_mfs, self.mf)
            norm = np.sqrt(sum(float(np.sum(g**2)) for g in grads))
            if norm > 0:
                premises = [_constrain(p - k * g / norm, self.mf) for p, g in zip(premises, grads)]
            k = _update_step(k, train_hist, self.step_increase, self.step_decrease)
        self.n_features_in_ = X.shape[1]
        self.input_offset_ = offset
        self.input_scale_ = scale
        self.premises_ = best[2]
        self.consequents_ = best[3]
        self.train_rmse_ = np.asarray(train_hist)
        self.val_rmse_ = np.asarray(val_hist, dtype=np.float64)
        self.step_sizes_ = np.asarray(steps)
        self.best_epoch_ = best[1]
        return self

    def _forward(self, X: np.ndarray) -> np.ndarray:
        """Model output for each row of `X`, in the unit of y."""
        Z = scaled_columns(X, self.input_offset_, self.input_scale_)
        return _predict(Z, self.premises_, self.consequents_, self.mf)

    def _check_params(self, n_features: int) -> tuple[int, ...]:
        owner = "ANFIS"
        if isinstance(self.n_mfs, (tuple, list)):
            if len(self.n_mfs) != n_features:
                raise InputError(
                    f"ANFIS: `n_mfs` has {len(self.n_mfs)} entries but X has {n_features} columns"
                )
            n_mfs = tuple(check_int(owner, "n_mfs", m, 1) for m in self.n_mfs)
        else:
            n_mfs = (check_int(owner, "n_mfs", self.n_mfs, 1),) * n_features
        check_choice(owner, "mf", self.mf, MF_SHAPES)
        check_int(owner, "epochs", self.epochs, 1)
        check_float(owner, "step_size", self.step_size, 0.0, low_open=True)
        check_float(owner, "step_increase", self.step_increase, 1.0)
        check_float(owner, "step_decrease", self.step_decrease, 0.0, 1.0, low_open=True)
        check_float(owner, "validation_fraction", self.validation_fraction, 0.0, 0.5)
        check_float(owner, "ridge", self.ridge, 0.0)
        check_seed(owner, self.seed)
        return n_mfs

    def _decode_fitted(self, fitted: dict[str, Any]) -> None:
        super()._decode_fitted(fitted)
        premises = fitted["premises_"]
        if not isinstance(premises, list):
            raise InputError(f"ANFIS: `premises_` must be a list, got {type(premises).__name__}")
        self.premises_ = [finite_array("ANFIS", f"premises_[{j}]", p, ndim=2) for j, p in enumerate(premises)]
        self.best_epoch_ = check_int("ANFIS", "best_epoch_", self.best_epoch_, 0)

    def _check_loaded(self) -> None:
        owner = "ANFIS"
        n = self.n_features_in_
        n_mfs = self._check_params(n)
        width = 3 if self.mf == "gbell" else 2
        if len(self.premises_) != n:
            raise InputError(f"{owner}: `premises_` has {len(self.premises_)} inputs; `n_features_in_` is {n}")
        for j, (p, m) in enumerate(zip(self.premises_, n_mfs)):
            check_shape(owner, f"premises_[{j}]", p, (m, width))
            spread = p[:, 0] if self.mf == "gbell" else p[:, 1]
            if np.any(spread <= 0):
                raise InputError(f"{owner}: `premises_[{j}]` has a membership width <= 0")
        check_shape(owner, "consequents_", self.consequents_, (int(np.prod(n_mfs)), n + 1))
        check_shape(owner, "input_offset_", self.input_offset_, (n,))
        check_shape(owner, "input_scale_", self.input_scale_, (n,))
        if np.any(self.input_scale_ <= 0):
            raise InputError(f"{owner}: `input_scale_` must be > 0, got {self.input_scale_.tolist()}")


def _initial_premises(m: int, mf: str) -> np.ndarray:
    """MFs spread evenly over the unit interval, neighbours crossing at 0.5."""
    if m == 1:
        centres, half = np.array([0.5]), 0.5
    else:
        centres, half = np.linspace(0.0, 1.0, m), 0.5 / (m - 1)
    if mf == "gbell":
        return np.column_stack([np.full(m, half), np.full(m, 2.0), centres])
    sigma = half / np.sqrt(2.0 * np.log(2.0))
    return np.column_stack([centres, np.full(m, sigma)])


def _consequents(design: np.ndarray, y: np.ndarray, n_rules: int, ridge: float) -> np.ndarray:
    """Consequents by least squares ([2] eq. (28)), with the Tikhonov term of :class:`ANFIS` when `ridge` > 0.

    Returns shape (n_rules, n_features + 1); the design matrix has the
    columns wbar_r * (z, 1) rule after rule.
    """
    if ridge == 0:
        return np.linalg.lstsq(design, y, rcond=None)[0].reshape(n_rules, -1)
    level = float(np.mean(y))
    gram = design.T @ design
    gram[np.diag_indices_from(gram)] += len(y) * ridge
    import scipy.linalg  # training only: evaluating a model does without SciPy's import

    theta = scipy.linalg.solve(gram, design.T @ (y - level), assume_a="pos").reshape(n_rules, -1)
    theta[:, -1] += level
    return theta


def _log_mu(p: np.ndarray, x: np.ndarray, mf: str) -> np.ndarray:
    """log of the membership degrees, shape (n_samples, n_mfs)."""
    if mf == "gbell":
        a, b, c = p[:, 0], p[:, 1], p[:, 2]
        s = 2.0 * b * np.log(np.maximum(np.abs((x[:, None] - c) / a), _TINY))
        return -np.logaddexp(0.0, s)
    c, sigma = p[:, 0], p[:, 1]
    return -0.5 * ((x[:, None] - c) / sigma) ** 2


def _dlog_mu(p: np.ndarray, x: np.ndarray, mf: str) -> np.ndarray:
    """d log mu / d premise parameters, shape (n_samples, n_mfs, n_params_per_mf)."""
    if mf == "gbell":
        a, b, c = p[:, 0], p[:, 1], p[:, 2]
        u = (x[:, None] - c) / a
        log_abs = np.log(np.maximum(np.abs(u), _TINY))
        from scipy.special import expit  # training only, as scipy.linalg above

        one_minus_mu = expit(2.0 * b * log_abs)  # |u|^2b / (1 + |u|^2b)
        safe_u = np.where(u == 0, 1.0, u)
        d_a = 2.0 * b * one_minus_mu / a
        d_b = -2.0 * one_minus_mu * log_abs
        d_c = np.where(u == 0, 0.0, 2.0 * b * one_minus_mu / (a * safe_u))
        return np.stack([d_a, d_b, d_c], axis=2)
    c, sigma = p[:, 0], p[:, 1]
    d = x[:, None] - c
    return np.stack([d / sigma**2, d**2 / sigma**3], axis=2)


def _normalised_firing(log_mu: list[np.ndarray]) -> np.ndarray:
    """Normalised rule strengths w_r / sum w ([2] eqs. (23)-(24)), shape (n, n_rules)."""
    n = log_mu[0].shape[0]
    log_w = log_mu[0]
    for lm in log_mu[1:]:
        log_w = (log_w[:, :, None] + lm[:, None, :]).reshape(n, -1)
    log_w = log_w - log_w.max(axis=1, keepdims=True)
    w = np.exp(log_w)
    return w / w.sum(axis=1, keepdims=True)


def _predict(Z: np.ndarray, premises: list[np.ndarray], consequents: np.ndarray, mf: str) -> np.ndarray:
    """sum_r wbar_r (c_r . z + c_r0) for each row of `Z` ([2] eq. (25)), `PREDICT_BLOCK` rows at a time.

    The normalised firing strength of the grid partition factorises ([2]
    eqs. (23)-(24)):

        wbar_r = prod_j mu_j,k_j / sum_r prod_j mu_j,k_j = prod_j nu_j,k_j,
        nu_j,k = mu_j,k / sum_k mu_j,k,

    so each membership function is evaluated once per row (12 for the
    4 x 4 + 2 x 2 rules of PE-LCD-ANFIS, not once per rule) and each input
    normalised over its own functions (:func:`_memberships`); the rules,
    the last input's function varying fastest, are summed in order. The
    same output as ``_normalised_firing`` of ``_log_mu`` and the rule
    outputs, to rounding, without their (n, n_rules) temporaries. Every
    step is element-wise along the rows, so each row gets the same bits
    wherever it falls in `Z` (chunked and one-shot evaluations agree).
    """
    Z = np.asarray(Z, dtype=float)
    n, n_in = Z.shape
    n_mfs = [len(p) for p in premises]
    digits = np.array(np.unravel_index(np.arange(len(consequents)), n_mfs)).T  # rule r's function of each input
    rows = min(n, PREDICT_BLOCK)
    scratch = [np.empty((3, m, rows)) for m in n_mfs]  # each input's exponents, memberships and totals
    wbar, rule, term = np.empty(rows), np.empty(rows), np.empty(rows)
    out = np.empty(n)
    for start in range(0, n, rows):
        z = Z[start : start + rows]
        size = len(z)
        nu = [_memberships(z[:, j], p, mf, scratch[j][..., :size]) for j, p in enumerate(premises)]
        block = out[start : start + size]
        block[:] = 0.0
        w, r, t = wbar[:size], rule[:size], term[:size]
        for digit, c in zip(digits, consequents):
            np.copyto(w, nu[0][digit[0]])
            for j in range(1, n_in):
                w *= nu[j][digit[j]]
            np.multiply(z[:, 0], c[0], out=r)
            r += c[n_in]
            for j in range(1, n_in):
                np.multiply(z[:, j], c[j], out=t)
                r += t
            w *= r
            block += w
    return out


def _memberships(z: np.ndarray, p: np.ndarray, mf: str, scratch: np.ndarray) -> np.ndarray:
    """nu_k = mu_k / sum_k mu_k of one input's membership functions, shape (n_mfs, n_samples), in `scratch`.

    ``gbell``: mu = 1 / (1 + exp(s)), s = 2 b log|u|, u = (z - c) / a
    (|u| held in [`_TINY`, 1 / `_TINY`]); ``gauss``: mu = exp(-q),
    q = u^2 / 2, u = (z - c) / sigma. Where every membership of the input is
    below exp(-`SHIFT_ABOVE`) (an input far outside the training range,
    never after clamping), nu comes from the shifted exponents,
    exp(s_min - s_k), as ``_normalised_firing`` does with its row maximum.
    `scratch` (3, n_mfs, n_samples) holds the exponents, nu and the totals
    (reused from block to block: fresh arrays cost a page fault per 4 KiB).
    """
    gbell = mf == "gbell"
    centre, width = (p[:, 2], p[:, 0]) if gbell else (p[:, 0], p[:, 1])
    exponent, nu, total = scratch[0], scratch[1], scratch[2, 0]
    total[:] = 0.0
    for k, (e, mu) in enumerate(zip(exponent, nu)):
        np.subtract(z, centre[k], out=e)
        e *= 1.0 / width[k]
        if gbell:
            np.abs(e, out=e)
            np.clip(e, _TINY, 1.0 / _TINY, out=e)
            np.log(e, out=e)
            e *= 2.0 * p[k, 1]
            np.clip(e, -_EXP_ARG, _EXP_ARG, out=mu)
            np.exp(mu, out=mu)
            mu += 1.0
            np.divide(1.0, mu, out=mu)
        else:
            np.multiply(e, e, out=e)
            e *= 0.5
            np.clip(e, -_EXP_ARG, _EXP_ARG, out=mu)
            np.negative(mu, out=mu)
            np.exp(mu, out=mu)
        total += mu
    far = np.flatnonzero(total < FAR_TOTAL)
    if far.size:
        smallest = exponent[:, far].min(axis=0)
        far, smallest = far[smallest >= SHIFT_ABOVE], smallest[smallest >= SHIFT_ABOVE]
        shifted = np.exp(np.clip(smallest - exponent[:, far], -_EXP_ARG, _EXP_ARG))
        nu[:, far] = shifted
        total[far] = 0.0
        for row in shifted:
            total[far] += row
    np.divide(1.0, total, out=total)
    nu *= total
    return nu


def _premise_gradients(
    Z: np.ndarray,
    premises: list[np.ndarray],
    log_mu: list[np.ndarray],
    wbar: np.ndarray,
    rule_out: np.ndarray,
    error: np.ndarray,
    n_mfs: tuple[int, ...],
    mf: str,
) -> list[np.ndarray]:
    """dE/d premise parameters for E = sum (f - y)^2 with the consequents fixed.

    d f / d log w_r = wbar_r (z_r - f); log w_r is the sum of the log
    memberships that rule r combines, so dE/d log mu_{j,k} sums
    2 e wbar_r (z_r - f) over the rules that use MF k of input j.
    """
    h = (2.0 * error[:, None] * wbar * (rule_out - (wbar * rule_out).sum(axis=1, keepdims=True)))
    h = h.reshape((len(Z),) + n_mfs)
    grads = []
    for j, p in enumerate(premises):
        axes = tuple(i + 1 for i in range(len(n_mfs)) if i != j)
        d_logmu = h.sum(axis=axes) if axes else h
        grads.append(np.einsum("nm,nmk->mk", d_logmu, _dlog_mu(p, Z[:, j], mf)))
    return grads


def _constrain(p: np.ndarray, mf: str) -> np.ndarray:
    """Keep widths positive and gbell slopes bell-shaped after a step."""
    p = p.copy()
    if mf == "gbell":
        p[:, 0] = np.maximum(np.abs(p[:, 0]), _MIN_WIDTH)
        p[:, 1] = np.maximum(p[:, 1], _MIN_SLOPE)
    else:
        p[:, 1] = np.maximum(np.abs(p[:, 1]), _MIN_WIDTH)
    return p


def _update_step(k: float, history: list[float], increase: float, decrease: float) -> float:
    """Jang's two heuristic rules for the step size ([1] section V)."""
    if len(history) < 5:
        return k
    changes = np.diff(history[-5:])
    if np.all(changes < 0):
        return k * increase
    if (changes > 0).tolist() == [True, False, True, False]:
        return k * decrease
    return k
