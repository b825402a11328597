"""Sort decomposition components into noise, mixed and drift by an entropy.

Cao et al. (2021) use normalised permutation entropy with thresholds 0.6 and
0.4 (section IV-B, Fig. 10); Zhang et al. (2024) use sample entropy with 0.6
and 0.1 (section 4.2, Fig. 10), and call the low-entropy class "feature":
here it is ``drift``. Each entropy keeps its own thresholds, so switching
the entropy never applies one paper's thresholds to the other's measure.
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np

from gyrocomp.errors import InputError

__all__ = [
    "ENTROPIES",
    "CLASSES_SCHEMA",
    "PermutationSettings",
    "SampleSettings",
    "ClassifySettings",
    "classify",
    "class_of",
    "entropy_of",
]

ENTROPIES = ("permutation", "sample")
CLASSES_SCHEMA = "gyrocomp.classes"


def _check_thresholds(kind: str, noise_above: float, drift_below: float) -> None:
    """Defined first: the settings classes build default instances at import."""
    if not drift_below <= noise_above:
        raise InputError(f"{kind}: drift_below = {drift_below} must not exceed noise_above = {noise_above}")


@dataclasses.dataclass(frozen=True)
class PermutationSettings:
    """``[classify.permutation]``: normalised PE and its thresholds (Cao et al. 2021)."""

    order: int = 6
    delay: int = 1
    noise_above: float = 0.6
    drift_below: float = 0.4

    def __post_init__(self):
        if self.order < 2 or self.delay < 1:
            raise InputError(f"permutation: order = {self.order} must be >= 2 and delay = {self.delay} >= 1")
        _check_thresholds("permutation", self.noise_above, self.drift_below)


@dataclasses.dataclass(frozen=True)
class SampleSettings:
    """``[classify.sample]``: SampEn, r = r_factor * std (ddof 0), and thresholds (Zhang et al. 2024)."""

    m: int = 2
    r_factor: float = 0.2
    noise_above: float = 0.6
    drift_below: float = 0.1

    def __post_init__(self):
        if self.m < 0 or not self.r_factor > 0:
            raise InputError(f"sample: m = {self.m} must be >= 0 and r_factor = {self.r_factor} > 0")
        _check_thresholds("sample", self.noise_above, self.drift_below)


@dataclasses.dataclass(frozen=True)
class ClassifySettings:
    """The ``[classify]`` table: which entropy, and each entropy's settings.

    Defaults equal ``configs/pe-lcd-anfis.toml``; the ICEEMDAN-SE-TFPF config
    differs only in ``entropy = "sample"``.
    """

    entropy: str = "permutation"
    permutation: PermutationSettings = PermutationSettings()
    sample: SampleSettings = SampleSettings()

    def __post_init__(self):
        if self.entropy not in ENTROPIES:
            raise InputError(f"classify entropy {self.entropy!r}; choose one of {', '.join(ENTROPIES)}")

    @property
    def active(self) -> PermutationSettings | SampleSettings:
        """The settings of the selected entropy."""
        return getattr(self, self.entropy)

    def min_samples(self) -> tuple[int, str]:
        """Fewest samples a component needs for the selected entropy, and the setting that asks for them.

        Permutation entropy needs one ordinal pattern, (order - 1) delay + 1
        samples (Bandt & Pompe 2002); sample entropy needs m + 2 (two
        templates of length m + 1, Richman & Moorman 2000).
        """
        if self.entropy == "permutation":
            pe = self.permutation
            return (pe.order - 1) * pe.delay + 1, f"[classify.permutation] order = {pe.order}, delay = {pe.delay}"
        return self.sample.m + 2, f"[classify.sample] m = {self.sample.m}"

    @property
    def noise_above(self) -> float:
        """Entropy above which a component is noise."""
        return self.active.noise_above

    @property
    def drift_below(self) -> float:
        """Entropy below which a component is drift."""
        return self.active.drift_below


def entropy_of(x, settings: ClassifySettings = ClassifySettings()) -> float:
    """The selected entropy of one component (normalised PE, or SampEn in nats)."""
    from gyrocomp.entropy import permutation_entropy, sample_entropy

    if settings.entropy == "permutation":
        pe = settings.permutation
        return permutation_entropy(x, pe.order, pe.delay, normalize=True)
    se = settings.sample
    x = np.asarray(x, dtype=float)
    std = float(np.std(x))
    if std == 0:
        return 0.0  # a constant component is perfectly regular
    return sample_entropy(x, se.m, se.r_factor * std)


def classify(components, names: Sequence[str], settings: ClassifySettings = ClassifySettings()) -> list[dict]:
    """Entropy and class of each component.

    Parameters
    ----------
    components : array_like, shape (n_components, n_samples)
        One component per row, fastest first.
    names : sequence of str
        A name per row (``imf1`` ... ``residue``).
    settings : ClassifySettings

    Returns
    -------
    list of dict
        ``{"name", "entropy", "class"}`` per component, in order; ``class``
        is ``"noise"`` when entropy > noise_above, ``"drift"`` when
        entropy < drift_below, else ``"mixed"`` (both thresholds belong to
        the mixed band, as in both papers' "between" wording). A sample
        entropy with no matches at length m + 1 is ``inf``: noise.

    Raises
    ------
    InputError
        Not 2-D, or names and rows disagree.
    """
    comps = np.asarray(components, dtype=float)
    if comps.ndim != 2:
        raise InputError(f"classify: components must be 2-D (components x samples), got shape {comps.shape}")
    names = [str(n) for n in names]
    if len(names) != comps.shape[0]:
        raise InputError(f"classify: {len(names)} names for {comps.shape[0]} components")
    result = []
    for name, component in zip(names, comps):
        value = entropy_of(component, settings)
        result.append({"name": name, "entropy": value, "class": class_of(value, settings)})
    return result


def class_of(value: float, settings: ClassifySettings = ClassifySettings()) -> str:
    """``noise``, ``mixed`` or ``drift`` for one entropy value (see :func:`classify`)."""
    if np.isnan(value):
        raise InputError("classify: entropy is undefined (no template matches); cannot classify")
    if value > settings.noise_above:
        return "noise"
    if value < settings.drift_below:
        return "drift"
    return "mixed"
