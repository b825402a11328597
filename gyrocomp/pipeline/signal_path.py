"""The papers' signal path before the learners: decompose, classify, denoise each component by its class, sum each class.

Cao et al. (2021, Fig. 5) and Zhang et al. (2024, section 3.7): the
components of a record are classed noise, mixed or drift by their entropy,
denoised as ``[denoise]`` says for their class, and summed per class; the
learners of :mod:`gyrocomp.pipeline.train` fit the drift and mixed sums.
:func:`segments` denoises and sums components already in memory,
:func:`class_sums` runs the whole path on each gap-free range of a record,
and :func:`class_sums_on_disk` runs it on a long record a block at a time
with its components on disk, so that memory does not grow with the record.
"""

from __future__ import annotations

import numpy as np

from gyrocomp.errors import InputError

__all__ = ["segments", "class_sums", "class_sums_on_disk", "DiskSeries"]


def class_sums(
    rate,
    bounds,
    decompose_settings,
    classify_settings,
    denoise_settings,
    *,
    seed: int | None,
    time_s=None,
    name: str = "recording",
    workers: int = 1,
    callback=None,
) -> tuple[dict, list]:
    """Decompose, classify and denoise each gap-free row range on its own; the class sums end to end.

    A parallel pipeline's signal path (Cao et al. 2021, Fig. 5; Zhang et
    al. 2024, section 3.7) run on each range of `bounds` alone, so that no
    component, entropy or filter window spans a gap, and no sample is
    interpolated or dropped.

    Parameters
    ----------
    rate : array_like, shape (n_samples,)
        The axis' values [deg/s, or the axis' unit].
    bounds : sequence of slice or None
        Row ranges sampled without a gap, covering the rows (``None``: one).
    decompose_settings, classify_settings, denoise_settings
        :class:`~gyrocomp.decompose.DecomposeSettings`,
        :class:`~gyrocomp.classify.ClassifySettings`,
        :class:`~gyrocomp.denoise.DenoiseSettings`.
    seed : int or None
        Seed of every range's decomposition.
    time_s : array_like or None
        Time stamps [s], to name a range in messages.
    name : str
        The recording's name, for messages.
    workers : int
        Processes for the decomposition's ensemble.
    callback : callable(done, total) or None
        Progress: the decomposition's own for one range, else one step per range.

    Returns
    -------
    parts : dict of str to ndarray
        ``noise``, ``mixed``, ``drift`` as :func:`segments`, each range's in its rows.
    classes : list of list of dict
        The classes of each range's components (:func:`gyrocomp.classify.classify`).

    Raises
    ------
    InputError
        A range shorter than the decomposition, the entropy or a class's
        denoiser needs, naming the range, its time span, its length and
        the setting; such a range is never dropped silently.
    """
    from gyrocomp.classify import classify
    from gyrocomp.decompose import MIN_SAMPLES, decompose

    rate = np.asarray(rate, dtype=float)
    bounds = [slice(0, rate.size)] if bounds is None else list(bounds)
    need, why = max((MIN_SAMPLES, "the decomposition"), classify_settings.min_samples(), denoise_settings.min_samples(), key=lambda p: p[0])
    for k, rows in enumerate(bounds):
        n = rows.stop - rows.start
        if n < need:
            where = "" if time_s is None else f", t = {time_s[rows.start]:.6g}..{time_s[rows.stop - 1]:.6g} s"
            raise InputError(
                f"{name}: segment {k + 1} of {len(bounds)} (samples {rows.start}..{rows.stop - 1}{where}) has {n} samples, "
                f"fewer than the {need} that {why} needs; a decomposition pipeline decomposes each gap-free segment "
                "on its own and drops none: remove that segment's rows, or train a direct pipeline (bp, elm, polynomial)"
            )
    parts = {cls: np.empty(rate.size) for cls in ("noise", "mixed", "drift")}
    classes = []
    for k, rows in enumerate(bounds):
        step = callback if len(bounds) == 1 else None
        result = decompose(rate[rows], decompose_settings, seed=seed, workers=workers, callback=step)
        entries = classify(result.components, result.names, classify_settings)
        for cls, values in segments(np.asarray(result.components), [e["class"] for e in entries], denoise_settings).items():
            parts[cls][rows] = values
        classes.append(entries)
        if callback is not None and len(bounds) > 1:
            callback(k + 1, len(bounds))
    return parts, classes


def segments(stack, labels, denoise_settings) -> dict:
    """Denoise each component as ``[denoise]`` says for its class, then sum each class.

    Parameters
    ----------
    stack : ndarray, shape (n_components, n_samples), or sequence of 1-D arrays
        The components, fastest first (the columns of ``components.parquet``
        need not be copied into one array).
    labels : sequence of {"noise", "mixed", "drift"}
        One class per component.
    denoise_settings : gyrocomp.denoise.DenoiseSettings

    Returns
    -------
    dict of str to ndarray
        ``noise``, ``mixed``, ``drift``: the sums of the denoised components
        of each class [deg/s] (zeros for a class without components or one
        that is dropped).

    Notes
    -----
    One component is denoised at a time and added to its class's sum in
    component order: the same bytes as summing the rows of
    :func:`gyrocomp.denoise.apply`'s output over the first axis, in memory
    for one processed component instead of all of them.
    """
    from gyrocomp import denoise

    labels = list(labels)
    if len(labels) != len(stack):
        raise InputError(f"denoise: {len(labels)} classes for {len(stack)} components")
    n = len(stack[0]) if len(stack) else 0
    sums = {}
    for component, label in zip(stack, labels):
        processed = denoise.apply(np.asarray(component, dtype=float)[None], [label], denoise_settings)[0]
        if label in sums:
            sums[label] += processed
        else:
            sums[label] = processed
    return {cls: sums[cls] if cls in sums else np.zeros(n) for cls in ("noise", "mixed", "drift")}


class DiskSeries:
    """One row of a :class:`~gyrocomp.decompose.lcd_blocks.RowFile` read as a 1-D series: slices and the mean.

    What :func:`gyrocomp.pipeline.train.fit_parallel` reads of a target:
    ``y[a:b]`` (read from disk) and ``y.mean()``, numpy's pairwise sum of
    the whole row (the same bits as ``np.mean`` of the row in memory: the
    pairwise halves are summed by ``np.add.reduce`` once a half fits a block).
    """

    on_disk = True

    def __init__(self, store, row: int, block: int):
        self.store, self.row, self.block = store, row, block

    def __len__(self) -> int:
        return self.store.n

    def __getitem__(self, rows: slice) -> np.ndarray:
        lo, hi, step = rows.indices(self.store.n)
        if step != 1:
            raise IndexError("DiskSeries: only contiguous slices")
        return self.store.read(self.row, lo, hi)

    def read(self, lo: int, hi: int) -> np.ndarray:
        return self.store.read(self.row, lo, hi)

    def mean(self) -> float:
        return float(self._sum(0, self.store.n) / self.store.n)

    def _sum(self, lo: int, n: int):
        if n <= self.block:
            return np.add.reduce(self.read(lo, lo + n))
        half = n // 2
        half -= half % 8  # numpy's pairwise_sum splits so
        return self._sum(lo, half) + self._sum(lo + half, n - half)


def class_sums_on_disk(rate, decompose_settings, classify_settings, denoise_settings, directory, *, callback=None) -> tuple[dict, list]:
    """:func:`class_sums` of one gap-free LCD record, a block at a time, its components and class sums on disk.

    The decomposition is :func:`gyrocomp.decompose.lcd_blocks.lcd_on_disk`
    (the same components as the record decomposed whole, to rounding; see
    there); the permutation entropy of each component counts its patterns
    a block at a time (:func:`gyrocomp.entropy.permutation_entropy_blocks`:
    the same counts); ``drop``, ``keep`` and Savitzky-Golay (modes other
    than ``wrap``) denoise each block with the filter's window on either
    side, so every output sees the samples it sees in the whole record
    (the same bits); TFPF and ``wrap`` read a component whole.

    Parameters
    ----------
    rate : ndarray, shape (n_samples,)
    decompose_settings, classify_settings, denoise_settings
        As :func:`class_sums`; the method must be ``lcd``.
    directory : path-like
        A temporary directory: about 140 bytes a sample go there.
    callback : callable(done, total) or None
        The decomposition's progress.

    Returns
    -------
    parts : dict of str to DiskSeries
        ``noise``, ``mixed``, ``drift`` (the class sums), valid while
        `directory` exists.
    classes : list of dict
        ``{name, entropy, class}`` per component, as :func:`gyrocomp.classify.classify`.
    """
    import os

    from gyrocomp.classify import class_of, entropy_of
    from gyrocomp.decompose.lcd_blocks import BLOCK, RowFile, lcd_on_disk
    from gyrocomp.entropy import permutation_entropy_blocks

    d = decompose_settings
    if d.method != "lcd":
        raise InputError(f"class_sums_on_disk: method {d.method!r}; only lcd decomposes on disk")
    n = int(np.size(rate))
    store, count = lcd_on_disk(
        rate, directory, q=d.q, sd_stop=d.sd_stop, max_components=d.max_components, max_sift=d.max_sift, block=BLOCK, callback=callback
    )
    sums = RowFile(os.path.join(directory, "classes.f8"), 3, n)
    try:
        names = [f"isc{k + 1}" for k in range(count - 1)] + ["trend"]
        classes = []
        for k, name in enumerate(names):
            if classify_settings.entropy == "permutation":
                pe = classify_settings.permutation
                value = permutation_entropy_blocks(lambda lo, hi, k=k: store.read(k, lo, hi), n, pe.order, pe.delay, True, BLOCK)
            else:
                value = entropy_of(store.read(k, 0, n), classify_settings)
            classes.append({"name": name, "entropy": value, "class": class_of(value, classify_settings)})
        order = ("noise", "mixed", "drift")
        present = set()
        for k, entry in enumerate(classes):
            row = order.index(entry["class"])
            for lo, hi, values in _denoised(store, k, entry["class"], denoise_settings, BLOCK):
                sums.write(row, lo, sums.read(row, lo, hi) + values if row in present else values)
            present.add(row)
        for row in set(range(3)) - present:
            for lo in range(0, n, BLOCK):
                sums.write(row, lo, np.zeros(min(n, lo + BLOCK) - lo))
    except BaseException:
        sums.close()
        raise
    finally:
        store.close()
    return {cls: DiskSeries(sums, row, BLOCK) for row, cls in enumerate(order)}, classes


def _denoised(store, row: int, label: str, settings, block: int):
    """(lo, hi, values) of component `row` denoised as its class says, block by block (whole when the filter is not local)."""
    from gyrocomp import denoise

    n = store.n
    method = getattr(settings, label)
    margin = {"drop": 0, "keep": 0}.get(method, settings.savgol.window if method == "savgol" and settings.savgol.mode != "wrap" else None)
    if margin is None:
        yield 0, n, denoise.apply(store.read(row, 0, n)[None], [label], settings)[0]
        return
    for lo in range(0, n, block):
        hi = min(n, lo + block)
        start, stop = max(0, lo - margin), min(n, hi + margin)
        values = denoise.apply(store.read(row, start, stop)[None], [label], settings)[0]
        yield lo, hi, values[lo - start : hi - start]

