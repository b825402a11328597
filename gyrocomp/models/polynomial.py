"""The industry baseline: bias as a cubic in temperature plus a temperature-rate term.

Flight-controller firmware calibrates a gyro's thermal drift with a
polynomial in the sensor temperature about a reference temperature (ArduPilot
and PX4 use a third-order polynomial per axis); the rate term models the
thermal-gradient sensitivity of IEEE Std 1431 (a bias proportional to
dT/dt). It is the comparator every learned model has to beat.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from gyrocomp.errors import InputError
from gyrocomp.models._base import Learner, check_float, check_int, check_shape, check_X_y
from gyrocomp.recordings import PLAUSIBLE_DEGC

__all__ = ["PolynomialDrift"]


class PolynomialDrift(Learner):
    """bias = sum_{k=0}^{degree} c_k (T - T_ref)^k + d * dT/dt, by least squares.

    Parameters
    ----------
    degree : int, default=3
        Highest power of (T - T_ref); 3 as flight-controller thermal calibration.
    reference_temperature : float, default=25.0
        T_ref [degC], the expansion point (room temperature).
    rate_term : bool, default=True
        Include d * dT/dt; needs X column 1.

    Attributes
    ----------
    coef_ : ndarray, shape (degree + 1,)
        c_0 ... c_degree, in [unit of y / degC^k].
    rate_coef_ : float
        d, in [unit of y / (degC/s)]; 0 without the rate term.
    n_features_in_ : int

    Notes
    -----
    X columns: 0 temperature [degC], 1 temperature rate [degC/s] (the
    convention of every drift model here). Unlike the other models this one
    needs physical units, not normalised inputs, because T_ref is in degC.
    The least-squares problem is solved with each column scaled to unit
    peak (the powers of T - T_ref span many decades), then the coefficients
    are scaled back to physical units.

    References
    ----------
    .. [1] IEEE Std 1431-2004, Specification format guide and test procedure
       for Coriolis vibratory gyros (thermal sensitivity terms).

    Examples
    --------
    >>> import numpy as np
    >>> T = np.linspace(-40, 60, 101)
    >>> X = np.column_stack([T, np.zeros_like(T)])
    >>> model = PolynomialDrift(rate_term=False).fit(X, 0.1 + 1e-3 * (T - 25))
    >>> np.round(model.coef_[:2], 6).tolist(), bool(np.abs(model.coef_[2:]).max() < 1e-12)
    ([0.1, 0.001], True)
    """

    kind = "polynomial"
    _fitted = ("n_features_in_", "coef_", "rate_coef_")
    _arrays = frozenset({"coef_"})

    def __init__(self, degree=3, reference_temperature=25.0, rate_term=True):
        self.degree = degree
        self.reference_temperature = reference_temperature
        self.rate_term = rate_term

    def fit(self, X: Any, y: Any) -> "PolynomialDrift":
        """Least-squares coefficients.

        Parameters
        ----------
        X : array_like, shape (n_samples, 1 or 2)
            Temperature [degC] and (with `rate_term`) its rate [degC/s].
        y : array_like, shape (n_samples,)

        Returns
        -------
        self
        """
        X, y = check_X_y(X, y)
        self._check_params(X.shape[1])
        design = self._design(X)
        peak = np.abs(design).max(axis=0)
        peak[peak == 0] = 1.0
        solution = np.linalg.lstsq(design / peak, y, rcond=None)[0] / peak
        self.coef_ = solution[: self.degree + 1]
        self.rate_coef_ = float(solution[self.degree + 1]) if self.rate_term else 0.0
        self.n_features_in_ = X.shape[1]
        return self

    def _forward(self, X: np.ndarray) -> np.ndarray:
        """Bias for each row of `X` (Horner's rule)."""
        dt = X[:, 0] - self.reference_temperature
        out = np.full(len(X), self.coef_[-1])
        for c in self.coef_[-2::-1]:
            out = out * dt + c
        if self.rate_term:
            out = out + self.rate_coef_ * X[:, 1]
        return out

    def _design(self, X: np.ndarray) -> np.ndarray:
        dt = X[:, 0] - self.reference_temperature
        columns = [dt**k for k in range(self.degree + 1)]
        if self.rate_term:
            columns.append(X[:, 1])
        return np.column_stack(columns)

    def _check_loaded(self) -> None:
        owner = "PolynomialDrift"
        self._check_params(self.n_features_in_)
        check_shape(owner, "coef_", self.coef_, (self.degree + 1,))
        self.rate_coef_ = check_float(owner, "rate_coef_", self.rate_coef_, -math.inf)
        if not self.rate_term and self.rate_coef_ != 0.0:
            raise InputError(f"{owner}: `rate_coef_` is {self.rate_coef_} but `rate_term` is false")

    def _check_params(self, n_features: int) -> None:
        owner = "PolynomialDrift"
        check_int(owner, "degree", self.degree, 0, 10)
        check_float(owner, "reference_temperature", self.reference_temperature, *PLAUSIBLE_DEGC)  # a recording's temperatures: 1e300 overflowed the fit
        if not isinstance(self.rate_term, (bool, np.bool_)):
            raise InputError(f"{owner}: `rate_term` must be True or False, got {self.rate_term!r}")
        if self.rate_term and n_features < 2:
            raise InputError(
                f"{owner}: `rate_term` needs X column 1 (temperature rate, degC/s); X has {n_features} column"
            )
