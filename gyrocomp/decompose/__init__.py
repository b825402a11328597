"""Decompose a gyro record into components, fastest first, residue or trend last.

The algorithms live in the modules :mod:`.lcd`, :mod:`.iceemdan`,
:mod:`.ceemdan` and :mod:`.emd` (functions of the same names);
:func:`gyrocomp.commands.decompose.write` is the ``components.parquet``
artefact that ``gyrocomp decompose`` and the pipelines write.

Methods: ``lcd`` (Cao et al. 2021 eqs. (4)-(11)), ``iceemdan`` (Colominas
et al. 2014), ``ceemdan`` (Torres et al. 2011) and plain ``emd`` (Huang et
al. 1998 with Rilling's sifting). Settings come from the ``[decompose]``
table of a pipeline config (:class:`DecomposeSettings`).
"""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np

from gyrocomp.decompose import ceemdan, emd, iceemdan, lcd
from gyrocomp.decompose.emd import Sifting
from gyrocomp.decompose.stats import SIDECAR_SCHEMA, component_stats
from gyrocomp.errors import InputError

__all__ = [
    "METHODS",
    "MIN_SAMPLES",
    "DecomposeSettings",
    "Decomposition",
    "decompose",
    "component_stats",
    "SIDECAR_SCHEMA",
]

METHODS = ("lcd", "iceemdan", "ceemdan", "emd")

MIN_SAMPLES = 4
"""Fewest samples :func:`decompose` takes: with fewer, no envelope through three extrema exists."""

MAX_ENSEMBLE = 10_000
"""Most noise realisations of iceemdan/ceemdan: 20x the largest NR the papers use (500,
Colominas et al. 2014); beyond it a run takes days, so a larger value is a typo."""


@dataclasses.dataclass(frozen=True)
class DecomposeSettings:
    """The ``[decompose]`` table; defaults equal ``configs/pe-lcd-anfis.toml``.

    Parameters
    ----------
    method : {"lcd", "iceemdan", "ceemdan", "emd"}
    stop : {"rilling", "sd", "s_number", "fixed"}
        Sifting stop of the EMD family (see :class:`~gyrocomp.decompose.emd.Sifting`).
    thresholds : tuple of float
        Rilling's (theta1, theta2, alpha) = (0.05, 0.5, 0.05).
    sd_threshold : float
        Huang's SD threshold when ``stop = "sd"``.
    s_number : int
        S of Huang et al.'s (2003) S-number rule when ``stop = "s_number"``.
    max_sift : int
        Most sifting iterations per component (all methods).
    max_imfs : int
        Most IMFs of the EMD family.
    ensemble : int
        Noise realisations of ICEEMDAN / CEEMDAN.
    noise_strength : float
        eps_0, noise std relative to the signal's.
    constant_snr : bool
        Normalise each noise mode by its std (``SNRFlag = 2``).
    q : float
        LCD baseline weight, eq. (4) of Cao et al. (2021).
    sd_stop : float
        LCD sifting stop, eq. (9).
    max_components : int
        Most ISCs of LCD.
    """

    method: str = "lcd"
    stop: str = "fixed"
    thresholds: tuple = (0.05, 0.5, 0.05)
    sd_threshold: float = 0.2
    s_number: int = 4
    max_sift: int = 10
    max_imfs: int = 30
    ensemble: int = 100
    noise_strength: float = 0.2
    constant_snr: bool = False
    q: float = 0.5
    sd_stop: float = 0.3
    max_components: int = 10

    def __post_init__(self):
        if self.method not in METHODS:
            raise InputError(f"method = {self.method!r}; choose one of {', '.join(METHODS)}")
        if not 1 <= self.ensemble <= MAX_ENSEMBLE:
            raise InputError(f"ensemble = {self.ensemble!r}; must be in 1..{MAX_ENSEMBLE} (each realisation is a full EMD)")
        if not self.noise_strength > 0:
            raise InputError(f"noise_strength = {self.noise_strength}; must be positive")
        if not 0.0 < self.q < 1.0:
            raise InputError(f"q = {self.q}; must lie in (0, 1)")
        for name in ("max_sift", "max_imfs", "max_components"):
            if getattr(self, name) < 1:
                raise InputError(f"{name} = {getattr(self, name)}; must be at least 1")
        try:
            self.sifting()
        except ValueError as err:
            raise InputError(str(err)) from None

    def sifting(self) -> Sifting:
        """The sifting settings of the EMD family."""
        return Sifting(
            stop=self.stop,
            thresholds=tuple(self.thresholds),
            sd_threshold=self.sd_threshold,
            s_number=self.s_number,
            max_sift=self.max_sift,
        )


@dataclasses.dataclass(frozen=True)
class Decomposition:
    """Components of a signal.

    Attributes
    ----------
    components : ndarray, shape (k, n_samples)
        Fastest first; the last is the residue (EMD family) or trend (LCD).
        They sum to `signal`.
    names : list of str
        ``imf1..imfK, residue`` or ``isc1..iscK, trend``.
    method : str
    signal : ndarray, shape (n_samples,)
        The decomposed signal.
    """

    components: np.ndarray
    names: list
    method: str
    signal: np.ndarray


def decompose(
    x,
    settings: DecomposeSettings = DecomposeSettings(),
    *,
    seed: int = 0,
    workers: int = 1,
    callback: Callable[[int, int], None] | None = None,
) -> Decomposition:
    """Decompose a signal with the method of `settings`.

    Parameters
    ----------
    x : array_like, shape (n_samples,)
        Finite samples, uniformly spaced; at least 4.
    settings : DecomposeSettings
    seed : int, default=0
        Seed of the noise ensemble (ICEEMDAN, CEEMDAN).
    workers : int, default=1
        Processes for the ensemble; the result does not depend on it.
    callback : callable(done, total), optional
        Progress, per component.

    Returns
    -------
    Decomposition

    Raises
    ------
    InputError
        `x` not 1-D, too short, or not finite.
    """
    x = _check_signal(x)
    if workers < 1:
        raise InputError(f"workers = {workers}; must be at least 1")
    s = settings
    if s.method == "lcd":
        comps = lcd.lcd(x, q=s.q, sd_stop=s.sd_stop, max_components=s.max_components, max_sift=s.max_sift, callback=callback)
        prefix, last = "isc", "trend"
    elif s.method == "emd":
        imfs, residue = emd.emd(x, s.sifting(), max_imfs=s.max_imfs)
        comps = np.vstack([imfs, residue[None]])
        prefix, last = "imf", "residue"
        if callback is not None:
            callback(1, 1)
    else:
        run = iceemdan.iceemdan if s.method == "iceemdan" else ceemdan.ceemdan
        comps = run(
            x,
            ensemble=s.ensemble,
            noise_strength=s.noise_strength,
            constant_snr=s.constant_snr,
            sifting=s.sifting(),
            max_imfs=s.max_imfs,
            seed=seed,
            workers=workers,
            callback=callback,
        )
        prefix, last = "imf", "residue"
    names = [f"{prefix}{k + 1}" for k in range(comps.shape[0] - 1)] + [last]
    return Decomposition(components=comps, names=names, method=s.method, signal=x)


def _check_signal(x) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim != 1:
        raise InputError(f"signal must be 1-D, got shape {x.shape}")
    if x.size < MIN_SAMPLES:
        raise InputError(f"signal has {x.size} samples; decomposition needs at least {MIN_SAMPLES}")
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        raise InputError(f"signal sample {bad[0]} is {x[bad[0]]!r}; samples must be finite")
    return x
