"""The recordings of one diagnosis as the likelihood sees them: block means of runs at most ``max_rate_hz``.

:func:`problems` turns the fit and holdout recordings into
:class:`gyrocomp.diagnose.select.Problem` objects: every run averaged to at
most ``max_rate_hz`` at entry (:func:`reduce_recording`), cut in blocks of
``block_s`` (longer when a run would have more than ``max_blocks``), the
temperature effects skipped where the fit run cannot identify them, and a
recording with gaps cut into the whole blocks of its segments (nothing is
interpolated across a gap). :class:`Runs` names their roles: the selection
runs, the holdout whose gap is reported, and what the gap needs.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gyrocomp.diagnose.effects import NEEDS_TEMPERATURE, Run, TemperatureScale
from gyrocomp.diagnose.select import Problem, sample_arw
from gyrocomp.diagnose.settings import DiagnoseSettings
from gyrocomp.errors import InputError

__all__ = ["Runs", "problems", "reduce_recording", "segment_lengths", "GAPPED_SKIP"]


@dataclasses.dataclass(frozen=True)
class Runs:
    """The runs of one diagnosis, as the likelihood sees them (:func:`problems`).

    Attributes
    ----------
    fit : Problem
        The fit run.
    selection : list of Problem
        The runs that select the effects: the fit run and every holdout but the last.
    holdout : Problem or None
        The last holdout, which gives the held-out gap.
    gapped : bool
        A run is in segments with gaps: no scalar gap and no localization.
    white : float
        The fit run's sample-level white level [deg/s/sqrt(Hz)]
        (:func:`gyrocomp.diagnose.select.sample_arw`), the gap's white noise.
    """

    fit: Problem
    selection: list
    holdout: Problem | None
    gapped: bool
    white: float

    @classmethod
    def of(cls, fit_p, holdout_ps):
        """The runs of the fit problem `fit_p` and the holdouts' `holdout_ps` (in order)."""
        gapped = any(p.run.gapped for p in [fit_p] + holdout_ps)
        return cls(fit_p, [fit_p] + holdout_ps[:-1], holdout_ps[-1] if holdout_ps else None, gapped, sample_arw(fit_p.run))

    @property
    def labelled(self) -> list:
        """``[("fit", fit), ("holdout", holdout)]``, without the holdout when there is none."""
        return [("fit", self.fit)] + ([("holdout", self.holdout)] if self.holdout is not None else [])

    def residuals(self, gaps) -> list | None:
        """The full-rate residual in `gaps` (:func:`_gaps`) on each labelled run; None on a recording with gaps."""
        return None if self.gapped else [gaps[label]["residual"] for label, _ in self.labelled]


def problems(fit, holdouts=(), settings: DiagnoseSettings = DiagnoseSettings()):
    """The fit and holdout recordings prepared for the likelihood.

    The temperature effects are skipped without a temperature column or when
    the fit run's temperature spans less than ``min_temperature_span_c``;
    blocks are ``block_s`` long, or longer so that a run has at most
    ``max_blocks`` of them; every run is averaged to at most ``max_rate_hz``
    at entry (:func:`reduce_recording`).

    Parameters
    ----------
    fit : gyrocomp.recordings.Recording
    holdouts : Recording or sequence of Recording
    settings : DiagnoseSettings

    Returns
    -------
    fit_p : Problem
    holdout_ps : list of Problem
        One per holdout, in order.
    skipped : dict
        ``{effect: reason}`` for the effects that cannot be diagnosed.
    """
    s = settings
    has_temp = fit.temperature_c is not None
    skipped = {}
    if not has_temp:
        reason = "no temperature column: temperature polynomial and temperature effects skipped"
        skipped = {e: reason for e in NEEDS_TEMPERATURE}
    else:
        span = float(np.ptp(fit.temperature_c))
        if span < s.min_temperature_span_c:
            reason = f"temperature spans {span:.2f} degC < {s.min_temperature_span_c} degC: temperature effects not identifiable"
            skipped = {e: reason for e in NEEDS_TEMPERATURE}
    use_temp = has_temp and not skipped
    degree = s.poly_degree if use_temp else 0
    scale = TemperatureScale.of(fit.temperature_c) if use_temp else None
    recs = [fit] + _as_list(holdouts)
    block_s = max(s.block_s, (fit.time_s.size / fit.fs_hz) / s.max_blocks)
    if any(len(segment_lengths(r)) > 1 for r in recs):
        reason = (
            "recording in segments with gaps: the element temperature, dT/dt, the hysteresis branch and the "
            "period scan need a contiguous record (nothing is interpolated across a gap)"
        )
        skipped.update({e: reason for e in GAPPED_SKIP if e not in skipped})
        block_s = min(block_s, min(_block_limit(r) for r in recs))
    fit_p, *hold_ps = (Problem(_run(rec, block_s, use_temp, s), s, scale, degree) for rec in recs)
    return fit_p, hold_ps, skipped


def reduce_recording(time_s, rate_dps, temperature_c, fs_hz, m):
    """Means of consecutive groups of `m` samples (the tail is dropped): the recording at ``fs / m``.

    The likelihood works on block means, which are exactly means of these
    means when a block is a whole number of groups; the deterministic shapes
    are evaluated on the group-mean time and temperature, whose error is of
    second order in the temperature's curvature over ``m / fs`` seconds.

    Parameters
    ----------
    time_s, rate_dps : ndarray, shape (n,)
    temperature_c : ndarray, shape (n,), or None
    fs_hz : float
    m : int
        Samples per group (1 returns the inputs themselves).

    Returns
    -------
    time_s, rate_dps, temperature_c : ndarray (temperature None when absent)
    fs_hz : float
        ``fs / m``.
    """
    if m == 1:
        return time_s, rate_dps, temperature_c, fs_hz
    k = time_s.size // m

    def mean(x):
        return None if x is None else np.asarray(x[: k * m], dtype=float).reshape(k, m).mean(axis=1)

    return mean(time_s), mean(rate_dps), mean(temperature_c), fs_hz / m


def _group(n_per, fs_hz, max_rate_hz) -> int:
    """The largest divisor of `n_per` samples per block that averages to at most `max_rate_hz`."""
    most = max(1, int(np.floor(fs_hz / max_rate_hz + 1e-9)))
    return max(d for d in range(1, min(most, n_per) + 1) if n_per % d == 0)


def _as_list(holdout) -> list:
    """None, one recording or a sequence of them, as a list."""
    if holdout is None:
        return []
    return list(holdout) if isinstance(holdout, (list, tuple)) else [holdout]


GAPPED_SKIP = ("thermal_lag", "temp_rate", "hysteresis", "periodic")
"""Effects whose shape needs a contiguous record: skipped on a recording with gaps."""


def segment_lengths(rec) -> list:
    """Samples in each gap-free segment of `rec` (:attr:`gyrocomp.recordings.Recording.segments`)."""
    segments = getattr(rec, "segments", None) or (slice(0, rec.time_s.size),)
    return [seg.stop - seg.start for seg in segments]


def _block_limit(rec) -> float:
    """Longest block [s] that fits in every segment of `rec` at least half the median segment's length.

    Shorter segments (a burst cut short) are left out rather than shortening every block.
    """
    lengths = np.array(segment_lengths(rec))
    return float(lengths[lengths >= 0.5 * np.median(lengths)].min() / rec.fs_hz)


def _run(rec, block_s, use_temp, s) -> Run:
    """`rec` as a :class:`Run`: contiguous, or the whole blocks of each segment (none spans a gap),
    averaged to at most ``max_rate_hz`` (groups within blocks, so none spans a gap either)."""
    n_per = max(1, int(round(block_s * rec.fs_hz)))
    lengths = segment_lengths(rec)
    gapped = len(lengths) > 1
    if gapped:
        starts = [seg.start for seg in rec.segments]
        keep = np.concatenate([a + np.arange((m // n_per) * n_per) for a, m in zip(starts, lengths)])
    else:
        keep = slice(None)
    n = rec.time_s[keep].size
    if n // n_per < 16:
        raise InputError(
            f"{rec.name}: {n} samples make {n // n_per} blocks of {block_s:g} s"
            + (f" within its {len(lengths)} segments" if gapped else "")
            + "; the diagnosis needs at least 16"
        )
    temperature = rec.temperature_c[keep] if use_temp else None
    full = Run(rec.name, rec.time_s[keep], rec.rate_dps[keep], temperature, rec.fs_hz, n_per, s.temp_rate_smooth_s, gapped)
    m = _group(n_per, rec.fs_hz, s.max_rate_hz)
    time_s, rate_dps, temperature, fs_hz = reduce_recording(full.time_s, full.rate_dps, temperature, rec.fs_hz, m)
    arw = sample_arw(full)
    return Run(rec.name, time_s, rate_dps, temperature, fs_hz, n_per // m, s.temp_rate_smooth_s, gapped, arw)
