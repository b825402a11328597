"""``spectrum``: a tone that repeats in every run at the same time since power-on (a noise term's signature, own statistics).

A wander, however large, does not put its power at the same time and
frequency in independent runs, where a disturbance tied to the time since
power-on (a tone, a chirp) does, whatever its phase: cut from power-on into
halves, quarters and eighths (``spectrum_parts``), each run's periodogram
ordinates of the innovations are independent ``Exp(1)`` under the model, so
their minimum over the ``R`` runs is ``Exp(R)`` and the largest such
minimum over the ``M`` cells has an exact tail (:func:`tone_replication`);
Bonferroni over the segment lengths (conservative).
"""

from __future__ import annotations

import numpy as np

from gyrocomp.diagnose.checks._base import Check, Result

__all__ = ["tone_replication", "test", "CHECK"]


def tone_replication(innovations, parts):
    """Whether a tone repeats in every run at the same time since power-on: the largest run-wise minimum of the periodograms.

    Each run's innovations are cut from power-on into segments of ``L =
    n_min // parts`` blocks (``n_min`` the shortest run); segment ``j`` of
    run ``r`` gives the periodogram ``I_rjk = |sum_t e_t exp(-2 pi i k t /
    L)|^2 / L`` at the inner Fourier frequencies ``k = 1 .. ceil(L/2) - 1``.
    When the model holds the innovations are white with unit variance, so
    the ``I_rjk`` are independent ``Exp(1)`` and their minimum over the
    ``R`` runs, ``m_jk``, is ``Exp(R)``: a wander, however large, does not
    put its power at the same time and frequency in independent runs, where
    a disturbance tied to the time since power-on (a tone, a chirp) does,
    whatever its phase. Over the ``M`` cells ``P(max m >= x) = 1 - (1 -
    exp(-R x))^M``; Bonferroni over the segment lengths.

    Parameters
    ----------
    innovations : sequence of ndarray
        One run's whitened residual each (:func:`innovations`), of blocks of one length.
    parts : sequence of int
        The shortest run is cut into this many segments, one segment length each.

    Returns
    -------
    dict or None
        ``p``, the strongest cell's ``segment`` and ``bin`` (``k``),
        ``blocks`` (``L``), ``power`` (its ``I`` in each run), ``cells``
        (``M``); None with fewer than two runs or no length giving a bin.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(720)
    >>> noise = [rng.standard_normal(720) for _ in range(2)]
    >>> tone = [e + 0.5 * np.sin(2 * np.pi * t / 30.0 + phase) for e, phase in zip(noise, (0.3, 2.0))]
    >>> bool(tone_replication(noise, (2, 4))["p"] > 0.01), bool(tone_replication(tone, (2, 4))["p"] < 1e-6)
    (True, True)
    """
    if len(innovations) < 2:
        return None
    n = min(e.size for e in innovations)
    best = None
    for k in parts:
        length = n // k
        if length < 4:
            continue
        power = np.array([np.abs(np.fft.rfft(e[: k * length].reshape(k, length), axis=1)[:, 1:(length + 1) // 2]) ** 2 / length
                          for e in innovations])
        low = power.min(axis=0)
        j, b = np.unravel_index(np.argmax(low), low.shape)
        p = float(-np.expm1(low.size * np.log1p(-np.exp(-len(innovations) * low[j, b]))))
        if best is None or p < best["p"]:
            best = {"p": p, "segment": int(j), "bin": int(b) + 1, "blocks": int(length), "power": power[:, j, b].tolist(), "cells": int(low.size)}
    if best is not None:
        best["p"] = float(min(1.0, best["p"] * len(parts)))
    return best


def test(runs, es, s):
    """Test (a', spectrum): :func:`tone_replication` of the runs' innovations, with the tone's period and window in seconds.

    Runs whose blocks differ in length (runs of different durations), or
    with gaps between their blocks (a recording in segments: its block
    index is not its time), are not compared (None).
    """
    block_s = {p.basis.block_s for p in runs}
    if len(block_s) != 1 or not all(p.basis.contiguous for p in runs):
        return None
    found = tone_replication(es, s.spectrum_parts)
    if found is None:
        return None
    tb = block_s.pop()
    span = found["blocks"] * tb
    where = {k: v for k, v in found.items() if k != "p"}
    return Result(float(min(found["power"])), found["p"], where | {
        "period_s": span / found["bin"], "window_s": [found["segment"] * span, (found["segment"] + 1) * span]})




CHECK = Check("spectrum", test, exact=False, families=("signature",), shape=None, scope="runs", own=True)
