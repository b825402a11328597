"""A model's drift as one polynomial in temperature, in physical units: what firmware loads.

Flight-controller thermal calibration holds, per gyro axis, a polynomial in
``T - T_ref`` [degC] whose value is the rate offset subtracted from the
measurement. gyrocomp's polynomial learner is trained on a normalised
target and, for a learned model, on normalised inputs; this module undoes
both maps exactly and re-expands the result about any reference
temperature, or fits the nearest cubic to a model no polynomial can hold.

``drift(T) = sum_k c_k (T - T_ref)^k`` [deg/s], ``c_k`` in deg/s/degC^k.
"""

from __future__ import annotations

import dataclasses
from math import comb

import numpy as np

from gyrocomp.errors import InputError

__all__ = ["Cubic", "exact_cubic", "nearest_cubic", "reexpand"]


@dataclasses.dataclass(frozen=True)
class Cubic:
    """Drift as a polynomial in temperature over the training range.

    Attributes
    ----------
    reference_c : float
        T_ref [degC].
    coef_dps : tuple of float
        c_0 ... c_degree [deg/s / degC^k].
    temperature_range_c : tuple of float
        Training range (TMIN, TMAX) [degC].
    added_error_deg_h : dict or None
        For a fitted stand-in (:func:`nearest_cubic`): ``rms`` and ``max``
        of stand-in minus model over the training range [deg/h].
    """

    reference_c: float
    coef_dps: tuple
    temperature_range_c: tuple
    added_error_deg_h: dict | None = None

    def __call__(self, temperature_c) -> np.ndarray:
        """drift [deg/s] at `temperature_c` (no clamping)."""
        dt = np.asarray(temperature_c, dtype=float) - self.reference_c
        out = np.zeros_like(dt)
        for c in self.coef_dps[::-1]:
            out = out * dt + c
        return out

    def about(self, reference_c: float) -> "Cubic":
        """The same polynomial expanded about another reference temperature."""
        return dataclasses.replace(self, reference_c=float(reference_c), coef_dps=tuple(reexpand(self.coef_dps, reference_c - self.reference_c)))


def exact_cubic(model, max_degree: int = 3) -> Cubic:
    """The model's drift as a polynomial in temperature, when it is exactly one.

    Parameters
    ----------
    model : gyrocomp.pipeline.compensate.DriftModel
    max_degree : int
        Highest power the target format holds.

    Raises
    ------
    InputError
        One line naming what the format lacks: a learner that is not a
        polynomial, a dT/dt term, a power above `max_degree`, or output
        clipping.
    """
    from gyrocomp.export.plain import plain_model

    total = np.zeros(max_degree + 1)
    reference = None
    for segment in plain_model(model)["segments"]:
        name = segment["name"]
        if segment["learner"] != "polynomial":
            raise InputError(
                f"{model.name}: segment {name} is a {segment['learner']} network; the format holds only a polynomial "
                "in temperature (use --fit-polynomial for the nearest cubic)"
            )
        if segment["rate_coef_dps_per_c_per_s"] != 0.0:
            raise InputError(
                f"{model.name}: segment {name} has a dT/dt term ({segment['rate_coef_dps_per_c_per_s']:.3g} deg/s per degC/s); "
                "the format holds no temperature-rate term (train with --set model.drift.rate_term=false, or use --fit-polynomial)"
            )
        coef = np.asarray(segment["coef_dps"])
        if len(coef) - 1 > max_degree:
            raise InputError(f"{model.name}: segment {name} is of degree {len(coef) - 1}; the format holds up to {max_degree}")
        if reference is None:
            reference = segment["reference_c"]
        coef = reexpand(coef, reference - segment["reference_c"])
        total[: len(coef)] += coef
    if model.clip_output:
        raise InputError(f"{model.name}: clip_output holds the drift inside a range; the format has no output limits (use --fit-polynomial)")
    return Cubic(reference, tuple(float(c) for c in total), model.temperature_range_c)


def nearest_cubic(model, degree: int = 3, n_grid: int = 201) -> Cubic:
    """The least-squares polynomial closest to any model over its training ranges.

    The model is evaluated on a uniform grid of ``n_grid`` temperatures
    across the training temperature range times ``n_grid // 10 + 1``
    temperature rates across the training dT/dt range (clamped inputs, as
    causal compensation evaluates it), and a polynomial in temperature alone
    is fitted to it by least squares about the range's midpoint. The error
    it adds is the stand-in minus the model on that grid.
    """
    (t_lo, t_hi), (r_lo, r_hi) = model.temperature_range_c, model.rate_range_c_per_s
    temperature = np.linspace(t_lo, t_hi, n_grid)
    rates = np.linspace(r_lo, r_hi, n_grid // 10 + 1)
    T, R = np.meshgrid(temperature, rates, indexing="ij")
    X = np.column_stack([T.ravel(), R.ravel()])
    y = np.sum(list(model.predict(X, clamp=True).values()), axis=0)
    reference = 0.5 * (t_lo + t_hi)
    half = max(0.5 * (t_hi - t_lo), 1e-12)
    u = (X[:, 0] - reference) / half
    coef_u = np.polynomial.polynomial.polyfit(u, y, degree)
    coef = coef_u / half ** np.arange(degree + 1)
    cubic = Cubic(reference, tuple(float(c) for c in coef), (t_lo, t_hi))
    error = (cubic(X[:, 0]) - y) * 3600.0
    added = {"rms": float(np.sqrt(np.mean(error**2))), "max": float(np.max(np.abs(error)))}
    return dataclasses.replace(cubic, added_error_deg_h=added)


def reexpand(coef, shift: float) -> np.ndarray:
    """Coefficients about ``T_ref + shift`` of a polynomial given about T_ref.

    ``sum_k c_k (T - T_ref)^k = sum_j b_j (T - T_ref - shift)^j`` with
    ``b_j = sum_{k >= j} C(k, j) shift^(k - j) c_k`` (Taylor expansion).

    Examples
    --------
    >>> reexpand([1.0, 2.0, 3.0], 1.0).tolist()  # 1 + 2x + 3x^2 about x = 1
    [6.0, 8.0, 3.0]
    """
    c = np.asarray(coef, dtype=float)
    if c.ndim != 1:
        raise InputError(f"polynomial coefficients: expected a 1-D list, got shape {c.shape}")
    n = len(c)
    return np.array([sum(comb(k, j) * shift ** (k - j) * c[k] for k in range(j, n)) for j in range(n)])
