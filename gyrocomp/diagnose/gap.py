"""The scalar sim-to-real gap: one number for drift and Allan-curve mismatch.

For a residual ``r = rate - offset - deterministic model`` and the noise
model ``theta = (N, B, K)`` of the calibrated simulation, the gap is

.. math::

    G = \\sqrt{\\max\\left(0,\\; D^2 + S - E_0\\right)}

* **deterministic part** ``D = ln(s^2 / E_theta[s^2])``: ``s^2`` is the
  sample variance of the ``T_g``-second means of ``r`` (``T_g = 100 s``,
  the residual-drift convention of DESIGN.md "Honest evaluation"),
  corrected by ``(n - 1) / (n - p)`` for the ``p`` block-level coefficients
  fitted on this run; its expectation under ``theta`` is Barnes' bias
  function times the Allan variance of each term,
  ``E[s^2] = N^2 / T_g + B_1(n, 0) (2 ln 2 / pi) B^2 + B_1(n, 1) K^2 T_g / 3``
  with ``B_1(n, 0) = n ln n / (2 (n - 1) ln 2)`` (flicker) and
  ``B_1(n, 1) = n / 2`` (random walk) [1]_. An unmodelled drift makes
  ``D > 0``.
* **stochastic part** ``S``: the mean over octave taus (at least
  `min_windows` windows in the record) of
  ``ln^2(adev_r(tau) / adev_theta(tau))``, with ``adev_r`` the overlapping
  Allan deviation of the residual (:func:`gyrocomp.allan.oadev`) and
  ``adev_theta`` the IEEE Std 952 model of the simulation.
* ``E_0`` is what ``D^2 + S`` is expected to be for a recording that *is*
  the calibrated simulation. A sample variance with ``nu`` degrees of
  freedom is a scaled ``chi^2_nu``, so ``E[ln^2(s^2 / E s^2)] =
  psi'(nu/2) + (psi(nu/2) - ln(nu/2))^2`` (``~ 2 / nu`` for large ``nu``;
  ``psi`` the digamma function); ``ln adev`` has a quarter of it. Under
  white noise ``nu = n - p`` for ``D`` and ``L / tau - 1`` (the
  non-overlapping window count, a conservative one for the overlapping
  estimator) at each ``tau``. Flicker and a random walk put their variance
  in a few slow modes, under a floor that the white part sets: for ``D``
  the moment is averaged over draws of ``sum lambda_j z_j^2`` with the
  eigenvalues ``lambda_j`` of the centred ``T_g`` means' covariance under
  the model (:class:`NoiseBasis`); at each ``tau`` with at most
  :data:`MAX_EDF_WINDOWS` windows ``nu`` is scaled by Satterthwaite's
  ``tr(A)^2 / tr(A^2)`` of the first differences of the ``tau`` means,
  relative to its white value. The 100 s spread of a random walk has about
  three degrees of freedom whatever the length of the run: with the white
  count a perfectly modelled random walk read as a gap of order 1.

``G`` is dimensionless (nepers of ADEV or of block-mean spread): 0 means the
recording is indistinguishable from the simulation within sampling noise,
0.1 a mismatch of about 10 %. The same definition is applied to the fit and
to the holdout recording.

Sampling noise alone gives some ``G > 0``: ``noise_level`` is the 95th
percentile of ``G`` for a recording that *is* the simulation, with ``D``
and the log ratios taken as independent normals of the second moments above and
``D^2 + S`` as a scaled chi-square of the same mean and variance
(Satterthwaite 1946). A gap below it is no evidence of a mismatch; an
effect whose gap stays below it is one the likelihood of the selection can
see and this scalar cannot.

References
----------
.. [1] J. A. Barnes, "Tables of bias functions, B1 and B2, for variances
   based on finite samples of processes with power law spectral
   densities", NBS Technical Note 375 (1969).
.. [2] F. E. Satterthwaite, "An approximate distribution of estimates of
   variance components", Biometrics Bulletin 2(6), 110-114 (1946).
"""

from __future__ import annotations

import numpy as np
from scipy import linalg, special, stats

from gyrocomp import allan
from gyrocomp.allan.ieee952 import FLICKER_AVAR
from gyrocomp.effects.likelihood import NoiseBasis, NoiseModel, block_means, markov_block_covariance

__all__ = ["gap", "barnes_b1", "noise_level", "log_chi2_moment", "effective_dof", "satterthwaite_dof"]

MAX_EDF_WINDOWS = 512
"""Largest covariance the coloured-noise terms of ``E_0`` build (512 x 512): Allan taus with more
windows keep the white count; a longer 100 s spread is judged on fewer, longer means."""


def barnes_b1(n, mu):
    """Barnes' B1 bias function for ``mu = 0`` (flicker) or ``mu = 1`` (random walk) [1]_.

    ``B1(n, mu) = n (1 - n^mu) / (2 (n - 1) (1 - 2^mu))``; its ``mu -> 0``
    limit is ``n ln n / (2 (n - 1) ln 2)``.

    Examples
    --------
    >>> barnes_b1(2, 0), barnes_b1(4, 1)
    (1.0, 2.0)
    """
    n = float(n)
    if mu == 0:
        return float(n * np.log(n) / (2.0 * (n - 1.0) * np.log(2.0)))
    return n * (1.0 - n**mu) / (2.0 * (n - 1.0) * (1.0 - 2.0**mu))


def log_chi2_moment(nu):
    """``E[ln^2(X / nu)]`` for ``X ~ chi^2_nu``: ``psi'(nu/2) + (psi(nu/2) - ln(nu/2))^2``.

    Examples
    --------
    >>> round(float(log_chi2_moment(2.0)), 3), round(float(log_chi2_moment(1000.0)) * 1000.0 / 2.0, 3)
    (1.978, 1.002)
    """
    half = 0.5 * np.asarray(nu, dtype=float)
    return special.polygamma(1, half) + (special.digamma(half) - np.log(half)) ** 2


def effective_dof(form, covariance):
    """Satterthwaite's degrees of freedom ``tr(A)^2 / tr(A^2)`` of ``v' Q v``, ``v ~ N(0, covariance)``, ``A = Q covariance``.

    Parameters
    ----------
    form : ndarray, shape (k, n)
        ``F`` with ``Q = F' F`` (the quadratic form is ``|F v|^2``).
    covariance : ndarray, shape (n, n)

    Examples
    --------
    >>> x = np.eye(5) - 1.0 / 5  # the centred values of 5 white samples: n - 1
    >>> round(effective_dof(x, np.eye(5)), 6)
    4.0
    """
    return satterthwaite_dof(form @ covariance @ form.T)


def satterthwaite_dof(a):
    """Satterthwaite's ``tr(A)^2 / tr(A^2)`` of a quadratic form's symmetric ``A`` (its scale cancels):
    :func:`effective_dof` from ``A = F covariance F'``, or from a covariance already formed.

    Examples
    --------
    >>> satterthwaite_dof(np.eye(3) * 2.5)
    3.0
    """
    return float(np.trace(a) ** 2 / np.sum(a * a))


def noise_level(variances, quantile=0.95):
    """Quantile of ``G`` for a recording that is the simulation (module docstring).

    Parameters
    ----------
    variances : sequence of float
        ``E[D^2]`` (or nothing when ``D`` is not computed), then the second
        moment of each log ratio divided by the number of taus (the
        stochastic part is their mean): the ``E_0`` terms of the module
        docstring.
    quantile : float, default=0.95

    Returns
    -------
    float
        ``sqrt(q - E_0)`` with ``q`` the quantile of the scaled chi-square
        ``a chi2_nu`` whose mean ``E_0 = sum v`` and variance ``2 sum v^2``
        are those of ``sum v_j z_j^2``.

    Examples
    --------
    >>> round(noise_level([2 / 286]), 3)  # D alone, 288 blocks: sqrt((3.84 - 1) var D)
    0.141
    """
    v = np.asarray(variances, dtype=float)
    mean, var = v.sum(), 2.0 * np.sum(v**2)
    if mean <= 0.0:
        return 0.0
    scale, dof = var / (2.0 * mean), 2.0 * mean**2 / var
    return float(np.sqrt(max(0.0, scale * stats.chi2.ppf(quantile, dof) - mean)))


def gap(residual_dps, fs_hz, noise: NoiseModel, n_fitted=1, block_s=100.0, min_windows=16):
    """The gap between a residual and the calibrated simulation's noise.

    Parameters
    ----------
    residual_dps : array_like, shape (n,)
        Rate minus the calibrated deterministic model [deg/s].
    fs_hz : float
        Sample rate [Hz].
    noise : NoiseModel
        The simulation's noise terms.
    n_fitted : int, default=1
        Coefficients fitted on this run (the per-run offset is one).
    block_s : float, default=100.0
        ``T_g`` [s] of the deterministic part.
    min_windows : int, default=16
        Longest tau of the stochastic part: ``L / min_windows``.

    Returns
    -------
    dict
        ``total`` (G), ``deterministic`` (D), ``stochastic`` (S),
        ``noise_floor`` (E_0), ``noise_level`` (:func:`noise_level`: the
        95th percentile of G under no mismatch), and ``timescale``: ``tau_s``, ``adev``,
        ``adev_model``, ``log_ratio`` per octave tau.
    """
    r = np.asarray(residual_dps, dtype=float)
    length_s = r.size / fs_hz
    n_per = max(1, int(round(block_s * fs_hz)))
    means = block_means(r, n_per)
    t_g = n_per / fs_hz
    n = means.size
    variances = []
    if n - n_fitted >= 2:
        s2 = float(np.var(means, ddof=1)) * (n - 1) / (n - n_fitted)
        expected = noise.arw**2 / t_g + _bias_spread(noise, n, t_g) + barnes_b1(n, 1) * noise.rate_random_walk**2 * t_g / 3.0
        d = float(np.log(max(s2, 1e-300) / expected))
        variances.append(_spread_log_moment(noise, n, t_g, n_fitted))
    else:
        d = 0.0
    tau, adev, _ = allan.oadev(r, fs_hz, "octave")
    keep = tau <= length_s / min_windows
    tau, adev = tau[keep], adev[keep]
    model = np.sqrt(noise.avar(tau))
    log_ratio = np.log(np.maximum(adev, 1e-300) / model)
    s = float(np.mean(log_ratio**2)) if tau.size else 0.0
    if tau.size:
        edf = (length_s / tau - 1.0) * np.array([_colored_dof_ratio(noise, length_s, t) for t in tau])
        variances += list(0.25 * log_chi2_moment(edf) / tau.size)
    floor = float(np.sum(variances))
    return {
        "total": float(np.sqrt(max(0.0, d * d + s - floor))),
        "deterministic": d,
        "stochastic": s,
        "noise_floor": floor,
        "noise_level": noise_level(variances),
        "timescale": {"tau_s": tau, "adev": adev, "adev_model": model, "log_ratio": log_ratio},
    }


def _bias_spread(noise: NoiseModel, n, t_g):
    """``E[s^2]`` of `n` contiguous means of `t_g` seconds of the bias-instability term alone.

    Flicker: Barnes' ``B1(n, 0)`` times its Allan variance. The Markov form:
    exactly, from the means' covariance ``c(h)`` at lag ``h`` blocks,
    ``(n c(0) - (n c(0) + 2 sum_h (n - h) c(h)) / n) / (n - 1)``.
    """
    if not noise.bias_correlation_s:
        return barnes_b1(n, 0) * FLICKER_AVAR * noise.bias_instability**2
    lag = np.arange(n, dtype=float)
    c = noise.markov_variance * markov_block_covariance(lag, t_g, noise.bias_correlation_s)
    total = n * c[0] + 2.0 * float(np.sum((n - lag[1:]) * c[1:]))
    return (n * c[0] - total / n) / (n - 1)


def _spread_log_moment(noise: NoiseModel, n, t_g, n_fitted, draws=2000, seed=0):
    """``E[D^2]`` for a recording that is the simulation: ``D = ln(s^2 / E s^2)`` of `n` means of `t_g` seconds.

    White noise alone makes ``s^2`` a scaled ``chi^2_{n - p}``
    (:func:`log_chi2_moment`). With flicker or a random walk ``s^2`` is
    ``sum lambda_j z_j^2 / (n - 1)`` over the eigenvalues ``lambda_j`` of
    the centred means' covariance: a few slow modes carry most of it, the
    white part sets a floor under it (so no ``chi^2`` of Satterthwaite's
    degrees of freedom has its log moments); the moment is averaged over
    `draws` normal vectors from ``numpy.random.default_rng(seed)``. Up to
    :data:`MAX_EDF_WINDOWS` means exactly; a longer record is judged on fewer,
    longer means (more weight to the coloured terms: an upper bound). The
    coefficients fitted beyond the offset are counted in the white case only
    (a polynomial in temperature takes a little of a random walk's slowest
    modes, which this moment then slightly overstates).
    """
    if not (noise.bias_instability or noise.rate_random_walk):
        return float(log_chi2_moment(n - n_fitted))
    merge = -(-n // MAX_EDF_WINDOWS)
    k = n // merge
    centre = np.eye(k) - 1.0 / k
    lam = np.clip(linalg.eigvalsh(centre @ NoiseBasis(k, t_g * merge).covariance(noise) @ centre), 0.0, None)
    z = np.random.default_rng(seed).standard_normal((draws, k))
    return float(np.mean(np.log((z * z) @ lam / lam.sum()) ** 2))


def _colored_dof_ratio(noise: NoiseModel, length_s, tau_s):
    """Degrees of freedom of the Allan variance at `tau_s` under `noise`, relative to white noise alone.

    Both from the non-overlapping estimator (first differences of the
    ``tau`` means); 1 for white noise alone and where the record holds more
    than :data:`MAX_EDF_WINDOWS` windows.
    """
    m = int(length_s // tau_s)
    if not (noise.bias_instability or noise.rate_random_walk) or m > MAX_EDF_WINDOWS or m < 3:
        return 1.0
    diff = np.diff(np.eye(m), axis=0)
    basis = NoiseBasis(m, tau_s)
    return effective_dof(diff, basis.covariance(noise)) / effective_dof(diff, basis.white)
