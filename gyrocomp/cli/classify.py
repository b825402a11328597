"""``gyrocomp classify``: entropy and class (noise / mixed / drift) of each component."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, List, Optional

import typer

from gyrocomp.cli._app import app, console_for, report_errors


@app.command()
def classify(
    ctx: typer.Context,
    components: Annotated[Path, typer.Argument(help="components.parquet written by `gyrocomp decompose`.")],
    out: Annotated[str, typer.Option("--out", "-o", help="classes.json to write; - writes to stdout.")] = ...,
    entropy: Annotated[
        Optional[str],
        typer.Option("--entropy", help="permutation (Cao et al. 2021) or sample (Zhang et al. 2024); default: the config's."),
    ] = None,
    config: Annotated[
        Optional[str],
        typer.Option("--config", help="Pipeline TOML (path or name in configs/); its [classify] table is read. Default: the PE-LCD-ANFIS settings."),
    ] = None,
    assignments: Annotated[
        Optional[List[str]],
        typer.Option("--set", help="Override a setting, e.g. --set classify.sample.m=3 (repeatable)."),
    ] = None,
    plot: Annotated[Optional[Path], typer.Option("--plot", help="PNG bar chart of the entropy per component with the thresholds (the papers' Fig. 10).")] = None,
) -> None:
    """Classify each component as noise, mixed or drift by its entropy.

    Normalised permutation entropy (thresholds 0.6 / 0.4) or sample entropy
    (0.6 / 0.1): above the upper threshold noise, below the lower one drift,
    in between (inclusive) mixed. Writes classes.json with the entropy
    settings and thresholds used.
    """
    with report_errors(ctx):
        import dataclasses
        import hashlib

        from gyrocomp import config as cfg
        from gyrocomp import io
        from gyrocomp.classify import ClassifySettings, classify as run_classify
        from gyrocomp.errors import InputError

        table, source = {}, "defaults [classify]"
        if config is not None or assignments:
            whole = cfg.load_config(config) if config is not None else {}
            whole = cfg.apply_overrides(whole, assignments or ())
            table, source = dict(whole.get("classify", {})), f"{config or '--set'} [classify]"
        settings = cfg.bind(ClassifySettings, table, source)
        if entropy is not None:
            settings = cfg.bind(ClassifySettings, {**table, "entropy": entropy}, f"--entropy {entropy}")
        frame, header = io.read_table(components, "gyrocomp.components")
        names = header.get("components")
        if not isinstance(names, list) or not names:
            raise InputError(f"{components}: header lists no `components`")
        missing = [n for n in names if n not in frame.columns]
        if missing:
            raise InputError(f"{components}: component column {missing[0]!r} listed in the header is missing")
        entries = run_classify(frame[names].to_numpy(dtype=float).T, names, settings)
        sha = hashlib.sha256(Path(components).read_bytes()).hexdigest()
        result = io.artefact_header(
            "gyrocomp.classes",
            inputs=[{"name": Path(components).name, "sha256": sha}],
            settings=cfg.settings_dict(settings),
        )
        result["entropy"] = {"kind": settings.entropy, **dataclasses.asdict(settings.active)}
        result["thresholds"] = {"noise_above": settings.noise_above, "drift_below": settings.drift_below}
        result["components"] = entries
        io.write_json(out, result)
        if plot is not None:
            _plot(plot, entries, settings)
    _print_table(console_for(ctx, out), entries, settings)


def _print_table(console, entries, settings) -> None:
    from rich.table import Table

    label = "PE (normalised)" if settings.entropy == "permutation" else "SampEn [nats]"
    table = Table(
        title=f"{settings.entropy} entropy",
        caption=f"noise > {settings.noise_above:g} >= mixed >= {settings.drift_below:g} > drift",
    )
    table.add_column("component")
    table.add_column(label, justify="right")
    table.add_column("class")
    for e in entries:
        table.add_row(e["name"], f"{e['entropy']:.4f}", e["class"])
    console.print(table)


def _plot(path: Path, entries, settings) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from gyrocomp import io

    colours = {"noise": "tab:red", "mixed": "tab:orange", "drift": "tab:blue"}
    values = np.array([e["entropy"] for e in entries], dtype=float)
    finite = values[np.isfinite(values)]
    cap = 1.1 * max(float(finite.max()) if finite.size else 0.0, settings.noise_above)
    shown = np.where(np.isfinite(values), values, cap)  # an infinite SampEn drawn at the top
    fig, ax = plt.subplots(figsize=(max(5.0, 0.6 * len(entries) + 2), 3.5), constrained_layout=True)
    ax.bar([e["name"] for e in entries], shown, color=[colours[e["class"]] for e in entries])
    ax.axhline(settings.noise_above, color="k", linestyle="--", linewidth=1, label=f"noise above {settings.noise_above:g}")
    ax.axhline(settings.drift_below, color="k", linestyle=":", linewidth=1, label=f"drift below {settings.drift_below:g}")
    ax.set_ylabel("permutation entropy (normalised)" if settings.entropy == "permutation" else "sample entropy [nats]")
    ax.set_xlabel("component")
    ax.tick_params(axis="x", labelrotation=45)
    ax.legend(loc="upper right", fontsize="small")
    with io.atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120, metadata={"Software": None})
    plt.close(fig)
