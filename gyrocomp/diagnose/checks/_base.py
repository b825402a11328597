"""The common result and the registry entry of a residual check (:mod:`gyrocomp.diagnose.checks`)."""

from __future__ import annotations

import dataclasses
from typing import Callable, NamedTuple

import numpy as np
from scipy import stats

from gyrocomp.diagnose.checks._linear import score_test, temperature_bins, temperature_edges, whiten

__all__ = ["Result", "Check", "Frame", "as_dict", "log10", "score_columns"]


class Result(NamedTuple):
    """What a check returns.

    Attributes
    ----------
    statistic : float
        The test statistic.
    pvalue : float
        Its p-value under the model (exact or a conservative bound: :attr:`Check.exact`).
    where : dict
        Where the structure lies and the details a report prints (degrees of
        freedom, time, temperature, period ...), JSON-ready.
    """

    statistic: float
    pvalue: float
    where: dict


def as_dict(result: Result) -> dict:
    """The report's form of a result: ``{"stat", "p", **where}``.

    Examples
    --------
    >>> as_dict(Result(3.0, 0.2, {"dof": 2}))
    {'stat': 3.0, 'p': 0.2, 'dof': 2}
    """
    return {"stat": result.statistic, "p": result.pvalue, **result.where}


@dataclasses.dataclass(frozen=True)
class Check:
    """One registered residual test.

    Attributes
    ----------
    name : str
        Its key in the reports.
    test : callable
        ``test(frame, e, Xw) -> Result | None`` for a check of one run
        (None: the run cannot hold the structure, e.g. no temperature), with
        `e` the innovations and `Xw` the whitened design; ``frame`` (a
        :class:`Frame`) provides ``lower`` (``L``), ``t`` [s], ``temp``
        [degC] or None, ``block_s`` and the room's ``settings``.
    exact : bool
        The p-value is uniform under the model; otherwise a conservative bound.
    families : tuple of str
        The rooms that run it: ``"residual"`` (the verdict), ``"signature"``.
    shape : callable or None
        ``shape(frame, rng) -> ndarray``: a structure of the check's own
        shape, for the contract tests: a deterministic shape added to the
        block means (``level == "block"``, shape ``(n,)``), a block-level
        noise added as drawn (``level == "noise"``), or a factor on the
        sample pairs' spread (``level == "sample"``, one per pair of
        ``frame.pairs``).
    level : {"block", "noise", "sample"}
        What the check looks for (see `shape`).
    scope : {"run", "timescale", "runs"}
        What `test` takes: one run (``test(frame, e, Xw)``), the timescales
        a noise term explains on one run (``test(ts)``, a
        :class:`gyrocomp.diagnose.checks._timescales.Timescales`; a list of
        results, one per ``tau``), or all runs together (a signature's
        between-run tests; their arguments are in their modules).
    own : bool
        In a signature: a test of the noise term's own statistics (a failure
        says the noise is not of the kind claimed; the others may also fail
        for a structure beside a true noise term).
    """

    name: str
    test: Callable
    exact: bool
    families: tuple
    shape: Callable | None
    level: str = "block"
    scope: str = "run"
    own: bool = False


def log10(log_p):
    """A natural-log p-value in decades."""
    return float(log_p / np.log(10.0))


def score_columns(frame, e, Xw, name):
    """The score test (``chi^2`` of their rank) of the frame's columns `name`; None when the run has none."""
    G = frame.columns.get(name)
    if G is None:
        return None
    stat, dof, p, *_ = score_test(e, Xw, whiten(frame.lower, G))
    return Result(stat, p, {"dof": dof, "log10_p": log10(stats.chi2.logsf(stat, dof)) if dof else 0.0})


class Frame:
    """One run as the checks of the verdict see it.

    Parameters
    ----------
    lower : ndarray, shape (n, n)
        Cholesky factor ``L`` of the block means' covariance under the model.
    t : ndarray, shape (n,)
        Block centres after the run's first sample [s] (gaps included).
    temp : ndarray, shape (n,) or None
        Block-mean temperature [degC].
    block_s : float
        Block length [s].
    settings : gyrocomp.diagnose.settings.ChecksSettings
    samples : tuple (rate, n_per_block, fs_hz), optional
        The full-rate rate [deg/s], for the sample-level noise checks.

    Attributes
    ----------
    columns : dict
        The block-level columns of the column checks (``temperature`` bins,
        ``heating_cooling``, ``power_on`` windows, ``time`` segments).
    bands, band_c
        The single bins of each binning of ``temperature_scan_bins`` and their ranges [degC].
    threshold_c : ndarray
        Edges of a step at one temperature [degC].
    regime : ndarray of str
        ``heating``, ``cooling`` or ``soak`` per block.
    edges : dict
        Window edges [s] of ``power_on`` and ``time``.
    pairs : ndarray
        Paired differences within blocks, ``(x_(2j+1) - x_(2j)) / sqrt(2)``.
    """

    def __init__(self, lower, t, temp, block_s, settings, samples=None):
        s = settings
        self.lower, self.t, self.temp, self.block_s, self.settings = lower, t, temp, block_s, s
        self.columns = {}
        self.regime, self.bands, self.band_c, self.threshold_c = None, np.empty((t.size, 0)), [], np.empty(0)
        if temp is not None:
            self.columns["temperature"] = temperature_bins(temp, s.temperature_bins)
            self.bands, self.band_c = _bands(temp, s.temperature_scan_bins, s.min_step_blocks)
            self.threshold_c = temperature_edges(temp, s.temperature_step_bins, s.min_step_blocks)
            rate = np.gradient(temp, block_s) * 60.0
            heating, cooling = rate > s.soak_rate_c_per_min, rate < -s.soak_rate_c_per_min
            z = (temp - temp.mean()) / max(np.ptp(temp) / 2.0, 1e-9)
            self.regime = np.where(heating, "heating", np.where(cooling, "cooling", "soak"))
            if heating.sum() >= 2 and cooling.sum() >= 2:
                self.columns["heating_cooling"] = np.column_stack([heating, cooling, heating * z, cooling * z]).astype(float)
        edges = [e for e in s.poweron_edges_s if e < t[-1] / 2.0]
        end = float(t[-1] + 0.5 * block_s)
        self.edges = {"power_on": [0.0] + edges + [end]}
        if edges:
            self.columns["power_on"] = _indicators(t, self.edges["power_on"])
        self.edges["time"] = np.linspace(0.0, end, s.time_segments + 1).tolist()
        self.columns["time"] = _indicators(t, self.edges["time"])
        self.duration_s = end
        self.pairs, self.fs_hz, self.pairs_per_block = None, None, 0
        if samples is not None:
            # Pairs within blocks (no block spans a gap), block after block in time.
            rate, n_per_block, self.fs_hz = samples
            n = t.size
            x = np.asarray(rate, dtype=float)[: n * n_per_block].reshape(n, n_per_block)
            even = n_per_block - n_per_block % 2
            self.pairs = ((x[:, 1:even:2] - x[:, 0:even:2]) / np.sqrt(2.0)).ravel()
            self.pairs_per_block = even // 2


def _bands(temp, binnings, min_blocks):
    """Indicators of the bins of each equal-width binning of `temp` in `binnings` holding at least `min_blocks` blocks, and their ranges [degC]."""
    cols, ranges = [], []
    for n_bins in binnings:
        for col in temperature_bins(temp, n_bins).T:
            if col.sum() >= min_blocks:
                inside = temp[col > 0]
                cols.append(col)
                ranges.append([float(inside.min()), float(inside.max())])
    return (np.column_stack(cols) if cols else np.empty((temp.size, 0))), ranges


def _indicators(t, edges):
    """Indicator columns of the intervals between consecutive `edges` (the last one closed)."""
    k = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, len(edges) - 2)
    return (k[:, None] == np.arange(len(edges) - 1)[None, :]).astype(float)
