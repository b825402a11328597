"""Fit each segment's learner on block means of (T, dT/dt) and its target, in memory that does not grow with the log.

:mod:`gyrocomp.pipeline.train` prepares the targets (the recorded rate, or
the class sums of a parallel pipeline) and :func:`fit_block_means` fits
them: the learners' inputs are computed a run of :data:`TRAIN_ROWS`
samples at a time and reduced to at most ``[model] max_samples`` block
means, so a learner's design (Jang's least squares for ANFIS) has that many
rows whatever the recording's length; the targets are read a run at a
time too (a class sum on disk: :class:`gyrocomp.pipeline.signal_path.DiskSeries`).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Iterator

import numpy as np

from gyrocomp import artefacts
from gyrocomp.config import settings_dict
from gyrocomp.errors import InputError
from gyrocomp.pipeline import rate as rate_estimator
from gyrocomp.pipeline.coverage import even_over_temperature
from gyrocomp.pipeline.model_file import MODEL_SCHEMA
from gyrocomp.pipeline.settings import model_settings, pipeline_settings, rate_settings

__all__ = ["INPUTS", "TRAIN_ROWS", "fit_block_means"]

INPUTS = ("temperature_c", "temperature_rate_c_per_s")
"""Names of the learners' input columns, in order."""
TRAIN_ROWS = 1 << 16
"""Samples whose inputs training computes at once (whole blocks of the block means)."""


def fit_block_means(targets: dict, temperature, fs_hz, config, *, source, seed, settings, inputs, extra, bounds=None) -> dict:
    """Fit each segment's learner on block means of (T, dT/dt) and its target, in bounded memory.

    The inputs are computed a run of whole blocks at a time (:func:`_runs`,
    :func:`_inputs_of`), three times: for their ranges, the block means and
    the training RMSE. Beside the recording's own columns, memory holds one
    run's inputs and the block means (at most ``max_samples`` a segment),
    whatever the recording's length; the figures equal those of the whole
    arrays at once bit for bit on a recording of one run.
    """
    rate_cfg = rate_settings(config, source)
    pipeline = pipeline_settings(config, source)
    model_table = model_settings(config, source, parallel=pipeline.parallel)
    temperature = np.asarray(temperature, dtype=float)
    n = len(temperature)
    duration = n / fs_hz
    if rate_cfg.window_s > duration:
        raise InputError(
            f"{', '.join(record['name'] for record in inputs) or source}: [rate] window_s = {rate_cfg.window_s:g} s "
            f"is longer than the recording ({duration:g} s); the temperature rate needs a window within it"
        )
    ranges = [(0, n)] if bounds is None else [b.indices(n)[:2] for b in bounds]
    for lo, hi in ranges:
        rate_estimator.check_temperature(temperature[lo:hi], minimum=2)
    size = 1 if model_table.max_samples == 0 or n <= model_table.max_samples else -(-n // model_table.max_samples)
    runs = _runs(ranges, np.concatenate([np.arange(lo, hi, size) for lo, hi in ranges]), TRAIN_ROWS)

    def input_runs():
        return _inputs_of(temperature, fs_hz, rate_cfg, runs)

    extremes = [(X.min(axis=0), X.max(axis=0)) for _, X, _ in input_runs()]
    lo, hi = np.min([e[0] for e in extremes], axis=0), np.max([e[1] for e in extremes], axis=0)
    _check_rank(lo, hi, model_table, ", ".join(record["name"] for record in inputs) or source)
    maps = {}
    for segment, y in targets.items():
        spec = model_table.segments[segment]
        if spec.normalise_inputs:
            offset, scale = (hi + lo) / 2, np.where(hi > lo, (hi - lo) / 2, 1.0)
        else:
            offset, scale = np.zeros(2), np.ones(2)
        y = y if getattr(y, "on_disk", False) else np.asarray(y, dtype=float)  # a DiskSeries reads its slices
        y_offset = float(y.mean())
        y_scale = math.sqrt(sum(float(np.sum((y[run[0] : run[1]] - y_offset) ** 2)) for run in runs) / n) or 1.0
        maps[segment] = (y, offset, scale, y_offset, y_scale)
    means = {segment: ([], []) for segment in targets}
    for rows, X, local_starts in input_runs():
        counts = np.diff(np.append(local_starts, len(X)))
        for segment, (y, offset, scale, y_offset, y_scale) in maps.items():
            means[segment][0].append(np.add.reduceat((X - offset) / scale, local_starts, axis=0) / counts[:, None])
            means[segment][1].append(np.add.reduceat((y[rows] - y_offset) / y_scale, local_starts) / counts)
    learners, not_fitted = {}, {}
    for segment, (y, offset, scale, y_offset, y_scale) in maps.items():
        Xb, yb = np.concatenate(means[segment][0]), np.concatenate(means[segment][1])
        if model_table.temperature_bin_c:
            Xb, yb = even_over_temperature(Xb, yb, Xb[:, 0] * scale[0] + offset[0], model_table.temperature_bin_c)
        learner, not_fitted[segment] = _identifiable(model_table.segments[segment], Xb * scale + offset, model_table.min_unique_variance, seed)
        learners[segment] = (learner.fit(Xb, yb), float(np.min(yb)), float(np.max(yb)))
    squares = dict.fromkeys(targets, 0.0)
    for rows, X, _ in input_runs():
        for segment, (y, offset, scale, y_offset, y_scale) in maps.items():
            error = learners[segment][0].predict((X - offset) / scale) * y_scale + y_offset - y[rows]
            squares[segment] += float(np.sum(error**2))
    fitted = {}
    for segment, (y, offset, scale, y_offset, y_scale) in maps.items():
        learner, low, high = learners[segment]
        fitted[segment] = {
            **extra["segments"][segment],
            "not_fitted": [refusal.to_dict() for refusal in not_fitted[segment]],
            "input_offset": offset.tolist(),
            "input_scale": scale.tolist(),
            "output_offset": y_offset,
            "output_scale": y_scale,
            "output_min": low * y_scale + y_offset,
            "output_max": high * y_scale + y_offset,
            "train_rmse_dps": math.sqrt(squares[segment] / n),
            "learner": learner.to_dict(),
        }
    settings = {**settings, "rate": settings_dict(rate_cfg), "model": model_table.to_dict()}
    header = artefacts.artefact_header(MODEL_SCHEMA, inputs=inputs, settings=settings, seed=seed)
    body = {
        "kind": pipeline.kind,
        "parallel": pipeline.parallel,
        "fs_hz": float(fs_hz),
        "input_columns": list(INPUTS),
        "rate_estimator": rate_estimator.describe(rate_cfg, fs_hz),
        "clip_inputs": model_table.clip_inputs,
        "clip_output": model_table.clip_output,
        "formula": (
            "per segment: y = learner((x - input_offset) / input_scale) * output_scale + output_offset, "
            "x = [temperature, temperature rate] held inside the training ranges when clip_inputs, "
            "y held inside [output_min, output_max] when clip_output; drift_model = sum over segments"
        ),
        "segments": fitted,
        "training": {
            "temperature_c": {"min": float(lo[0]), "max": float(hi[0])},
            "temperature_rate_c_per_s": {"min": float(lo[1]), "max": float(hi[1])},
            "temperature_rate_causal_c_per_s": dict(zip(("min", "max"), _causal_rate_range(temperature, fs_hz, rate_cfg, bounds))),
            "n_samples": n,
            "duration_s": float(n / fs_hz),
            "n_segments": 1 if bounds is None else len(bounds),
        },
    }
    if extra.get("training_classes") is not None:
        body["training"]["classes"] = extra["training_classes"]
    if extra.get("segment_classes") is not None:
        body["training"]["segment_classes"] = extra["segment_classes"]
    return {**header, **body}


def _causal_rate_range(temperature, fs_hz: float, rate_cfg, bounds) -> tuple[float, float]:
    """dT/dt range of the training run by the causal estimator, the one ``compensate --mode causal`` judges a recording's against.

    Each range is streamed through :class:`~gyrocomp.pipeline.rate.CausalRate`
    `TRAIN_ROWS` samples at a time (chunks change no bit of its output), as
    :func:`gyrocomp.pipeline.train.segment_inputs` ``causal=True`` gives it whole.
    """
    n = len(temperature)
    ranges = [(0, n)] if bounds is None or len(bounds) == 1 else [b.indices(n)[:2] for b in bounds]
    low, high = math.inf, -math.inf
    for lo, hi in ranges:
        estimator = rate_estimator.CausalRate(rate_cfg, fs_hz, hi - lo)
        for start in range(lo, hi, TRAIN_ROWS):
            rate = estimator(temperature[start : min(hi, start + TRAIN_ROWS)])
            low, high = min(low, float(rate.min())), max(high, float(rate.max()))
    return low, high


def _identifiable(spec, X: np.ndarray, min_unique: float, seed) -> tuple:
    """An unfitted learner of `spec` with only the terms the training inputs identify, and the terms it leaves out.

    A polynomial drops each power of T and its dT/dt term that the block
    means `X` (physical units: degC, degC/s) cannot tell from the terms
    before it (:func:`gyrocomp.identifiability.polynomial_terms`). A learned
    map of (T, dT/dt) keeps both inputs, but when dT/dt follows T on the
    training runs the refusal is recorded all the same: what it learns of
    dT/dt is then a guess (:mod:`gyrocomp.identifiability`).
    """
    from gyrocomp.identifiability import polynomial_terms

    if spec.learner == "polynomial":
        asked = spec.build(seed)
        degree, rate_term, refused = polynomial_terms(X[:, 0], X[:, 1], asked.degree, asked.rate_term, min_unique)
        return asked.set_params(degree=degree, rate_term=rate_term), refused
    _, _, refused = polynomial_terms(X[:, 0], X[:, 1], 3, True, min_unique)
    refused = [
        dataclasses.replace(r, reason=f"{r.reason} (the {spec.learner} learner keeps its dT/dt input; what it learns of it is not identified)")
        for r in refused
        if r.term == "dT/dt"
    ]
    return spec.build(seed), refused


def _check_rank(lo: np.ndarray, hi: np.ndarray, model_table, name: str) -> None:
    """Refuse inputs that leave the drift model rank-deficient (see :class:`ModelSettings`).

    The temperature-rate span is not checked for a polynomial alone: its
    dT/dt term is judged with its powers of T (:func:`_identifiable`) and
    left out, not refused, on a run that ramps at one rate.
    """
    limits = (("temperature", "degC", model_table.min_temperature_span_c, "min_temperature_span_c"),)
    if any(spec.learner != "polynomial" for spec in model_table.segments.values()):
        limits += (("temperature rate", "degC/s", model_table.min_temperature_rate_span_c_per_s, "min_temperature_rate_span_c_per_s"),)
    for (what, unit, limit, key), low, high in zip(limits, lo, hi):
        if high - low < limit:
            raise InputError(
                f"{name}: the training {what} spans only {high - low:.3g} {unit} ({low:.6g} to {high:.6g}); "
                f"a drift model needs at least {limit:g} ([model] {key}): train on a run that heats and cools"
            )


def _runs(ranges: list, starts: np.ndarray, rows: int) -> list:
    """Runs of whole blocks, about `rows` samples each, within each gap-free range.

    Returns
    -------
    list of (first, stop, range_lo, range_hi, block_starts)
        Samples ``first .. stop - 1`` of the range ``range_lo .. range_hi - 1``,
        and the first samples of the run's blocks counted from `first`
        (`starts`: every block of every range, :func:`fit_block_means`), so a block
        never spans a gap or two runs.
    """
    runs = []
    for lo, hi in ranges:
        first = starts[(starts >= lo) & (starts < hi)]
        step = max(1, rows // (int(first[1] - first[0]) if len(first) > 1 else hi - lo))
        for k in range(0, len(first), step):
            stop = int(first[k + step]) if k + step < len(first) else hi
            runs.append((int(first[k]), stop, lo, hi, first[k : k + step] - first[k]))
    return runs


def _inputs_of(temperature: np.ndarray, fs_hz: float, settings, runs: list) -> Iterator[tuple]:
    """(rows, X, block starts) of each run: X = [T, centred dT/dt] of its samples, the rate of its range's whole series, bit for bit."""
    estimators = {}
    for first, stop, lo, hi, block_starts in runs:
        if (lo, hi) not in estimators:
            estimators = {(lo, hi): rate_estimator.CentredRate(temperature[lo:hi], fs_hz, settings)}
        rate = estimators[(lo, hi)].rows(first - lo, stop - lo)
        yield slice(first, stop), np.column_stack([temperature[first:stop], rate]), block_starts
