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
  the calibrated simulation: ``var D = 2 / (n - p)`` and
  ``var ln adev = 1 / (2 edf)`` with ``edf = L / tau - 1`` non-overlapping
  windows (a conservative count for the overlapping estimator).

``G`` is dimensionless (nepers of ADEV or of block-mean spread): 0 means the
recording is indistinguishable from the simulation within sampling noise,
0.1 a mismatch of about 10 %. The same definition is applied to the fit and
to the holdout recording.

References
----------
.. [1] J. A. Barnes, "Tables of bias functions, B1 and B2, for variances
   based on finite samples of processes with power law spectral
   densities", NBS Technical Note 375 (1969).
"""

from __future__ import annotations

import numpy as np

from gyrocomp import allan
from gyrocomp.diagnose.likelihood import FLICKER_AVAR, NoiseModel, block_means

__all__ = ["gap", "barnes_b1"]


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
        return n * np.log(n) / (2.0 * (n - 1.0) * np.log(2.0))
    return n * (1.0 - n**mu) / (2.0 * (n - 1.0) * (1.0 - 2.0**mu))


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
        ``noise_floor`` (E_0), and ``timescale``: ``tau_s``, ``adev``,
        ``adev_model``, ``log_ratio`` per octave tau.
    """
    r = np.asarray(residual_dps, dtype=float)
    length_s = r.size / fs_hz
    n_per = max(1, int(round(block_s * fs_hz)))
    means = block_means(r, n_per)
    t_g = n_per / fs_hz
    n = means.size
    floor = 0.0
    if n - n_fitted >= 2:
        s2 = float(np.var(means, ddof=1)) * (n - 1) / (n - n_fitted)
        expected = (
            noise.arw**2 / t_g
            + barnes_b1(n, 0) * FLICKER_AVAR * noise.bias_instability**2
            + barnes_b1(n, 1) * noise.rate_random_walk**2 * t_g / 3.0
        )
        d = float(np.log(max(s2, 1e-300) / expected))
        floor += 2.0 / (n - n_fitted)
    else:
        d = 0.0
    tau, adev, _ = allan.oadev(r, fs_hz, "octave")
    keep = tau <= length_s / min_windows
    tau, adev = tau[keep], adev[keep]
    model = np.sqrt(noise.avar(tau))
    log_ratio = np.log(np.maximum(adev, 1e-300) / model)
    s = float(np.mean(log_ratio**2)) if tau.size else 0.0
    if tau.size:
        floor += float(np.mean(1.0 / (2.0 * (length_s / tau - 1.0))))
    return {
        "total": float(np.sqrt(max(0.0, d * d + s - floor))),
        "deterministic": d,
        "stochastic": s,
        "noise_floor": floor,
        "timescale": {"tau_s": tau, "adev": adev, "adev_model": model, "log_ratio": log_ratio},
    }
