"""Denoisers of the classified components, and the per-class dispatch.

The two pipelines treat the three classes of components differently:

=========  ================================  ======================================
class      PE-LCD-ANFIS (Cao et al. 2021)    ICEEMDAN-SE-TFPF (Zhang et al. 2024)
=========  ================================  ======================================
noise      dropped                           long-window TFPF
mixed      Savitzky-Golay                    short-window TFPF
drift      kept (modelled downstream)        kept (the "feature" segment, modelled)
=========  ================================  ======================================

Which method each class gets, and the methods' settings, come from the
``[denoise]`` table of the pipeline config (:class:`DenoiseSettings`).
"""

from __future__ import annotations

import dataclasses
from typing import Mapping, Sequence

import numpy as np

from gyrocomp.denoise.savgol import MODES as SAVGOL_MODES
from gyrocomp.denoise.savgol import savgol
from gyrocomp.denoise.tfpf import tfpf
from gyrocomp.errors import InputError

__all__ = ["METHODS", "SavgolSettings", "TfpfSettings", "DenoiseSettings", "apply", "savgol", "tfpf"]

METHODS = ("drop", "keep", "savgol", "tfpf_long", "tfpf_short")
"""What can be done to a class of components."""

CLASSES = ("noise", "mixed", "drift")


@dataclasses.dataclass(frozen=True)
class SavgolSettings:
    """``[denoise.savgol]``: see :func:`gyrocomp.denoise.savgol`."""

    window: int = 51
    polyorder: int = 3
    mode: str = "interp"

    def __post_init__(self):
        if self.mode not in SAVGOL_MODES:
            raise InputError(f"savgol mode {self.mode!r}; choose one of {', '.join(SAVGOL_MODES)}")
        if self.window < 1 or self.window % 2 == 0 or not 0 <= self.polyorder < self.window:
            raise InputError(
                f"savgol window {self.window} must be odd and polyorder {self.polyorder} in [0, window)"
            )


@dataclasses.dataclass(frozen=True)
class TfpfSettings:
    """``[denoise.tfpf]``: see :func:`gyrocomp.denoise.tfpf`; window lengths in samples."""

    long_window: int = 101
    short_window: int = 21
    scale_low: float = 0.05
    scale_high: float = 0.45
    lag_window: str = "hamming"

    def __post_init__(self):
        for name in ("long_window", "short_window"):
            value = getattr(self, name)
            if value < 3 or value % 2 == 0:
                raise InputError(f"tfpf {name} = {value} must be odd and >= 3")
        if not 0 < self.scale_low < self.scale_high < 0.5:
            raise InputError(
                f"tfpf scale [{self.scale_low}, {self.scale_high}] must satisfy 0 < low < high < 0.5"
            )


@dataclasses.dataclass(frozen=True)
class DenoiseSettings:
    """The ``[denoise]`` table: one method per class, and the methods' settings.

    Defaults are those of ``configs/pe-lcd-anfis.toml``; the ICEEMDAN-SE-TFPF
    config differs only in ``noise = "tfpf_long"`` and ``mixed = "tfpf_short"``.
    """

    noise: str = "drop"
    mixed: str = "savgol"
    drift: str = "keep"
    savgol: SavgolSettings = SavgolSettings()
    tfpf: TfpfSettings = TfpfSettings()

    def __post_init__(self):
        for cls in CLASSES:
            method = getattr(self, cls)
            if method not in METHODS:
                raise InputError(f"denoise {cls} = {method!r}; choose one of {', '.join(METHODS)}")

    def min_samples(self) -> tuple[int, str]:
        """Fewest samples every class's method takes, and the setting that asks for them.

        Savitzky-Golay fits its window (:func:`~gyrocomp.denoise.savgol.savgol`);
        TFPF needs half its lag window plus one (:func:`~gyrocomp.denoise.tfpf.tfpf`);
        ``drop`` and ``keep`` take any length.
        """
        need = {"drop": (1, ""), "keep": (1, "")}
        need["savgol"] = (self.savgol.window, f"[denoise.savgol] window = {self.savgol.window}")
        for method, window in (("tfpf_long", self.tfpf.long_window), ("tfpf_short", self.tfpf.short_window)):
            need[method] = ((window - 1) // 2 + 1, f"[denoise.tfpf] {method[5:]}_window = {window}")
        return max((need[getattr(self, cls)] for cls in CLASSES), key=lambda pair: pair[0])


def apply(components, classes: Sequence, settings: DenoiseSettings = DenoiseSettings()) -> np.ndarray:
    """Denoise each component by the method its class gets.

    Parameters
    ----------
    components : array_like, shape (n_components, n_samples)
        The decomposition (IMFs / ISCs and the residue), one per row.
    classes : sequence of str or of mapping
        ``"noise"``, ``"mixed"`` or ``"drift"`` per row, or the records of
        :func:`gyrocomp.classify.classify` (their ``"class"`` is used).
    settings : DenoiseSettings

    Returns
    -------
    ndarray, shape (n_components, n_samples)
        The processed components: a dropped one is a row of zeros, so the
        sum over rows is the denoised signal.

    Raises
    ------
    InputError
        Shapes disagree, or an unknown class.
    """
    comps = np.asarray(components, dtype=float)
    if comps.ndim != 2:
        raise InputError(f"denoise: components must be 2-D (components x samples), got shape {comps.shape}")
    names = [c["class"] if isinstance(c, Mapping) else c for c in classes]
    if len(names) != comps.shape[0]:
        raise InputError(f"denoise: {len(names)} classes for {comps.shape[0]} components")
    out = np.empty_like(comps)
    for row, (component, cls) in enumerate(zip(comps, names)):
        if cls not in CLASSES:
            raise InputError(f"denoise: component {row} has class {cls!r}; expected one of {', '.join(CLASSES)}")
        out[row] = _denoise_one(component, getattr(settings, cls), settings)
    return out


def _denoise_one(x: np.ndarray, method: str, settings: DenoiseSettings) -> np.ndarray:
    if method == "drop":
        return np.zeros_like(x)
    if method == "keep":
        return x.copy()
    if method == "savgol":
        sg = settings.savgol
        return savgol(x, sg.window, sg.polyorder, sg.mode)
    tf = settings.tfpf
    window = tf.long_window if method == "tfpf_long" else tf.short_window
    return tfpf(x, window, scale=(tf.scale_low, tf.scale_high), lag_window=tf.lag_window)
