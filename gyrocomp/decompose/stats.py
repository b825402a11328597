"""Statistics of a decomposition for the ``components.meta.json`` sidecar."""

from __future__ import annotations

import numpy as np

__all__ = ["component_stats", "SIDECAR_SCHEMA"]

SIDECAR_SCHEMA = "gyrocomp.components-summary"


def component_stats(decomposition, fs_hz: float) -> dict:
    """Per-component energy share, mean frequency and orthogonality index.

    Parameters
    ----------
    decomposition : Decomposition
    fs_hz : float
        Sample rate [Hz].

    Returns
    -------
    dict
        ``components``: list (fastest first) of ``{name, energy_share,
        mean_frequency_hz, orthogonality_index, rms}``;
        ``orthogonality_index``: the overall index IO of Huang et al. (1998)
        eq. (6.5), ``sum_{j != k} <c_j, c_k> / <x, x>``;
        ``reconstruction_error``: ``max|sum c - x| / max|x|``.

    Notes
    -----
    energy share: ``<c_k, c_k> / sum_j <c_j, c_j>`` (the shares sum to 1).
    Mean frequency: the power-weighted mean frequency of the component's
    periodogram, ``sum f P(f) / sum P(f)`` [Hz] (0 for a zero component).
    A component's orthogonality index: its part of IO,
    ``sum_{j != k} <c_k, c_j> / <x, x>``; the parts sum to IO.
    """
    c = np.asarray(decomposition.components, dtype=float)
    x = np.asarray(decomposition.signal, dtype=float)
    gram = c @ c.T
    energy = np.diag(gram)
    total_energy = float(energy.sum()) or 1.0
    x_energy = float(x @ x) or 1.0
    cross = (gram.sum(axis=1) - energy) / x_energy
    power = np.abs(np.fft.rfft(c, axis=1)) ** 2
    freqs = np.fft.rfftfreq(c.shape[1], d=1.0 / fs_hz)
    weight = power.sum(axis=1)
    mean_f = np.divide(power @ freqs, weight, out=np.zeros_like(weight), where=weight > 0)
    peak = float(np.max(np.abs(x))) or 1.0
    error = float(np.max(np.abs(c.sum(axis=0) - x))) / peak
    return {
        "components": [
            {
                "name": name,
                "energy_share": float(energy[k] / total_energy),
                "mean_frequency_hz": float(mean_f[k]),
                "orthogonality_index": float(cross[k]),
                "rms": float(np.sqrt(energy[k] / c.shape[1])),
            }
            for k, name in enumerate(decomposition.names)
        ],
        "orthogonality_index": float(cross.sum()),
        "reconstruction_error": error,
    }
