"""Where the gap lies: by regime, by timescale and by decomposition component.

All three break a residual (rate minus the calibrated model) down against
the calibrated simulation's noise model:

* **regime** -- soak / ramp (``|dT/dt|`` below or above `checks.soak_rate_c_per_min`),
  heating / cooling, the warm-up window after power-on and temperature bins:
  the mean and RMS of the residual's `smooth_s` moving mean in each, beside
  the RMS the noise model predicts for that moving mean (white part);
* **timescale** -- the ratio of the residual's Allan deviation to the
  model's per octave tau, and of its Welch power spectral density to the
  model's per frequency decade;
* **component** -- the energy (mean square) of each component of an EMD of
  the residual's `smooth_s` means (:func:`gyrocomp.decompose.decompose`).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage, signal

from gyrocomp.decompose import DecomposeSettings, decompose
from gyrocomp.effects.likelihood import NoiseModel, block_means
from gyrocomp.effects import shapes

__all__ = ["regimes", "timescales", "components"]

_DPH = 3600.0
"""deg/s -> deg/h."""


def regimes(time_s, temperature_c, residual_dps, fs_hz, noise: NoiseModel, settings):
    """Residual statistics per operating regime (deg/h).

    Returns
    -------
    dict
        ``{regime: {"fraction", "mean_deg_h", "rms_deg_h", "expected_rms_deg_h"}}``;
        regimes without samples are left out.
    """
    n_smooth = max(1, int(round(settings.smooth_s * fs_hz)))
    smooth = ndimage.uniform_filter1d(np.asarray(residual_dps, dtype=float), n_smooth, mode="nearest")
    expected = _DPH * float(np.sqrt(noise.avar(n_smooth / fs_hz)))
    t = np.asarray(time_s, dtype=float)
    masks = {"warmup_window": t - t[0] < settings.warmup_window_s}
    masks["after_warmup"] = ~masks["warmup_window"]
    if temperature_c is not None:
        rate = shapes.temperature_rate(t, temperature_c, smooth_s=settings.smooth_s) * 60.0
        thr = settings.checks.soak_rate_c_per_min
        masks["soak"] = np.abs(rate) < thr
        masks["ramp"] = ~masks["soak"]
        masks["heating"] = rate >= thr
        masks["cooling"] = rate <= -thr
        width = settings.temperature_bin_c
        bins = np.floor(np.asarray(temperature_c) / width) * width
        for lo in np.unique(bins):
            masks[f"T {lo:+.0f}..{lo + width:+.0f} degC"] = bins == lo
    out = {}
    for name, mask in masks.items():
        if mask.any():
            part = smooth[mask]
            out[name] = {
                "fraction": float(mask.mean()),
                "mean_deg_h": _DPH * float(part.mean()),
                "rms_deg_h": _DPH * float(np.sqrt(np.mean(part**2))),
                "expected_rms_deg_h": expected,
            }
    return out


def timescales(residual_dps, fs_hz, noise: NoiseModel, gap_timescale: dict):
    """Allan-deviation ratio per octave tau and PSD ratio per frequency decade (recording / simulation)."""
    r = np.asarray(residual_dps, dtype=float)
    nper = int(min(r.size, 2 ** int(np.floor(np.log2(max(r.size / 8, 16))))))
    f, pxx = signal.welch(r, fs=fs_hz, nperseg=nper, detrend="constant")
    keep = f > 0
    f, pxx = f[keep], pxx[keep]
    model = noise.psd(f)
    bands = []
    for lo in 10.0 ** np.arange(np.floor(np.log10(f[0])), np.ceil(np.log10(f[-1]))):
        sel = (f >= lo) & (f < 10 * lo)
        if sel.any():
            bands.append(
                {"f_lo_hz": lo, "f_hi_hz": 10 * lo, "ratio": float(pxx[sel].mean() / model[sel].mean()), "n_bins": int(sel.sum())}
            )
    tau = gap_timescale["tau_s"]
    return {
        "adev": [
            {"tau_s": float(t), "adev_dps": float(a), "adev_model_dps": float(m), "ratio": float(a / m)}
            for t, a, m in zip(tau, gap_timescale["adev"], gap_timescale["adev_model"])
        ],
        "psd": bands,
    }


def components(residual_dps, fs_hz, settings):
    """Energy of each EMD component of the residual's `smooth_s` means [(deg/h)^2]."""
    n = max(1, int(round(settings.smooth_s * fs_hz)))
    means = block_means(residual_dps, n) * _DPH
    if means.size < 8:
        return []
    dec = decompose(
        means, DecomposeSettings(method="emd", max_imfs=settings.emd_max_imfs, max_sift=settings.emd_max_sift)
    )
    energies = np.mean(dec.components**2, axis=1)
    total = float(np.mean(means**2))
    return [
        {"component": name, "energy_deg2_h2": float(e), "share": float(e / total) if total > 0 else 0.0}
        for name, e in zip(dec.names, energies)
    ]
