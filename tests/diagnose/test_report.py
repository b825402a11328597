"""The diagnosis' markdown and terminal summaries (gyrocomp.diagnose.report) against the report they are made from.

Issue 37: the summaries printed one-at-a-time fits beside "selected" (the
sample pair's thermal lag alone takes tau = 2 s; the selected model's is
381 s), said "NOT EXPLAINED" beside "0 % of the gap", and said nothing on
what a recording without temperature cannot tell apart.
"""

import pytest
from rich.console import Console

from gyrocomp.diagnose.report import summary_table, to_markdown


def _report(share=0.0, skipped=None):
    parts = {"fit": {"noise_level": 0.1}, "holdout": {"noise_level": 0.1}}
    return {
        "selected_effects": ["thermal_lag"],
        "skipped": skipped or {},
        "models": {"selected": {"params": {"thermal_lag": {"tau_s": {"value": 381.0, "unit": "s"}}}}},
        "gap": {m: {"fit": 1.0, "holdout": 1.0, "parts": parts} for m in ("baseline", "selected")},
        "candidates": {"thermal_lag": {"params": {"tau_s": {"value": 2.0, "unit": "s"}}, "gap_fit": 1.0, "gap_holdout": 1.0,
                                       "delta_bic": -50.0, "detection_limit": None, "not_identifiable": None},
                       "hysteresis": {"params": {}, "gap_fit": 1.0, "gap_holdout": 1.0, "delta_bic": 3.0, "detection_limit": None,
                                      "not_identifiable": "not identifiable from these runs: its branch never changes"}},
        "localization": {},
        "selection": {"error_rate": {"statement": "named effects: at most 0.00021"}},
        "unexplained": {"present": True, "family_alpha": 0.01, "hints": ["fit: a step of +3.6 deg/h at 0.03 h"],
                        "size": {"fit": {"rms_deg_h": 1.7, "share_of_gap": share}}},
    }


def _terminal(report):
    console = Console(width=300, record=True)
    console.print(summary_table(report))
    return console.export_text()


@pytest.mark.parametrize("render", [to_markdown, _terminal])
def test_the_selected_models_parameters_are_shown_and_the_alone_fits_are_labelled(render):
    text = render(_report())
    assert "381.000" in text and "fitted jointly" in text
    assert "not identifiable from these runs: its branch never changes" in text
    if render is to_markdown:
        assert "tau_s = 2.000 s" in text and "parameters (fitted alone)" in text
        assert "Error rates: named effects: at most 0.00021." in text


@pytest.mark.parametrize("render", [to_markdown, _terminal])
def test_a_small_unexplained_part_is_not_called_zero(render):
    text = render(_report(share=0.001))
    assert "0 % of the gap" not in text and "under 1 % of the gap" in text
    assert "80 % of the gap" in render(_report(share=0.8))


@pytest.mark.parametrize("render", [to_markdown, _terminal])
def test_a_recording_without_temperature_says_what_it_cannot_tell_apart(render):
    assert "No temperature channel" not in render(_report())
    text = render(_report(skipped={"temp_rate": "no temperature column: temperature polynomial and temperature effects skipped"}))
    assert "No temperature channel" in text and "cannot be told from a slow noise" in text.replace("\n", " ").replace("  ", " ")


@pytest.mark.parametrize("render", [to_markdown, _terminal])
def test_a_candidate_the_holdout_needs_but_the_selection_cannot_identify_says_which_run_to_add(render):
    report = _report()
    report["candidates"]["hysteresis"]["holdout_needs"] = {"p": 3e-8, "holdout": "oven_test.parquet"}
    text = " ".join(render(report).split())
    assert ("its branch never changes; the holdout needs it (p = 3e-08): give that run to the selection "
            "(--holdout oven_test.parquet --holdout <another run>)") in text
