"""Gaussian likelihood of block means under a white + flicker (or Markov) + random-walk bias model.

`gyrocomp diagnose` compares models of a recording (the baseline and the
baseline plus effects) by one likelihood, so that a deterministic effect
and a noise term compete on equal terms: a slow drift that a regressor
explains is not also paid for as rate random walk, and a wander of the bias
is not mistaken for a thermal term merely because it is slow.

The recording's rate is averaged over blocks of ``T_b`` seconds (block
means ``y_i``; the deterministic model is linear in its coefficients, so
its block means are exact). The noise of the block means is Gaussian with
covariance

.. math:: \\Sigma = N^2 C_w + B^2 C_f + K^2 C_k

* white rate noise of angle random walk ``N`` [deg/s/sqrt(Hz)]:
  ``C_w = I / T_b`` (``N^2 / T_b`` is the Allan variance at ``T_b``);
* flicker of bias instability ``B`` [deg/s]: ``C_f`` is the block-mean
  covariance of a sum of first-order Gauss-Markov processes with time
  constants three per decade from ``T_b / 10`` to ``L / (2 pi)`` and equal
  variances, the classical approximation of 1/f noise (Keshner 1982) whose
  Allan deviation is flat; it is scaled so that the Allan variance at
  ``T_b`` is ``(2 ln 2 / pi) B^2`` (IEEE Std 952 Annex C, REFERENCES.md
  2.2);
* or, in its Markov form, the bias instability as one first-order
  Gauss-Markov process of correlation time ``T_c`` (IEEE Std 952 Annex C,
  "exponentially correlated noise"): a real part's bias often wanders with
  one dominant correlation time inside the run, a Lorentzian spectrum that
  1/f cannot take. Its variance is set so that the peak of its Allan
  variance equals the flicker floor of the same ``B``, ``(2 ln 2 / pi) B^2``
  (:data:`~gyrocomp.allan.ieee952.MARKOV_PEAK_AVAR`), so ``B`` reads the
  same on an Allan plot in both forms;
* rate random walk ``K`` [deg/s/sqrt(s)], the bias a Wiener process from
  power-on: ``C_k[i, j] = E[m_i m_j]`` with
  ``E[W(s) W(t)] = min(s, t)``, exactly ``c_i`` (the centre of the earlier
  block) off the diagonal and ``a_i + T_b / 3`` on it (``a_i`` the start of
  block ``i``), so that the Allan variance is ``K^2 tau / 3``.

For a design matrix ``X`` (offset, temperature polynomial, effects) the
coefficients are concentrated out by generalised least squares and
:func:`profile_deviance` returns ``-2 log L`` (maximum likelihood, Cholesky
whitening).

References
----------
.. [1] IEEE Std 952-1997, Annex C (Allan variance of the noise terms).
.. [2] M. S. Keshner, "1/f noise", Proc. IEEE 70(3), 212-218 (1982).
.. [3] D. Foreman-Mackey, E. Agol, S. Ambikasaran, R. Angus, "Fast and scalable
   Gaussian process modeling with applications to astronomical time series",
   Astron. J. 154, 220 (2017).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import linalg, optimize

from gyrocomp.allan import ieee952
from gyrocomp.allan.ieee952 import FLICKER_AVAR, MARKOV_PEAK_AVAR, markov_avar
from gyrocomp.effects.block_covariance import block_lags, flicker_block_covariance, markov_amplitude, markov_block_covariance

__all__ = ["FLICKER_AVAR", "NoiseBasis", "NoiseModel", "block_means", "markov_block_covariance", "merge_blocks", "profile_deviance", "fit_noise", "fit_noise_runs"]


_LN_FLOOR = -60.0
"""Lower bound of a fitted log-variance: ``exp(-60)`` is numerically zero."""

_COLOURED = ("bias_instability", "rate_random_walk")


@dataclasses.dataclass(frozen=True)
class NoiseModel:
    """The stochastic part of a gyro model, in SI-like units of the library.

    Attributes
    ----------
    arw : float
        White rate noise ``N`` [deg/s/sqrt(Hz)] (= deg/sqrt(s)).
    bias_instability : float
        Flicker ``B`` [deg/s]; its Allan floor is ``0.664 B``.
    rate_random_walk : float
        ``K`` [deg/s/sqrt(s)]; Allan variance ``K^2 tau / 3``.
    bias_correlation_s : float
        0: the bias instability is flicker. Otherwise its Markov form: one
        Gauss-Markov process of this correlation time ``T_c`` [s] whose
        Allan variance peaks at the flicker floor ``(0.664 B)^2``.
    """

    arw: float
    bias_instability: float = 0.0
    rate_random_walk: float = 0.0
    bias_correlation_s: float = 0.0

    @property
    def markov_variance(self) -> float:
        """Stationary variance [(deg/s)^2] of the bias instability's Markov form (0 when flicker)."""
        if not self.bias_correlation_s:
            return 0.0
        return FLICKER_AVAR * self.bias_instability**2 / MARKOV_PEAK_AVAR

    def term_avar(self, term, tau_s):
        """Allan variance [(deg/s)^2] of one noise term (``arw``, ``bias_instability``, ``rate_random_walk``) at `tau_s`."""
        tau = np.asarray(tau_s, dtype=float)
        if term == "arw":
            return self.arw**2 / tau
        if term == "rate_random_walk":
            return self.rate_random_walk**2 * tau / 3.0
        if term != "bias_instability":
            raise ValueError(f"{term!r} is not a noise term")
        if self.bias_correlation_s:
            return self.markov_variance * markov_avar(tau, self.bias_correlation_s)
        return FLICKER_AVAR * self.bias_instability**2 * np.ones_like(tau)

    def avar(self, tau_s):
        """Allan variance [(deg/s)^2] at `tau_s` (IEEE Std 952, REFERENCES.md 2.2)."""
        return sum(self.term_avar(term, tau_s) for term in ("arw", "bias_instability", "rate_random_walk"))

    def psd(self, f_hz):
        """One-sided power spectral density [(deg/s)^2/Hz] at `f_hz` > 0.

        Twice IEEE Std 952's two-sided densities ``N^2``, ``B^2 / (2 pi f)``
        (or the Markov form's ``2 sigma^2 T_c / (1 + (2 pi f T_c)^2)``) and
        ``K^2 / (2 pi f)^2``.
        """
        f = np.asarray(f_hz, dtype=float)
        if self.bias_correlation_s:
            tc = self.bias_correlation_s
            bias = 2.0 * self.markov_variance * tc / (1.0 + (2.0 * np.pi * f * tc) ** 2)
        else:
            bias = self.bias_instability**2 / (2.0 * np.pi * f)
        return 2.0 * (self.arw**2 + bias + self.rate_random_walk**2 / (2.0 * np.pi * f) ** 2)

    def datasheet_units(self) -> dict:
        """The terms in the units datasheets (and :mod:`gyrocomp.sim`) quote; ``bias_correlation_s`` in the Markov form."""
        out = {
            "arw": {"value": ieee952.to_datasheet("arw", self.arw), "unit": ieee952.UNITS["arw"]},
            "bias_instability": {"value": ieee952.to_datasheet("bias_instability", self.bias_instability), "unit": ieee952.UNITS["bias_instability"]},
            "rate_random_walk": {"value": ieee952.to_datasheet("rrw", self.rate_random_walk), "unit": ieee952.UNITS["rrw"]},
        }
        if self.bias_correlation_s:
            out["bias_correlation_s"] = {"value": self.bias_correlation_s, "unit": "s"}
        return out


def block_means(x, n_per_block):
    """Means of consecutive blocks of `n_per_block` samples along axis 0 (the tail is dropped).

    Parameters
    ----------
    x : array_like, shape (n,) or (n, p)
    n_per_block : int

    Returns
    -------
    numpy.ndarray, shape (n // n_per_block,) or (n // n_per_block, p)
    """
    x = np.asarray(x, dtype=float)
    k = x.shape[0] // n_per_block
    return x[: k * n_per_block].reshape((k, n_per_block) + x.shape[1:]).mean(axis=1)


class NoiseBasis:
    """The unit covariance matrices ``C_w``, ``C_f``, ``C_k`` of `n_blocks` block means (and ``C_m(T_c)``, :meth:`bias`).

    Parameters
    ----------
    n_blocks : int
        Number of blocks.
    block_s : float
        Block length ``T_b`` [s].
    starts : array_like, shape (n_blocks,), optional
        Start of each block [s] after power-on, for a recording in segments
        with gaps between them (default: contiguous blocks, ``i T_b``). The
        random walk keeps wandering and the flicker decorrelating through a
        gap; nothing is interpolated.

    Attributes
    ----------
    contiguous : bool
        The blocks follow each other without gaps (``starts`` absent, or
        ``T_b`` apart).
    """

    def __init__(self, n_blocks, block_s, starts=None):
        self.n_blocks = int(n_blocks)
        self.block_s = float(block_s)
        idx = np.arange(self.n_blocks)
        self.white = np.eye(self.n_blocks) / self.block_s
        start = idx * self.block_s if starts is None else np.asarray(starts, dtype=float)
        self.contiguous = bool(np.allclose(np.diff(start), self.block_s))
        centre = start + 0.5 * self.block_s
        earlier = np.minimum.outer(idx, idx)
        self.random_walk = centre[earlier]
        self.random_walk[idx, idx] = start + self.block_s / 3.0
        self._centre = centre
        self._lag = block_lags(self.n_blocks, self.block_s, None if starts is None else centre)
        self.flicker, self._flicker_tc, flicker_scale = flicker_block_covariance(self._lag, self.block_s)
        self._flicker_amplitude = flicker_scale * markov_amplitude(self.block_s, self._flicker_tc)
        self._markov = {}
        self._eig = {}

    def bias(self, correlation_s=0.0):
        """Unit-``B`` covariance of the bias instability: ``C_f`` (flicker, `correlation_s` 0) or its Markov form ``C_m(T_c)``.

        ``C_m`` is the block-mean covariance of one Gauss-Markov process of
        correlation time `correlation_s` with variance
        ``FLICKER_AVAR / MARKOV_PEAK_AVAR`` (module docstring), built once per ``T_c``.
        """
        if not correlation_s:
            return self.flicker
        if correlation_s not in self._markov:
            unit = markov_block_covariance(self._lag, self.block_s, correlation_s)
            self._markov[correlation_s] = unit * (FLICKER_AVAR / MARKOV_PEAK_AVAR)
        return self._markov[correlation_s]

    def covariance(self, noise: NoiseModel):
        """``Sigma = N^2 C_w + B^2 C_f + K^2 C_k`` (``C_m(T_c)`` for ``C_f`` in the Markov form).

        The coloured terms are summed in place and the white level added on
        the diagonal only: the same sums, in the same order, as adding the
        three whole matrices, at a third of the memory traffic.
        """
        terms = []
        if noise.bias_instability:
            terms.append((noise.bias_instability**2, self.bias(noise.bias_correlation_s)))
        if noise.rate_random_walk:
            terms.append((noise.rate_random_walk**2, self.random_walk))
        diagonal = noise.arw**2 * (1.0 / self.block_s)  # the entries of N^2 C_w
        if not terms:
            return diagonal * np.eye(self.n_blocks)
        out = np.multiply(terms[0][1], terms[0][0])
        for scale, matrix in terms[1:]:
            out += scale * matrix
        for scale, matrix in terms:
            diagonal = diagonal + scale * np.diagonal(matrix)
        np.fill_diagonal(out, diagonal)
        return out

    def whitener(self, noise: NoiseModel):
        """A factorisation of ``Sigma(noise)`` for :func:`profile_deviance`.

        With flicker alone or a random walk alone, ``Sigma = (N^2 / T_b) I +
        c C`` shares the eigenvectors of ``C`` (decomposed once per basis),
        so a new noise model costs O(k). The bias instability's Markov form
        (a new ``C`` for every correlation time) and a bias instability
        beside a random walk are factorised as semiseparable matrices
        (:meth:`_semiseparable`), in O(k J^2) for ``J`` exponential terms,
        instead of an O(k^3) eigendecomposition or Cholesky factorisation.
        """
        white = noise.arw**2 / self.block_s
        if not (noise.bias_instability or noise.rate_random_walk):
            return _Whitener(None, np.full(self.n_blocks, white), "white")
        if noise.bias_correlation_s or (noise.bias_instability and noise.rate_random_walk):
            return self._semiseparable(noise)
        key, matrix, value = (
            ("flicker", self.flicker, noise.bias_instability)
            if noise.bias_instability
            else ("random_walk", self.random_walk, noise.rate_random_walk)
        )
        if key not in self._eig:
            self._eig[key] = linalg.eigh(matrix, check_finite=False)
        lam, q = self._eig[key]
        return _Whitener(q, white + value**2 * np.maximum(lam, 0.0), key)

    def _semiseparable(self, noise: NoiseModel):
        """The factorisation ``Sigma = L D L'`` (``L`` unit lower) in O(k J^2).

        Below the diagonal every term is a sum of ``U_i V_j exp(-c (t_i - t_j))``
        over the block centres ``t_i > t_j``: each Gauss-Markov process of
        the flicker (or the Markov form) is one such term
        (:func:`~gyrocomp.effects.block_covariance.markov_amplitude`), the random walk another (``c = 0``,
        ``U = K^2``, ``V_j = t_j``, ``min(t_i, t_j) = t_j``). ``Sigma`` is then
        a semiseparable matrix of rank ``J`` (the terms present) plus its
        diagonal, which celerite2's solver factorises exactly in O(k J^2)
        ([3]_, the celerite algorithm) instead of the O(k^3) of a dense
        Cholesky factorisation; the whitened vectors are the dense lower
        Cholesky factor's, ``D^(-1/2) L^(-1) v``.
        """
        from celerite2 import driver

        b2, k2 = noise.bias_instability**2, noise.rate_random_walk**2
        rates, amplitudes, diagonal = [], [], noise.arw**2 / self.block_s
        if b2:
            if noise.bias_correlation_s:
                rates.append(1.0 / noise.bias_correlation_s)
                amplitudes.append(b2 * markov_amplitude(self.block_s, noise.bias_correlation_s) * (FLICKER_AVAR / MARKOV_PEAK_AVAR))
            else:
                rates += list(1.0 / self._flicker_tc)
                amplitudes += list(b2 * self._flicker_amplitude)
            diagonal = diagonal + b2 * np.diagonal(self.bias(noise.bias_correlation_s))
        V = np.ones((self.n_blocks, len(rates) + bool(k2)))
        if k2:
            rates.append(0.0)
            amplitudes.append(k2)
            V[:, -1] = self._centre
            diagonal = diagonal + k2 * np.diagonal(self.random_walk)
        rates = np.array(rates)
        U = np.empty_like(V)
        U[:] = amplitudes
        d, W = driver.factor(self._centre, rates, diagonal, U, V, np.empty(self.n_blocks), np.empty_like(V))
        return _SemiseparableWhitener(self._centre, rates, U, W, d)


def merge_blocks(y, X, basis: NoiseBasis, max_blocks):
    """Block means `y` and regressors `X` merged to at most `max_blocks` blocks, with their (contiguous) basis.

    A coarser likelihood for searches whose every evaluation would factorise
    the full covariance; the tail that does not fill a merged block is dropped.
    """
    f = -(-y.size // max_blocks)
    k = y.size // f
    return (
        y[: k * f].reshape(k, f).mean(axis=1),
        X[: k * f].reshape(k, f, X.shape[1]).mean(axis=1),
        NoiseBasis(k, basis.block_s * f),
    )


def profile_deviance(y, X, whitener):
    """``-2 log L`` of ``y ~ N(X beta, Sigma)`` with ``beta`` at its GLS estimate.

    Parameters
    ----------
    y : ndarray, shape (k,)
        Block means [deg/s].
    X : ndarray, shape (k, p)
        Block means of the regressors.
    whitener : object
        ``Sigma`` factorised by :meth:`NoiseBasis.whitener`.

    Returns
    -------
    deviance : float
    beta : ndarray, shape (p,)
    """
    beta, rss = _gls(whitener.whiten(y), whitener.whiten(X))
    return float(whitener.logdet + rss + y.size * np.log(2.0 * np.pi)), beta


def _gls(yw, Xw):
    """Least squares of whitened `yw` on whitened `Xw`: ``(beta, residual sum of squares)``."""
    beta, *_ = linalg.lstsq(Xw, yw, cond=1e-12, lapack_driver="gelsy", check_finite=False)
    r = yw - Xw @ beta
    return beta, float(r @ r)


class _Whitener:
    """``whiten(v) = Sigma^(-1/2) v`` from eigenvectors ``q`` and eigenvalues ``d``,
    or from a lower Cholesky factor when ``d`` is None; ``family`` names the ``q`` that a family of noise
    models shares (``"white"``: none): columns :meth:`rotated` once serve every model of it (:meth:`scaled`)."""

    def __init__(self, q, d, family=None):
        self.q = q
        self.d = d
        self.family = family
        if d is None:
            self.logdet = 2.0 * float(np.sum(np.log(np.diag(q))))
        else:
            self.logdet = float(np.sum(np.log(d)))
            self._scale = 1.0 / np.sqrt(d)

    def whiten(self, v):
        if self.d is None:
            return linalg.solve_triangular(self.q, v, lower=True, check_finite=False)
        return self.scaled(self.rotated(v))

    def rotated(self, v):
        """``Q' v``, the part of :meth:`whiten` shared by the `family`."""
        return v if self.q is None else self.q.T @ v

    def scaled(self, v):
        """Rotated `v` (:meth:`rotated`) scaled by ``d^(-1/2)``: whitened."""
        return v * (self._scale if v.ndim == 1 else self._scale[:, None])


class _SemiseparableWhitener:
    """``whiten(v) = D^(-1/2) L^(-1) v`` from celerite2's factorisation ``Sigma = L D L'`` (:meth:`NoiseBasis._semiseparable`)."""

    d = None  # no eigenbasis to rotate into once (fit_noise_runs)
    family = None

    def __init__(self, t, rates, U, W, d):
        self._factor = (t, rates, U, W)
        self._scale = 1.0 / np.sqrt(d)
        self.logdet = float(np.sum(np.log(d)))

    def whiten(self, v):
        from celerite2 import driver

        v = np.asarray(v, dtype=float)
        columns = np.ascontiguousarray(v.reshape(v.shape[0], -1))
        out = driver.solve_lower(*self._factor, columns, np.empty_like(columns)) * self._scale[:, None]
        return out.reshape(v.shape)


def fit_noise(y, X, basis: NoiseBasis, start: NoiseModel, free=("arw",), restricted=False):
    """Maximum-likelihood noise terms for block means `y` with regressors `X`.

    The log-variances of the terms named in `free` are optimised (Nelder-Mead,
    from `start`); the others keep their value in `start`, 0 meaning absent.
    With `restricted`, the restricted likelihood instead
    (:func:`fit_noise_runs`).

    Returns
    -------
    noise : NoiseModel
    deviance : float
        ``-2 log L`` at the optimum (``-2 log L_R`` with `restricted`).
    beta : ndarray
    """
    names = tuple(free)
    if restricted:
        noise, deviance, betas = fit_noise_runs([(y, X, basis)], start, free, restricted=True)
        return noise, deviance, betas[0]
    if names == ("arw",) and not (start.bias_instability or start.rate_random_walk):
        # White only: Sigma = s^2 I, so the ML s^2 is the mean squared OLS residual.
        unit = basis.whitener(NoiseModel(arw=np.sqrt(basis.block_s)))
        _, beta = profile_deviance(y, X, unit)
        s2 = max(float(np.mean((y - X @ beta) ** 2)), 1e-300)
        noise = NoiseModel(arw=float(np.sqrt(s2 * basis.block_s)))
        return noise, profile_deviance(y, X, basis.whitener(noise))[0], beta
    noise, deviance, betas = fit_noise_runs([(y, X, basis)], start, free)
    return noise, deviance, betas[0]


def fit_noise_runs(runs, start: NoiseModel, free=("arw",), restricted=False):
    """Noise terms shared by several runs of one gyro, by maximum likelihood.

    Each run keeps its own regression coefficients; the runs' ``-2 log L``
    add (independent noise realisations of the same terms).

    Parameters
    ----------
    runs : sequence of (y, X, basis)
        Block means, regressors and covariance basis of each run.
    start : NoiseModel
    free : sequence of str
        Terms whose log-variances are optimised (Nelder-Mead, from `start`;
        a flicker or random-walk term starts no lower than where it matches
        0.3 times the white level at one block). When ``arw`` comes first and
        every other term of `start` is free, ``Sigma = N^2 Sigma_1`` and the
        white level ``N^2`` is concentrated out (its ML value is the mean
        squared residual whitened by ``Sigma_1``): Nelder-Mead searches the
        coloured terms' log ratios to it, one dimension fewer and about half
        the evaluations, to the same optimum.
    restricted : bool
        Maximise the restricted (residual) likelihood of Patterson and
        Thompson [4]_ instead, ``-2 log L_R = -2 log L + log det(X'
        Sigma^-1 X) - p log 2 pi`` at the GLS ``beta`` (``N^2`` concentrated
        as ``rss / (n - p)``): the likelihood of the residual contrasts,
        which does not see what the regressors take. Maximum likelihood
        reads a slow correlated noise short and weak where a temperature
        polynomial or a per-run offset absorbs its slow part; the
        restricted likelihood does not. Restricted deviances compare noise
        models at one design `X` only.

    Returns
    -------
    noise : NoiseModel
    deviance : float
        Summed ``-2 log L`` at the optimum (``-2 log L_R`` with `restricted`).
    betas : list of ndarray

    References
    ----------
    .. [4] H. D. Patterson, R. Thompson, "Recovery of inter-block information
       when block sizes are unequal", Biometrika 58(3), 545-554 (1971).
    """
    names = tuple(free)
    # The likelihood is flat in a log-variance far below the white level: a
    # term that another run (or model) fitted to nothing restarts where it
    # would match 0.3 times the white level at one block.
    block_s = runs[0][2].block_s
    white = start.arw / np.sqrt(block_s)
    level = {"arw": 0.0, "bias_instability": 0.3 * white, "rate_random_walk": 0.3 * white / np.sqrt(block_s)}
    x0 = np.array([np.log(max(getattr(start, name), level[name], 1e-30) ** 2) for name in names])
    x0 = np.maximum(x0, _LN_FLOOR + 5.0)

    # When every term present is free, Sigma = N^2 Sigma_1 with Sigma_1 a function of the
    # coloured terms' ratios to the white level; N^2 then has a closed-form maximum (the
    # mean squared residual whitened by Sigma_1: the concentrated likelihood, as GLS
    # concentrates beta) and Nelder-Mead searches the ratios, one dimension fewer.
    scaled = names[0] == "arw" and len(names) > 1 and all(name in names for name in _COLOURED if getattr(start, name))
    if scaled:
        x0 = x0[1:] - x0[0]

    def model(z, white_variance=None):
        """The noise model at log-variances `z`; with `white_variance` ``N^2``, `z` holds the coloured terms' log ratios to it."""
        values = dataclasses.asdict(start)
        if white_variance is not None:
            values["arw"] = float(np.sqrt(white_variance))
            z = [white_variance * np.exp(max(v, _LN_FLOOR)) for v in z]
            for name, v in zip(names[1:], z):
                values[name] = float(np.sqrt(v))
            return NoiseModel(**values)
        for name, v in zip(names, z):
            values[name] = float(np.exp(0.5 * max(v, _LN_FLOOR)))
        return NoiseModel(**values)

    rotated = {}

    def run_terms(k, y, X, w):
        """``(log det Sigma, r' Sigma^-1 r)`` of run `k` at its GLS beta; with `restricted`, ``log det(X' Sigma^-1 X)`` added to the first."""
        if w.d is not None:
            # Same eigenvectors for every noise model of this family: rotate once.
            key = (k, id(w.q))
            if key not in rotated:
                rotated[key] = (y, X) if w.q is None else (w.q.T @ y, w.q.T @ X)
            y, X = rotated[key]
            w = _Whitener(None, w.d)
        try:
            Xw = w.whiten(X)
            return w.logdet + (_log_det_gram(Xw) if restricted else 0.0), _gls(w.whiten(y), Xw)[1]
        except linalg.LinAlgError:
            return w.logdet, np.inf

    def objective(z):
        noise = model(z, 1.0 if scaled else None)
        # Runs of one length and block share their covariance: factorise it once.
        whiteners = {}
        total, logdet, rss, n = 0.0, 0.0, 0.0, 0
        for k, (y, X, basis) in enumerate(runs):
            key = (basis.n_blocks, basis.block_s)
            if key not in whiteners:
                whiteners[key] = basis.whitener(noise)
            terms = run_terms(k, y, X, whiteners[key])
            m = y.size - (X.shape[1] if restricted else 0)
            total += float(terms[0] + terms[1] + m * np.log(2.0 * np.pi))
            logdet, rss, n = logdet + terms[0], rss + terms[1], n + m
        if scaled:
            # -2 log L at the ML scale N^2 = rss / n of Sigma = N^2 Sigma_1 (n less the columns: restricted).
            return logdet + n * np.log(max(rss / n, 1e-300)) + n + n * np.log(2.0 * np.pi)
        return total

    best = optimize.minimize(
        objective, x0, method="Nelder-Mead", options={"xatol": 1e-2, "fatol": 1e-2, "initial_simplex": _simplex(x0)}
    )
    noise = model(best.x, _white_variance(runs, model(best.x, 1.0), restricted) if scaled else None)
    if restricted:
        return noise, float(best.fun), [profile_deviance(y, X, basis.whitener(noise))[1] for y, X, basis in runs]
    deviance, betas = 0.0, []
    for y, X, basis in runs:
        dev, beta = profile_deviance(y, X, basis.whitener(noise))
        deviance += dev
        betas.append(beta)
    return noise, deviance, betas


def _white_variance(runs, unit: NoiseModel, restricted=False):
    """The ML ``N^2`` of ``Sigma = N^2 Sigma_1`` over `runs`, ``Sigma_1`` the covariance of `unit` (``arw`` 1);
    with `restricted`, the REML one (the residual degrees of freedom ``n - p``)."""
    rss = 0.0
    for y, X, basis in runs:
        w = basis.whitener(unit)
        rss += _gls(w.whiten(y), w.whiten(X))[1]
    return max(rss / sum(y.size - (X.shape[1] if restricted else 0) for y, X, _ in runs), 1e-300)


def _log_det_gram(Xw):
    """``log det(Xw' Xw)`` over the columns `Xw` spans (singular values above ``1e-12`` of the largest, as :func:`_gls`'s rank)."""
    if Xw.shape[1] == 0:
        return 0.0
    sv = linalg.svdvals(Xw, check_finite=False)
    return float(2.0 * np.sum(np.log(sv[sv > 1e-12 * sv[0]])))


def _simplex(x0, step=2.0):
    return np.vstack([x0] + [x0 + step * e for e in np.eye(x0.size)])
