"""When a searched ELM replaces the plain one: cross-validated blocks, a sign test and thermal regimes held out.

The acceptance rules 3 and 4 of :class:`gyrocomp.models.nsga2elm.NSGA2ELM`
(its Notes): the candidate must beat the plain ELM on significantly many
cross-validated blocks (:func:`cv_rmse`, :func:`sign_test`) and on every
thermal regime held out whole (:func:`regimes`, :func:`regime_rmse`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from gyrocomp.errors import InputError
from gyrocomp.models._base import rmse
from gyrocomp.models.elm import ELM

__all__ = ["REGIMES", "cv_rmse", "regimes", "regime_rmse", "significant_everywhere", "sign_test"]

REGIMES = ("cooling", "soak", "heating")
"""Thermal regimes of a sample, by the sign of the smoothed temperature slope (-1, 0, +1 in :func:`regimes`)."""


def cv_rmse(params: dict[str, Any], X: np.ndarray, y: np.ndarray, n_folds: int, ridge: float, seed: int) -> np.ndarray:
    """Cross-validated RMSE per block of an ELM with `params` and `seed` (NSGA2ELM Notes, rule 3).

    The samples, in time order, are cut into ``4 * n_folds`` contiguous
    blocks; block j goes to fold ``j mod n_folds``. Each fold is predicted
    by the ELM fitted on the other folds; returns the RMSE of each block's
    predictions, shape ``(4 * n_folds,)``.
    """
    if len(y) < 4 * n_folds:
        raise InputError(f"NSGA2ELM: {len(y)} samples cannot make 4 * cv_folds = {4 * n_folds} blocks")
    blocks = np.array_split(np.arange(len(y)), 4 * n_folds)
    fold = np.concatenate([np.full(len(block), j % n_folds) for j, block in enumerate(blocks)])
    prediction = np.empty(len(y))
    for k in range(n_folds):
        elm = ELM(params["n_hidden"], params["activation"], params["weight_scale"], ridge, seed=seed)
        prediction[fold == k] = elm.fit(X[fold != k], y[fold != k]).predict(X[fold == k])
    return np.array([rmse(prediction[block], y[block]) for block in blocks])


def regimes(temperature: np.ndarray, window: float, soak_fraction: float) -> np.ndarray:
    """Thermal regime of each sample: -1 cooling, 0 soak, +1 heating (NSGA2ELM Notes, rule 4).

    The temperature, in time order, is smoothed by a centred moving mean of
    ``max(3, round(window * n))`` samples (the ends padded with the end
    values) and differenced (``numpy.gradient``); a sample is soak where the
    magnitude of that slope is below `soak_fraction` times its 99th
    percentile over the run, else heating or cooling by its sign. The slope
    is per sample: its unit and the scaling of the column cancel in the
    ratio.
    """
    n = len(temperature)
    width = min(n, max(3, int(round(window * n))))
    padded = np.pad(temperature, (width // 2, width - 1 - width // 2), mode="edge")
    slope = np.gradient(np.convolve(padded, np.full(width, 1.0 / width), mode="valid")) if n > 1 else np.zeros(n)
    threshold = soak_fraction * np.quantile(np.abs(slope), 0.99)
    return np.where(slope > threshold, 1, np.where(slope < -threshold, -1, 0))


def regime_rmse(params: dict[str, Any], X: np.ndarray, y: np.ndarray, labels: np.ndarray, ridge: float, seed: int) -> np.ndarray:
    """RMSE on each regime of `labels` held out whole, the ELM fitted on the others (NSGA2ELM Notes, rule 4).

    One value per regime present, in increasing label order (cooling, soak,
    heating); none when a single regime is present.
    """
    present = np.unique(labels)
    if len(present) < 2:
        return np.empty(0)
    out = []
    for regime in present:
        held = labels == regime
        elm = ELM(params["n_hidden"], params["activation"], params["weight_scale"], ridge, seed=seed)
        out.append(rmse(elm.fit(X[~held], y[~held]).predict(X[held]), y[held]))
    return np.array(out)


def significant_everywhere(p_value: float, alpha: float, regime_rmse: np.ndarray | None) -> bool:
    """The ``sign_test`` verdict: p below `alpha` (rule 3) and, unless `regime_rmse` is None, row 1 below row 0 in every column (rule 4)."""
    return p_value < alpha and (regime_rmse is None or bool(np.all(regime_rmse[1] < regime_rmse[0])))


def sign_test(block_rmse: np.ndarray) -> float:
    """One-sided sign-test p-value that row 1 is below row 0 on more blocks than chance (ties count against)."""
    from scipy.stats import binomtest

    wins = int(np.sum(block_rmse[1] < block_rmse[0]))
    return float(binomtest(wins, block_rmse.shape[1], 0.5, alternative="greater").pvalue)
