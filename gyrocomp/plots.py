"""Every figure gyrocomp draws, on matplotlib's object API.

Each ``*_figure`` function builds a :class:`matplotlib.figure.Figure` from
results and returns it; :func:`save` writes one atomically as PNG through
the Agg canvas. Nothing here calls ``matplotlib.use`` or ``pyplot``: a
:class:`~matplotlib.figure.Figure` made directly holds no global state, so
batch workers and threads draw at the same time without a lock.

Figures
-------
:func:`drift_figure`
    ``train --plot`` / ``compensate --plot``: bias against temperature with
    the fitted model, heating and cooling branches coloured apart (a
    hysteresis loop shows as two branches), before and after compensation;
    beside it raw and compensated rate against time with the temperature on
    a second axis.
:func:`components_figure`
    ``decompose --plot``: the components stacked, labelled with their class
    once ``classify`` has run.
:func:`allan_figure`
    Allan deviation of several series (one colour each) with confidence
    bands, slope guides -1/2, 0, +1/2 and the N, B, K read-off points.
:func:`entropies_figure`, :func:`report_figure`, :func:`gap_figure`
    ``classify --plot``, ``run``'s ``report.png``, ``diagnose --plot``.
"""

from __future__ import annotations

import os
from typing import Sequence

import numpy as np

from gyrocomp.allan import ieee952

__all__ = [
    "save",
    "method_label",
    "drift_figure",
    "components_figure",
    "classes_figure",
    "allan_figure",
    "entropies_figure",
    "report_figure",
    "gap_figure",
    "model_curve",
    "drift_axis",
    "drift_axis_from_means",
    "BlockMeans",
    "minmax_columns",
    "DRIFT_BLOCK_S",
    "CLASS_COLOURS",
]

CLASS_COLOURS = {"noise": "tab:red", "mixed": "tab:orange", "drift": "tab:blue"}
"""Colour of each component class, in every figure that shows classes."""

_BRANCH_COLOURS = {"heating": "tab:red", "cooling": "tab:blue", "soak": "0.55"}

_MAX_DPI = 200
"""Highest resolution [dots per inch] a figure is saved at: a series is decimated to one span per dot column at it (:func:`minmax_columns`)."""

DRIFT_BLOCK_S = 60.0
"""Length [s] of the blocks whose means :func:`drift_figure` draws."""


def save(fig, path: str | os.PathLike, *, dpi: int = 110) -> None:
    """Write `fig` as PNG, atomically (temporary file, then rename), without a timestamp in the file."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from gyrocomp.artefacts import atomic_path

    FigureCanvasAgg(fig)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=dpi, metadata={"Software": None})


def _figure(width: float, height: float):
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), layout="constrained")


def _block_means(x: np.ndarray, block: int, segments: Sequence[slice] | None = None) -> np.ndarray:
    """Means of consecutive blocks of `block` samples inside each segment: a block never spans a gap, a shorter segment is one block."""
    x = np.asarray(x, dtype=float)
    means = []
    for seg in segments or (slice(0, len(x)),):
        part = x[seg]
        n = len(part) // block
        means.append(part[: n * block].reshape(n, block).mean(axis=1) if n else part.mean(keepdims=True))
    return np.concatenate(means)


class BlockMeans:
    """Means of consecutive blocks of `block` samples of several columns, fed chunk by chunk (as :func:`_block_means` of the whole columns).

    A long log's figure needs only these: memory n / block rows, not n.
    The last, partial block is dropped unless it is the only one.
    """

    def __init__(self, block: int):
        self.block = block
        self._names: list[str] = []
        self._means: list[np.ndarray] = []
        self._carry = np.zeros((0, 0))

    def add(self, columns: dict) -> None:
        """Take the next rows: a dict of equally long 1-D arrays, the same names every time."""
        self._names = list(columns)
        rows = np.column_stack([np.asarray(v, dtype=float) for v in columns.values()])
        if self._carry.size:
            rows = np.concatenate([self._carry, rows])
        n = len(rows) // self.block
        if n:
            self._means.append(rows[: n * self.block].reshape(n, self.block, -1).mean(axis=1))
        self._carry = rows[n * self.block :]

    def means(self) -> dict:
        """The block means by column name."""
        means = self._means or [self._carry.mean(axis=0, keepdims=True)]
        return dict(zip(self._names, np.concatenate(means).T))


def minmax_columns(x: np.ndarray, y: np.ndarray, columns: int) -> tuple[np.ndarray, np.ndarray]:
    """`y` against increasing `x` decimated for drawing: its minimum and maximum in each of `columns` equal spans of `x`.

    Returns the points of one line through each span's minimum and maximum
    in turn (two a span, empty spans left out), which a line of that many
    pixel columns draws as the whole series would: the same envelope, in
    4 x `columns` numbers whatever the series' length.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if len(x) <= 2 * columns:
        return x, y
    edges = np.searchsorted(x, np.linspace(x[0], x[-1], columns + 1)[1:-1])
    starts = np.unique(np.concatenate([[0], edges]))
    starts = starts[starts < len(x)]
    stops = np.append(starts[1:], len(x))
    low, high = np.minimum.reduceat(y, starts), np.maximum.reduceat(y, starts)
    centre = (x[starts] + x[stops - 1]) / 2.0
    return np.repeat(centre, 2), np.column_stack([low, high]).ravel()


def drift_figure(axes: Sequence[dict], *, block_s: float = DRIFT_BLOCK_S, title: str = ""):
    """Bias against temperature before and after compensation, and rate against time, one row per axis.

    Parameters
    ----------
    axes : sequence of dict
        One per gyro axis: ``name``; ``time_s``, ``temperature_c``,
        ``rate_dps`` (measured), ``compensated_dps`` (or None),
        ``temperature_rate_c_per_s`` (centred estimate, for the branches);
        ``model_temperature_c`` and ``model_dps``: the model's drift along
        a temperature grid at dT/dt = 0; ``segments`` (optional): the row
        ranges sampled without a gap.
    block_s : float
        The points are means over blocks of this length [s], so that the
        drift shows through the white noise; blocks are counted within each
        segment, and a segment shorter than a block is one point.

    Notes
    -----
    A block is *heating* or *cooling* when its mean dT/dt exceeds a tenth
    of the run's largest |dT/dt| in that direction, a *soak* otherwise.
    The left panel is the loop before compensation, with the model's
    static curve; with ``compensated_dps`` the middle panel is the same
    loop after it, on the same bias scale, each branch labelled with the
    standard deviation of its block means: a thermal lag or a hysteresis
    that the model leaves shows as heating and cooling apart.
    """
    after = any(ax.get("compensated_dps") is not None for ax in axes)
    fig = _figure(17.0 if after else 13.0, 4.2 * len(axes))
    ratios = [1.0, 1.0, 1.6] if after else [1.0, 1.6]
    grid = fig.subplots(len(axes), len(ratios), squeeze=False, width_ratios=ratios)
    for row, ax in zip(grid, axes):
        time = np.asarray(ax["time_s"], dtype=float)
        fs = 1.0 / float(np.median(np.diff(time))) if len(time) > 1 else 1.0
        block = max(1, int(round(block_s * fs)))
        segments = ax.get("segments")
        t_mean = _block_means(ax["temperature_c"], block, segments)
        r_mean = _block_means(ax["rate_dps"], block, segments) * 3600.0
        slope = _block_means(ax["temperature_rate_c_per_s"], block, segments)
        threshold = 0.1 * max(float(np.max(np.abs(slope))), 1e-12)
        branch = np.where(slope > threshold, "heating", np.where(slope < -threshold, "cooling", "soak"))
        before = row[0]
        _loop(before, t_mean, r_mean, branch, f"({block_s:g} s means)")
        before.plot(ax["model_temperature_c"], np.asarray(ax["model_dps"]) * 3600.0, "k-", linewidth=1.8, label="model, dT/dt = 0")
        before.set(xlabel="temperature [degC]", ylabel="bias [deg/h]", title=f"{ax['name']}: bias against temperature")
        before.legend(fontsize=7, loc="best")
        c_mean = None if ax.get("compensated_dps") is None else _block_means(ax["compensated_dps"], block, segments) * 3600.0
        if after:
            loop = row[1]
            loop.sharey(before)
            if c_mean is not None:
                _loop(loop, t_mean, c_mean, branch, "std {std:.3g} deg/h")
                loop.axhline(0.0, color="k", linewidth=0.8)
                loop.legend(fontsize=7, loc="best")
            loop.set(xlabel="temperature [degC]", ylabel="residual bias [deg/h]", title=f"{ax['name']}: after compensation")
        right = row[-1]
        hours = _block_means(time - time[0], block, segments) / 3600.0
        right.plot(hours, r_mean, color="0.45", linewidth=1.0, label="raw")
        if c_mean is not None:
            right.plot(hours, c_mean, color="tab:green", linewidth=1.0, label="compensated")
        right.set(xlabel="time [h]", ylabel=f"rate, {block_s:g} s means [deg/h]", title=f"{ax['name']}: rate against time")
        right.grid(True, alpha=0.3)
        twin = right.twinx()
        twin.plot(hours, t_mean, color="tab:purple", linewidth=0.9, alpha=0.7, label="temperature")
        twin.set_ylabel("temperature [degC]", color="tab:purple")
        lines = right.get_lines() + twin.get_lines()
        right.legend(lines, [line.get_label() for line in lines], fontsize=7, loc="upper right")
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def _loop(ax, temperature, bias, branch, note: str) -> None:
    """Block means of bias against temperature, one colour per branch; ``note`` may name ``{std}``, the branch's std [deg/h]."""
    for name in ("soak", "heating", "cooling"):
        mask = branch == name
        if mask.any():
            label = f"{name} " + note.format(std=float(np.std(bias[mask])))
            ax.plot(temperature[mask], bias[mask], ".", color=_BRANCH_COLOURS[name], markersize=3, label=label)
    ax.grid(True, alpha=0.3)


def components_figure(time_s, components: Sequence[tuple], *, title: str = ""):
    """The components stacked, fastest first, each labelled with its class when known.

    Parameters
    ----------
    time_s : array_like
    components : sequence of (name, values, class or None)
        Values in deg/s; class one of noise, mixed, drift (``classify``).
    """
    fig = _figure(10.0, 0.95 * len(components) + 1.2)
    _draw_components(fig, time_s, components, title)
    return fig


def classes_figure(time_s, components: Sequence[tuple], entries: Sequence[dict], settings):
    """``classify --plot``: the entropy per component with the thresholds, beside the components labelled by class."""
    fig = _figure(16.0, max(4.0, 0.95 * len(components) + 1.2))
    left, right = fig.subfigures(1, 2, width_ratios=[1.0, 1.6])
    _draw_entropies(left, entries, settings)
    _draw_components(right, time_s, components, "")
    return fig


def _draw_components(fig, time_s, components, title) -> None:
    time = np.asarray(time_s, dtype=float)
    hours = (time - time[0]) / 3600.0
    rows = fig.subplots(len(components), 1, sharex=True, squeeze=False)[:, 0]
    pixels = int(np.ceil(fig.get_figure(root=True).get_figwidth() * _MAX_DPI))
    for row, (name, values, cls) in zip(rows, components):
        row.plot(*minmax_columns(hours, values, pixels), color=CLASS_COLOURS.get(cls, "0.3"), linewidth=0.6)
        row.set_ylabel(name if cls is None else f"{name}\n{cls}", rotation=0, ha="right", va="center", fontsize=8)
        row.tick_params(labelsize=7)
        row.grid(True, alpha=0.3)
    rows[-1].set_xlabel("time [h]")
    fig.suptitle(title or "components [deg/s], fastest first", fontsize=10)


def allan_figure(series: Sequence, *, unit: str = "deg/s"):
    """Allan deviation of several series with bands, slope guides and the N, B, K read-offs.

    Parameters
    ----------
    series : sequence of gyrocomp.allan.AllanSeries
        One colour each (one per axis).

    Notes
    -----
    The guides are lines of slope -1/2, 0 and +1/2 through the first
    read-off of each term among the series (angle random walk N at tau = 1 s,
    bias instability B at the curve's minimum, rate random walk K at
    tau = 3 s), or through the first curve's first point, minimum and last
    point when no series has that read-off. Each series marks its own read-off points (triangle down N,
    circle B, triangle up K) and gives their values in the legend, where
    labels of several series cannot collide.
    """
    from matplotlib.lines import Line2D

    fig = _figure(8.0, 5.6)
    ax = fig.add_subplot()
    colours = [f"C{i}" for i in range(10)]
    handles = []
    for i, s in enumerate(series):
        colour = colours[i % len(colours)]
        tau, adev = np.asarray(s.tau_s), np.asarray(s.adev)
        ax.fill_between(tau, s.adev_lo, s.adev_hi, color=colour, alpha=0.18, linewidth=0)
        ax.loglog(tau, adev, "-", color=colour, linewidth=1.3)
        points, text = _readoff_points(s)
        for key, (x, y) in points.items():
            ax.loglog([x], [y], {"arw": "v", "bias_instability": "o", "rrw": "^"}[key], color=colour, markersize=8, markeredgecolor="k")
        label = s.name if s.column == "rate" else f"{s.name} [{s.column}]"
        handles.append(Line2D([], [], color=colour, label=f"{label}: {text}"))
    if series:
        low = min(float(np.min(np.asarray(x.adev_lo)[np.asarray(x.adev_lo) > 0], initial=np.inf)) for x in series)
        low = min([low] + [y for x in series for _, y in _readoff_points(x)[0].values() if y > 0])  # every marked point shows
        high = max(float(np.max(x.adev_hi)) for x in series)
        _slope_guides(ax, series)
        if np.isfinite(low) and high > 0:
            ax.set_ylim(low / 2.0, high * 2.0)  # the guides do not stretch the range beyond the curves and their points
    level = series[0].confidence if series else 0.683
    ax.set_xlabel("averaging time tau [s]")
    ax.set_ylabel(f"overlapping Allan deviation [{unit}]")
    ax.set_title(f"Allan deviation ({level:.1%} bands); v N at 1 s, o B at the minimum, ^ K at 3 s", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    if handles:
        ax.legend(handles=handles, fontsize=7, loc="lower left")
    return fig


def _readoff_points(s) -> tuple[dict, str]:
    """(tau, sigma) of each read-off and a one-line summary; sigma from the read-off's definition."""
    terms = s.terms
    points, parts = {}, []
    arw = terms["arw"].get("readoff")
    if arw is not None:
        points["arw"] = (1.0, ieee952.from_datasheet("arw", arw))  # sigma(1 s) = N
    b, b_tau = terms["bias_instability"].get("readoff"), terms["bias_instability"].get("readoff_tau_s")
    if b is not None and b_tau is not None:
        points["bias_instability"] = (float(b_tau), float(np.interp(np.log(b_tau), np.log(s.tau_s), s.adev)))
    rrw = terms["rrw"].get("readoff")
    if rrw is not None:
        points["rrw"] = (3.0, ieee952.from_datasheet("rrw", rrw))  # sigma(3 s) = K
    parts.append(f"N {arw:.3g}" if arw is not None else "N -")
    parts.append(f"B {b:.3g}" if b is not None else "B -")
    parts.append(f"K {rrw:.3g}" if rrw is not None else "K -")
    return points, ", ".join(parts)


def _slope_guides(ax, series) -> None:
    """Lines of slope -1/2, 0, +1/2 through the first read-off of that term among the series, else through the first curve."""
    first = series[0]
    tau, adev = np.asarray(first.tau_s), np.asarray(first.adev)
    i_min = int(np.argmin(adev))
    fallback = {"arw": (tau[0], adev[0]), "bias_instability": (tau[i_min], adev[i_min]), "rrw": (tau[-1], adev[-1])}
    points = [_readoff_points(s)[0] for s in series]
    span = np.geomspace(min(float(s.tau_s[0]) for s in series), max(float(s.tau_s[-1]) for s in series), 50)
    for key, slope in (("arw", -0.5), ("bias_instability", 0.0), ("rrw", 0.5)):
        x0, y0 = next((p[key] for p in points if key in p), fallback[key])
        y = y0 * (span / x0) ** slope
        ax.loglog(span, y, ":", color="0.4", linewidth=0.9)
        j = {-0.5: 2, 0.0: len(span) // 2, 0.5: -6}[slope]
        ax.annotate(f"slope {'+' if slope > 0 else ''}{slope:g}", (span[j], y[j]), fontsize=7, color="0.3",
                    xytext=(0, 4), textcoords="offset points")


def entropies_figure(entries: Sequence[dict], settings):
    """Bar chart of the entropy per component, coloured by class, with the thresholds (the papers' Fig. 10).

    An infinite sample entropy is drawn at the top of the axis.
    """
    fig = _figure(max(5.0, 0.6 * len(entries) + 2), 3.5)
    _draw_entropies(fig, entries, settings)
    return fig


def _draw_entropies(fig, entries, settings) -> None:
    values = np.array([e["entropy"] for e in entries], dtype=float)
    finite = values[np.isfinite(values)]
    cap = 1.1 * max(float(finite.max()) if finite.size else 0.0, settings.noise_above)
    shown = np.where(np.isfinite(values), values, cap)
    ax = fig.add_subplot()
    ax.bar([e["name"] for e in entries], shown, color=[CLASS_COLOURS[e["class"]] for e in entries])
    ax.axhline(settings.noise_above, color="k", linestyle="--", linewidth=1, label=f"noise above {settings.noise_above:g}")
    ax.axhline(settings.drift_below, color="k", linestyle=":", linewidth=1, label=f"drift below {settings.drift_below:g}")
    ax.set_ylabel("permutation entropy (normalised)" if settings.entropy == "permutation" else "sample entropy [nats]")
    ax.set_xlabel("component")
    ax.tick_params(axis="x", labelrotation=45)
    ax.legend(loc="upper right", fontsize="small")


def method_label(row: dict, with_axis: bool = False) -> str:
    """``method (mode)`` of a ``run`` report row, followed by ``[axis]`` when `with_axis` (a report of several axes).

    The one label of a method in ``report.md`` (:mod:`gyrocomp.pipeline.report`)
    and ``report.png``.
    """
    label = row["method"] if row["mode"] is None else f"{row['method']} ({row['mode']})"
    return f"{label} [{row['axis']}]" if with_axis and row.get("axis") is not None else label


def report_figure(report: dict):
    """``run``'s report: Allan deviation, 100 s means over time and signal survival, one panel each."""
    several = len(report.get("axes", ())) > 1
    fig = _figure(17.0, 5.2)
    axes = fig.subplots(1, 3)
    for row in report["rows"]:
        label = method_label(row, several)
        style = {"color": "k", "lw": 2} if row["method"] == "raw" else {"lw": 1.2, "ls": "--" if row["mode"] == "causal" else "-"}
        axes[0].loglog(row["allan"]["tau_s"], np.asarray(row["allan"]["adev"]) * 3600, label=label, **style)
        means = np.asarray(row["means_dph"])
        block = row["residual_drift"]["block_s"]
        axes[1].plot((np.arange(means.size) + 0.5) * block / 3600, means, label=label, **style)
    axes[0].set(xlabel="tau [s]", ylabel="Allan deviation [deg/h]", title="Allan deviation (test run)")
    axes[1].set(xlabel="time [h]", ylabel="block mean [deg/h]", title="Residual drift: 100 s means")
    axes[0].grid(True, which="both", alpha=0.3)
    axes[1].grid(True, alpha=0.3)
    axes[0].legend(fontsize=7)
    kept = [r for r in report["rows"] if r.get("signal")]
    parts = report["signal"]["parts"]
    width = 0.8 / max(len(parts), 1)
    x = np.arange(len(kept))
    for i, part in enumerate(parts):
        axes[2].bar(x + i * width, [100 * r["signal"]["parts"][part] for r in kept], width, label=part)
    axes[2].axhline(100, color="k", lw=0.8)
    axes[2].set_xticks(x + width * (len(parts) - 1) / 2, [method_label(r, several) for r in kept], rotation=35, ha="right", fontsize=7)
    axes[2].set(ylabel="signal kept [%]", title="Injected angular rate that survives")
    axes[2].legend(fontsize=7)
    return fig


def gap_figure(report: dict):
    """``diagnose``: residual RMS by regime and ADEV ratio by tau, baseline against selected, one row per run;
    the selected model's parameters with their 1-sigma uncertainties as the title."""
    import textwrap

    from gyrocomp.diagnose.report import format_value, selected_rows

    runs = [r for r in ("fit", "holdout") if r in report["localization"]]
    fig = _figure(12.0, 4.0 * len(runs))
    axes = fig.subplots(len(runs), 2, squeeze=False)
    for row, run in zip(axes, runs):
        loc = report["localization"][run]
        regimes = list(loc["baseline"]["regime"])
        x = np.arange(len(regimes))
        for k, (model, color) in enumerate((("baseline", "tab:red"), ("selected", "tab:blue"))):
            vals = [loc[model]["regime"].get(r, {}).get("rms_deg_h", np.nan) for r in regimes]
            row[0].bar(x + (k - 0.5) * 0.4, vals, width=0.4, color=color, label=model)
        noise = [loc["selected"]["regime"].get(r, {}).get("expected_rms_deg_h", np.nan) for r in regimes]
        row[0].plot(x, noise, "k_", markersize=14, label="noise (selected model)")
        row[0].set_xticks(x, regimes, rotation=45, ha="right", fontsize=8)
        row[0].set_ylabel("residual 100 s RMS [deg/h]")
        row[0].set_title(f"{run}: gap by regime")
        row[0].legend(fontsize=8)
        for model, color in (("baseline", "tab:red"), ("selected", "tab:blue")):
            ts = loc[model]["timescale"]["adev"]
            row[1].semilogx([p["tau_s"] for p in ts], [p["ratio"] for p in ts], "o-", color=color, label=model)
        row[1].axhline(1.0, color="k", lw=0.8)
        row[1].set_xlabel("tau [s]")
        row[1].set_ylabel("ADEV residual / ADEV simulation")
        row[1].set_title(f"{run}: gap by timescale (gap {format_value(report['gap']['baseline'][run])} -> {format_value(report['gap']['selected'][run])})")
        row[1].legend(fontsize=8)
    rows = selected_rows(report)
    if rows:
        words = "; ".join(f"{e} {k} = {v}" + (f" ± {d}" if d and d != "not estimated" else "") + (f" {u}" if u else "") for e, k, v, d, u in rows)
        fig.suptitle(textwrap.fill("selected model (± 1 sigma): " + words, 150), fontsize=8)
    return fig


def model_curve(model, n: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """A model's drift [deg/s] along its training temperature range at dT/dt = 0 (clamped inputs)."""
    lo, hi = model.temperature_range_c
    temperature = np.linspace(lo, hi, n)
    if model.kind == "greybox":  # a state-space model: its settled bias at each temperature
        return temperature, model.static(temperature)
    X = np.column_stack([temperature, np.zeros(n)])
    return temperature, np.sum(list(model.predict(X, clamp=True).values()), axis=0)


def drift_axis_from_means(name: str, parts: Sequence[dict], model) -> dict:
    """One :func:`drift_figure` axis from the :class:`BlockMeans` of each gap-free segment (``time``, ``temperature``, ``rate``, ``compensated``).

    dT/dt, which only splits the points into branches, is the centred
    difference of the temperature's block means within each segment.
    """
    joined = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    bounds = np.cumsum([0, *(len(p["time"]) for p in parts)])
    slope = [np.gradient(p["temperature"], p["time"]) if len(p["time"]) > 1 else np.zeros(len(p["time"])) for p in parts]
    grid, drift = model_curve(model)
    return {
        "name": name,
        "time_s": joined["time"],
        "temperature_c": joined["temperature"],
        "rate_dps": joined["rate"],
        "compensated_dps": joined.get("compensated"),
        "temperature_rate_c_per_s": np.concatenate(slope),
        "model_temperature_c": grid,
        "model_dps": drift,
        "segments": [slice(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])],
    }


def drift_axis(name: str, time_s, temperature_c, rate_dps, compensated_dps, model, segments: Sequence[slice] | None = None) -> dict:
    """One :func:`drift_figure` axis: a run's columns and the model compensating it (its curve at dT/dt = 0, the branches by the centred dT/dt); `segments` the run's gap-free row ranges."""
    time = np.asarray(time_s, dtype=float)
    temperature = np.asarray(temperature_c, dtype=float)
    fs = 1.0 / float(np.median(np.diff(time))) if len(time) > 1 else 1.0
    grid, drift = model_curve(model)
    return {
        "name": name,
        "time_s": time,
        "temperature_c": temperature,
        "rate_dps": np.asarray(rate_dps, dtype=float),
        "compensated_dps": None if compensated_dps is None else np.asarray(compensated_dps, dtype=float),
        "temperature_rate_c_per_s": model.inputs(temperature, fs, causal=False)[:, 1],
        "model_temperature_c": grid,
        "model_dps": drift,
        "segments": segments,
    }
