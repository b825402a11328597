"""The diagnosis as JSON (schema ``gyrocomp.diagnosis``), markdown, a rich table and a plot."""

from __future__ import annotations

from gyrocomp.artefacts import artefact_header
from gyrocomp.diagnose.competing import sentence

__all__ = ["to_json", "to_markdown", "summary_table", "selected_rows", "format_value"]


def to_json(body: dict, *, inputs: list, settings: dict) -> dict:
    """Header (:func:`gyrocomp.artefacts.artefact_header`) + the body of :func:`gyrocomp.diagnose.diagnose`."""
    out = artefact_header("gyrocomp.diagnosis", inputs=inputs, settings=settings, seed=None)
    out.update({k: v for k, v in body.items() if k != "settings"})
    out["gap_definition"] = (
        "G = sqrt(max(0, D^2 + S - E0)): D = ln(variance of the 100 s residual means / the noise "
        "model's expectation, Barnes B1), S = mean over octave taus of ln^2(ADEV residual / ADEV model), "
        "E0 their expectation for a recording that is the calibrated simulation; dimensionless, 0 = no gap; "
        "noise_level: the 95th percentile of G for such a recording (a gap below it is within sampling noise)"
    )
    return out


def to_markdown(report: dict) -> str:
    """A short human-readable report."""
    sel = report["selected_effects"]
    lines = ["# Sim-to-real gap diagnosis", ""]
    names = ", ".join(i["name"] for i in report.get("inputs", []))
    if names:
        lines += [f"Recordings: {names}", ""]
    lines.append("**Selected effects:** " + _selected_words(report, code=True))
    rows = selected_rows(report)
    if rows:
        lines += ["", "## Selected model (fitted jointly on the selection runs)", "", "| effect | parameter | value | ± 1 sigma | unit |", "|---|---|---|---|---|"]
        lines += [f"| `{e}` | {k} | {v} | {d} | {u} |" for e, k, v, d, u in rows]
    blind = _no_temperature_line(report)
    if blind:
        lines += ["", blind]
    lines += [""] + _unexplained_lines(report)
    rivals = _competing_sentences(report)
    if rivals:
        lines += ["", "**Competing explanations** (a listed noise term against one time-local event per run, each beside the other "
                  "in BIC):", ""] + [f"- {r}" for r in rivals]
    lines += ["", "| model | gap fit | gap holdout |", "|---|---|---|"]
    for name in ("baseline", "selected"):
        g = report["gap"][name]
        lines.append(f"| {name} | {format_value(g['fit'])} | {format_value(g['holdout'])} |")
    lines.append("| sampling noise (95 %) | {} | {} |".format(*_noise_levels(report)))
    protocol = report["gap"].get("protocol")
    if protocol:
        lines += ["", f"Held-out protocol: {protocol['description']}."]
    rate = (report.get("selection") or {}).get("error_rate")
    if rate:
        lines += ["", f"Error rates: {rate['statement']}."]
    if report.get("gap_note"):
        lines += ["", report["gap_note"] + "."]
    lines += [
        "",
        "## Candidates, each fitted alone beside the baseline",
        "",
        "One-at-a-time fits: each candidate's parameters without the other effects; the selected model's are above.",
        "",
        "| candidate | gap fit | gap holdout | delta BIC | parameters (fitted alone) | detection limit |",
        "|---|---|---|---|---|---|",
    ]
    for effect, c in report["candidates"].items():
        params = ", ".join(f"{k} = {format_value(v['value'])} {v['unit']}" for k, v in c["params"].items())
        lines.append(
            f"| `{effect}` | {format_value(c['gap_fit'])} | {format_value(c['gap_holdout'])} | {format_value(c['delta_bic'])} | {params} "
            f"| {_limit(effect, c, sel)} |"
        )
    power = report.get("settings", {}).get("detection_power")
    lines += [
        "",
        "Detection limit: for an effect not selected, the weakest amplitude (thermal lag: time constant) "
        f"an ideal detector would find beside the selected model with probability {format_value(power)}: looked for and "
        "absent. A candidate the selection runs cannot identify at any amplitude is marked \"not identifiable from these "
        "runs\" instead, with the reason.",
    ]
    if report.get("skipped"):
        lines += ["", "Skipped:"] + [f"- `{e}`: {why}" for e, why in report["skipped"].items()]
    loc = report["localization"].get("fit", {})
    if loc:
        lines += ["", "## Where (fit recording, residual 100 s RMS in deg/h)", "", "| regime | baseline | selected | noise |", "|---|---|---|---|"]
        base, selected = loc["baseline"]["regime"], loc["selected"]["regime"]
        for regime, v in base.items():
            after = selected.get(regime, {}).get("rms_deg_h")
            lines.append(f"| {regime} | {format_value(v['rms_deg_h'])} | {format_value(after)} | {format_value(v['expected_rms_deg_h'])} |")
    lines.append("")
    lines.append(report.get("gap_definition", ""))
    return "\n".join(lines) + "\n"


def summary_table(report: dict):
    """The selected model's parameters and a table of the gap before and after, per candidate (a :class:`rich.console.Group`)."""
    from rich.console import Group
    from rich.table import Table

    sel = report["selected_effects"]
    un = report.get("unexplained") or {}
    caption = None
    if un.get("present"):
        caption = "NOT EXPLAINED -- " + "; ".join(un["hints"]) + "; " + _size_words(un)
    table = Table(title="selected: " + _selected_words(report), caption=caption)
    for col in ("model / candidate", "gap fit", "gap holdout", "delta BIC", "detection limit"):
        table.add_column(col, justify="left" if col in ("model / candidate", "detection limit") else "right")
    for name in ("baseline", "selected"):
        g = report["gap"][name]
        table.add_row(name, format_value(g["fit"]), format_value(g["holdout"]), "", "")
    table.add_row("sampling noise (95 %)", *_noise_levels(report), "", "")
    for effect, c in report["candidates"].items():
        mark = " *" if effect in sel else ""
        table.add_row(f"+ {effect}{mark}", format_value(c["gap_fit"]), format_value(c["gap_holdout"]), format_value(c["delta_bic"]), _limit(effect, c, sel))
    parts = []
    rows = selected_rows(report)
    if rows:
        model = Table(title="selected model (fitted jointly)")
        for col in ("effect", "parameter", "value", "± 1 sigma", "unit"):
            model.add_column(col, justify="right" if col in ("value", "± 1 sigma") else "left")
        for row in rows:
            model.add_row(*row)
        parts.append(model)
    rivals = "\n".join(f"competing: {r}" for r in _competing_sentences(report))
    table.caption = "\n".join(x for x in (caption, rivals, _no_temperature_line(report)) if x) or None
    return Group(*parts, table)


def selected_rows(report):
    """``(effect, parameter, value, 1-sigma, unit)`` of every selected effect, from the selected model's joint fit
    (the uncertainty blank for a form's name, "not estimated" where the likelihood's curvature does not give one)."""
    params = ((report.get("models") or {}).get("selected") or {}).get("params", {})
    return [(effect, name, format_value(v["value"]), _sigma(v), v["unit"]) for effect in report["selected_effects"]
            for name, v in params.get(effect, {}).items()]


def _sigma(entry):
    if "uncertainty" not in entry:
        return ""
    return "not estimated" if entry["uncertainty"] is None else format_value(entry["uncertainty"])


def _competing_sentences(report):
    """One sentence per competing explanation where the pair prefers the event or cannot tell (:func:`gyrocomp.diagnose.competing.sentence`)."""
    return [sentence(entry) for entry in report.get("competing") or [] if entry["verdict"] != "noise"]


def _no_temperature_line(report):
    """One sentence on what a recording without temperature cannot tell apart, or None."""
    if not any(str(why).startswith("no temperature column") for why in (report.get("skipped") or {}).values()):
        return None
    return ("No temperature channel: a drift that follows temperature cannot be told from a slow noise "
            "(rate random walk, bias instability) or a drift in time, so the temperature effects are not "
            "judged, and a noise term or time effect listed here may stand for a thermal drift.")


def _selected_words(report, code=False):
    """The selected effects in words; never "explains" when the residual holds unexplained structure."""
    sel = report["selected_effects"]
    present = (report.get("unexplained") or {}).get("present", False)
    if sel:
        names = ", ".join(f"`{e}`" if code else e for e in sel)
        return names + (" (the recording is NOT explained by them: see unexplained)" if present else "")
    if present:
        return "none from the vocabulary; the recording is NOT explained (see unexplained)"
    return "none (the baseline explains the recording)"


def _size_words(un):
    """``rms ... deg/h (share of the gap ...)`` per run of the unexplained part."""
    parts = []
    for run, v in un.get("size", {}).items():
        share = v.get("share_of_gap")
        parts.append(f"{run}: rms {format_value(v['rms_deg_h'])} deg/h" + ("" if share is None else _share_words(share)))
    return "unexplained part " + "; ".join(parts)


def _share_words(share):
    """The share of the gap in words: below 1 % it is small, not zero (the structure is significant)."""
    if share < 0.01:
        return ", under 1 % of the gap (significant, but small beside the gap)"
    return f", {100 * share:.0f} % of the gap"


def _unexplained_lines(report):
    """The markdown paragraph of the ``unexplained`` verdict."""
    un = report.get("unexplained")
    if not un:
        return []
    rate = f"family false-alarm rate {100 * un['family_alpha']:g} %"
    if un.get("signature_alpha"):
        rate += f", and {100 * un['signature_alpha']:g} % per selected noise term's signature"
    if not un["present"]:
        return [f"**Unexplained:** no structure the selected model does not predict ({rate})."]
    lines = [f"**Unexplained: present** -- the residual holds structure the selected model does not predict ({rate}):", ""]
    lines += [f"- {h}" for h in un["hints"]]
    lines += ["", _size_words(un) + "."]
    return lines


def _noise_levels(report):
    """The selected model's gap ``noise_level`` on the fit and holdout runs, formatted (None where absent)."""
    parts = report["gap"]["selected"]["parts"]
    return tuple(format_value(parts[run]["noise_level"] if run in parts else None) for run in ("fit", "holdout"))


def _limit(effect, candidate, selected):
    """``>= value unit`` of a candidate's detection limit, ``selected`` or ``beyond range``."""
    if effect in selected:
        return "selected"
    if candidate.get("not_identifiable"):
        needs = candidate.get("holdout_needs")
        if not needs:
            return candidate["not_identifiable"]
        return (f"{candidate['not_identifiable']}; the holdout needs it (p = {needs['p']:.2g}): give that run to the selection "
                f"(--holdout {needs['holdout']} --holdout <another run>)")
    limit = candidate.get("detection_limit")
    if not limit:
        return "beyond search range"
    return ", ".join(f"{k} >= {format_value(v['value'])} {v['unit']}" for k, v in limit.items())


def format_value(v):
    """A report number for tables and titles: ``-`` for None, 3 significant digits when very large or small, else 3 decimals."""
    if v is None:
        return "-"
    if isinstance(v, float) and (abs(v) >= 1e4 or (v != 0 and abs(v) < 1e-3)):
        return f"{v:.3g}"
    return f"{v:.3f}" if isinstance(v, float) else str(v)
