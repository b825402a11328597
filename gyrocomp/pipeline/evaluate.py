"""Scores of a compensated recording (DESIGN.md, "Honest evaluation").

* :func:`residual_drift`: the temperature-induced drift left after
  compensation, as the standard deviation and peak-to-peak of the means of
  consecutive 100 s blocks, in deg/h. White noise of density N
  [deg/s/sqrt(Hz)] alone gives block means of std N / sqrt(block_s), the
  floor of this figure.
* :func:`injected_signal` and :func:`signal_preservation`: a known angular
  rate (steps and low-frequency sines) is added to the test recording
  before processing; the difference between the outputs with and without
  it, regressed on the injected signal, is the share that survives
  (1 = kept, 0 = destroyed), and its residual is the RMS error.
* :func:`allan_terms`: angle random walk and bias instability, the
  figures both papers report, from :func:`gyrocomp.allan.analyse`.
"""

from __future__ import annotations

import numpy as np

from gyrocomp.allan.ieee952 import DPS_TO_DPH
from gyrocomp.errors import InputError
from gyrocomp.pipeline.settings import EvaluateSettings, SignalSettings

__all__ = ["block_means", "residual_drift", "injected_signal", "signal_preservation", "allan_terms"]



def block_means(x, fs_hz: float, block_s: float = 100.0) -> np.ndarray:
    """Means of consecutive, non-overlapping blocks of `block_s` seconds (a partial last block is dropped).

    Returns
    -------
    ndarray, shape (n_samples // round(block_s * fs_hz),)
    """
    x = np.asarray(x, dtype=float)
    size = max(1, int(round(block_s * fs_hz)))
    n_blocks = x.size // size
    if n_blocks < 2:
        raise InputError(f"residual drift: {x.size} samples make fewer than 2 blocks of {block_s:g} s at {fs_hz:g} Hz")
    return x[: n_blocks * size].reshape(n_blocks, size).mean(axis=1)


def residual_drift(x, fs_hz: float, settings: EvaluateSettings = EvaluateSettings()) -> dict:
    """Residual drift of a rate series [deg/s] from its block means.

    Returns
    -------
    dict
        ``std_deg_h`` (ddof 0) and ``p2p_deg_h`` of the block means [deg/h],
        ``block_s``, ``n_blocks``.
    """
    means = block_means(x, fs_hz, settings.block_s) * DPS_TO_DPH
    return {
        "std_deg_h": float(np.std(means)),
        "p2p_deg_h": float(np.ptp(means)),
        "block_s": settings.block_s,
        "n_blocks": int(means.size),
    }


def injected_signal(time_s, fs_hz: float, settings: SignalSettings = SignalSettings()) -> tuple[np.ndarray, dict]:
    """The known angular rate of the signal-preservation test.

    Parameters
    ----------
    time_s : array_like, shape (n_samples,)
    fs_hz : float
        Sample rate; every sine must lie below ``fs_hz / 4``.
    settings : SignalSettings

    Returns
    -------
    signal : ndarray, shape (n_samples,)
        Sum of the parts [deg/s].
    parts : dict of str to ndarray
        ``steps`` (levels 0, +A, 0, -A, each `step_s` long) and
        ``sine_<f>hz`` per frequency (amplitude A, zero phase at the start).
    """
    t = np.asarray(time_s, dtype=float) - float(np.asarray(time_s)[0])
    too_fast = [f for f in settings.sine_hz if f >= fs_hz / 4]
    if too_fast:
        raise InputError(f"[signal] sine_hz {too_fast} must lie below fs/4 = {fs_hz / 4:g} Hz")
    a = settings.amplitude_dps
    levels = np.array([0.0, a, 0.0, -a])
    parts = {"steps": levels[(t // settings.step_s).astype(int) % 4]}
    for f in settings.sine_hz:
        parts[f"sine_{f:g}hz"] = a * np.sin(2 * np.pi * f * t)
    return np.sum(list(parts.values()), axis=0), parts


def signal_preservation(with_signal, without_signal, parts: dict) -> dict:
    """How much of an injected rate survives a pipeline.

    Parameters
    ----------
    with_signal, without_signal : array_like, shape (n_samples,)
        The pipeline's output for the test recording with and without the
        injected rate [deg/s].
    parts : dict of str to array_like
        The injected parts (:func:`injected_signal`).

    Returns
    -------
    dict
        ``gain``: least-squares gain of the output difference on the whole
        injected signal (1 = all of it survives); ``rms_error_dps``: RMS of
        the difference minus the injected signal; ``rms_signal_dps``;
        ``destroyed``: ``1 - gain``; ``parts``: the gain of each part from a
        joint least-squares fit on all parts (each part centred).
    """
    d = np.asarray(with_signal, dtype=float) - np.asarray(without_signal, dtype=float)
    names = list(parts)
    S = np.column_stack([np.asarray(parts[k], dtype=float) for k in names])
    s = S.sum(axis=1)
    dc, sc = d - d.mean(), s - s.mean()
    gain = float(dc @ sc / (sc @ sc))
    Sc = S - S.mean(axis=0)
    part_gains, *_ = np.linalg.lstsq(Sc, dc, rcond=None)
    return {
        "gain": gain,
        "destroyed": 1.0 - gain,
        "rms_error_dps": float(np.sqrt(np.mean((dc - sc) ** 2))),
        "rms_signal_dps": float(np.sqrt(np.mean(sc**2))),
        "parts": {k: float(g) for k, g in zip(names, part_gains)},
    }


def allan_terms(x, fs_hz: float, settings: EvaluateSettings = EvaluateSettings()) -> dict:
    """ARW and bias instability of a rate series [deg/s] (:func:`gyrocomp.allan.analyse`).

    Both papers read the terms off the Allan curve (Cao et al. 2021, Fig. 17;
    Zhang et al. 2024, Fig. 15), so the IEEE Std 952 read-off is reported:
    ARW on the -1/2 line at tau = 1 s, bias instability the curve's first
    minimum / 0.664, as the papers read it; ``source`` is ``readoff`` when
    ``allan`` reads B there too (a flat region on enough clusters,
    :func:`gyrocomp.allan.fit.add_readoffs`), ``minimum`` when it does not
    (then the figure bounds B from above). Where the curve has no -1/2 line starting at the
    shortest tau (a smoothed output, whose only -1/2 stretch may lie at long
    tau and would be extrapolated to 1 s), the five-term fit's value stands
    in, and ``source`` says so.

    Returns
    -------
    dict
        ``arw`` [deg/sqrt(h)] and ``bias_instability`` [deg/h], each
        ``{value, unit, source, fit}``, plus the curve (``tau_s``, ``adev``
        [deg/s]) for the report's plot.
    """
    from gyrocomp import allan
    from gyrocomp.allan import ieee952
    from gyrocomp.allan.fit import first_minimum

    series = allan.analyse(np.asarray(x, dtype=float), fs_hz, taus=settings.taus)
    out = {"tau_s": series.tau_s.tolist(), "adev": series.adev.tolist()}
    arw = series.terms["arw"]
    readoff = arw.get("readoff")
    if readoff is not None and arw["readoff_tau_s"][0] > series.tau_s[0]:
        readoff = None
    out["arw"] = {"value": arw["value"] if readoff is None else readoff, "unit": arw["unit"], "source": "fit" if readoff is None else "readoff", "fit": arw["value"]}
    bias = series.terms["bias_instability"]
    minimum = series.adev[first_minimum(series.adev)] / allan.AllanConfig().bias_factor * ieee952.FACTORS["bias_instability"]
    out["bias_instability"] = {
        "value": float(minimum),
        "unit": bias["unit"],
        "source": "readoff" if bias.get("readoff") is not None else "minimum",
        "fit": bias["value"],
    }
    return out
