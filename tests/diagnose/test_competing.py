"""Competing explanations (gyrocomp.diagnose.competing) on constructed pairs of runs.

The runs are numpy draws made here: white noise, a cubic in temperature, and
one of a bias step at a different time in each run (a mode hop), a Gaussian
bump (a transient) or a random walk (cumulative sums). The noise term is
fitted by :func:`gyrocomp.diagnose.select.extend` as the diagnosis would; the
event is never given to the code under test.
"""

import dataclasses

import numpy as np
import pytest
from rich.console import Console
from scipy.signal import lfilter

from gyrocomp.diagnose import DiagnoseSettings
from gyrocomp.diagnose import competing as cp
from gyrocomp.diagnose.effects import Run, TemperatureScale
from gyrocomp.diagnose.report import summary_table, to_markdown
from gyrocomp.diagnose.select import Problem, extend, fit_baseline
from gyrocomp.diagnose.settings import ChecksSettings
from gyrocomp.diagnose.unexplained import assess

N = 0.005  # white rate noise [deg/s/sqrt(Hz)]
K = 1.0 / 3600.0 / 60.0  # rate random walk of 1 deg/h/sqrt(h) [deg/s/sqrt(s)]
HOURS = 8.0


def _run(seed, kind, amp, at, rrw=0.0):
    """An 8 h run at 1 Hz in an oven ramping 20 -> 60 -> 20 degC, with the event at fraction `at` of the run."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(HOURS * 3600))
    temp = 20.0 + 40.0 * (1.0 - np.abs(2.0 * t / t[-1] - 1.0))
    x = N * rng.standard_normal(t.size) + 0.002 * (temp - 40.0) / 20.0
    x += np.cumsum(rrw * rng.standard_normal(t.size))
    if kind == "step":
        x += amp * (t >= at * t[-1])
    elif kind == "bump":
        x += amp * np.exp(-0.5 * ((t - at * t[-1]) / 1200.0) ** 2)
    return t, x, temp


def _compare(kind, amp, term="rate_random_walk", events=("step", "bump"), rrw=0.0, seed=0, settings=DiagnoseSettings()):
    recs = [_run(seed, kind, amp, 0.3, rrw), _run(seed + 1000, kind, amp, 0.6, rrw)]
    scale = TemperatureScale.of(recs[0][2])
    runs = [Problem(Run(f"run{k}", t, x, temp, 1.0, 40, 60.0), DiagnoseSettings(), scale, 3) for k, (t, x, temp) in enumerate(recs)]
    model = extend(runs[0], fit_baseline(runs[0]), term)
    return cp.compare([("fit", runs[0]), ("holdout", runs[1])], model, term, events, settings)


def test_a_mode_hop_is_named_one_step_per_run_at_its_times():
    # 7.2 deg/h steps at 2.4 h (fit) and 4.8 h (holdout), white noise 2.8 deg/h per 40 s block
    found = _compare("step", 0.002)
    step = found["step"]
    assert step["verdict"] == "event", step
    assert step["gain"]["noise_beside_event"] < 10.0 < step["gain"]["event_beside_noise"]
    for run, hours in zip(step["runs"], (0.3 * HOURS, 0.6 * HOURS)):
        assert abs(run["time_s"] / 3600.0 - hours) < 0.1, run  # within one merged block (120 s) and a bit
        assert run["size_deg_h"] == pytest.approx(7.2, rel=0.15)
    assert found["bump"]["verdict"] == "noise", found["bump"]  # a step is not a bump


def test_a_transient_is_named_one_bump_per_run_at_its_centres():
    # 10.8 deg/h Gaussian bumps of sigma 1200 s (full width at half height 0.78 h) at 2.4 h and 4.8 h
    found = _compare("bump", 0.003, term="bias_instability")
    bump = found["bump"]
    assert bump["verdict"] == "event", bump
    for run, hours in zip(bump["runs"], (0.3 * HOURS, 0.6 * HOURS)):
        assert abs(run["time_s"] / 3600.0 - hours) < 0.15, run
        assert 0.4 < run["width_s"] / 3600.0 < 1.6
        assert run["size_deg_h"] == pytest.approx(10.8, rel=0.2)
    assert found["step"]["verdict"] == "noise", found["step"]


def test_a_strong_random_walk_keeps_its_name():
    # 5 deg/h/sqrt(h): the wander is many steps, not one
    found = _compare("none", 0.0, rrw=5.0 * K, seed=1)
    assert {e: r["verdict"] for e, r in found.items()} == {"step": "noise", "bump": "noise"}
    assert found["step"]["gain"]["noise_beside_event"] > 100.0


def test_a_weak_random_walk_and_one_step_per_run_cannot_be_told_apart():
    # 1 deg/h/sqrt(h) over 8 h beside 2.8 deg/h of white noise per block: each alone gains over 100 in BIC,
    # neither beside the other -- the measured limit of one pair (benchmarks/oov_separability.py)
    step = _compare("none", 0.0, rrw=K, seed=1, events=("step",))["step"]
    assert step["verdict"] == "inseparable", step
    assert step["gain"]["noise"] > 100.0 and step["gain"]["event"] > 100.0


def test_runs_too_short_for_an_event_are_not_compared():
    # 8 h in 240 merged blocks of 120 s: no step lies 121 blocks from either end; the widest bumps
    # (full width 120 blocks) still hold 121 blocks inside the run and are compared
    short = dataclasses.replace(DiagnoseSettings(), checks=dataclasses.replace(ChecksSettings(), min_step_blocks=121))
    found = _compare("step", 0.002, settings=short)
    assert found["step"] is None and found["bump"]["verdict"] in cp.VERDICTS


@pytest.mark.parametrize(
    ("beside_event", "beside_noise", "alone", "verdict"),
    [(30.0, 2.0, 50.0, "noise"), (2.0, 30.0, 50.0, "event"), (30.0, 30.0, 50.0, "both"),
     (2.0, 2.0, 50.0, "inseparable"), (2.0, 2.0, 5.0, "noise")],
)
def test_the_verdict_table(beside_event, beside_noise, alone, verdict):
    gain = {"noise": 60.0, "event": alone, "noise_beside_event": beside_event, "event_beside_noise": beside_noise}
    assert cp._verdict(gain, 10.0) == verdict


def _report(entries):
    parts = {"fit": {"noise_level": 0.1}, "holdout": {"noise_level": 0.1}}
    return {"selected_effects": ["rate_random_walk"], "skipped": {}, "models": {}, "candidates": {}, "localization": {},
            "gap": {m: {"fit": 1.0, "holdout": 1.0, "parts": parts} for m in ("baseline", "selected")},
            "unexplained": {"present": False, "family_alpha": 0.01, "hints": [], "size": {}}, "competing": entries}


def _terminal(report):
    console = Console(width=400, record=True)
    console.print(summary_table(report))
    return " ".join(console.export_text().split())


@pytest.mark.parametrize("render", [to_markdown, _terminal])
def test_the_report_names_the_alternative_with_the_numbers_of_the_json(render):
    entry = {"term": "rate_random_walk", "event": "step", "verdict": "inseparable",
             "gain": {"noise": 215.04, "event": 216.93, "noise_beside_event": -6.21, "event_beside_noise": -4.33},
             "runs": [{"run": "fit", "time_s": 6732.0, "size_deg_h": -2.54}, {"run": "holdout", "time_s": 16680.0, "size_deg_h": 3.61}]}
    text = " ".join(render(_report([entry])).split())
    assert ("rate_random_walk or one step per run (fit: at 1.87 h, -2.5 deg/h; holdout: at 4.63 h, +3.6 deg/h): alone they gain "
            "215.0 and 216.9 in BIC, beside each other -6.2 and -4.3; this pair cannot tell them apart") in text
    preferred = " ".join(render(_report([dict(entry, verdict="event")])).split())
    assert "the pair prefers one step per run (fit: at 1.87 h, -2.5 deg/h; holdout: at 4.63 h, +3.6 deg/h) to rate_random_walk" in preferred
    quiet = dict(entry, verdict="noise")
    assert "one step per run" not in render(_report([quiet]))


@pytest.mark.parametrize(("p", "verdict"), [(0.0001, "event"), (0.004, "inseparable"), (0.2, "noise")])
def test_popcorn_against_a_flicker_is_read_from_its_signatures_levels_test(p, verdict):
    sig = {"alpha": 0.0005, "levels": {"p": p, "by": "two_levels", "two_levels_z": 2.9, "two_levels_gain": 14.0}}
    assert cp.two_levels(sig, 0.01)["verdict"] == verdict
    assert cp.two_levels({"alpha": None, "levels": None}, 0.01) is None  # a random walk has no levels test


@pytest.mark.parametrize("render", [to_markdown, _terminal])
def test_the_report_names_popcorn_with_its_evidence(render):
    entry = cp.two_levels({"alpha": 0.00042, "levels": {"p": 0.0031, "by": "two_levels", "two_levels_z": 2.74,
                                                       "two_levels_gain": 15.3}}, 0.01)
    text = " ".join(render(_report([entry])).split())
    assert ("bias_instability or popcorn (a noise switching between two levels): two levels gain 15.3 in log-likelihood over "
            "a Gauss-Markov wander, z = 2.7 against Gaussian draws; Gaussian-levels test p = 0.0031 (the signature refuses "
            "below 0.00042, the term's rate is 0.01)") in text


def test_a_flickers_signature_in_the_verdict_carries_its_levels_evidence():
    # a true 3 deg/h flicker (Gauss-Markov draws of 600 s here), both runs: the verdict's signature holds the levels test
    rng = np.random.default_rng(5)
    recs = []
    for k in range(2):
        t, x, temp = _run(20 + k, "none", 0.0, 0.5)
        a = np.exp(-1.0 / 600.0)
        w = rng.standard_normal(t.size) * 3.0 / 3600.0 * np.sqrt(1 - a * a)
        recs.append((t, x + lfilter([1.0], [1.0, -a], w), temp))
    scale = TemperatureScale.of(recs[0][2])
    runs = [Problem(Run(f"run{k}", t, x, temp, 1.0, 40, 60.0), DiagnoseSettings(), scale, 3) for k, (t, x, temp) in enumerate(recs)]
    model = extend(runs[0], fit_baseline(runs[0]), "bias_instability")
    verdict, _ = assess([("fit", runs[0]), ("holdout", runs[1])], model, DiagnoseSettings(), None)
    levels = verdict["signatures"]["bias_instability"]["levels"]
    assert 0.0 <= levels["p"] <= 1.0 and levels["by"] in ("kurtosis", "two_levels")
    entry = cp.competing([("fit", runs[0]), ("holdout", runs[1])], model, ["bias_instability"], verdict["signatures"])[-1]
    assert entry["event"] == "two_levels" and entry["levels"] == levels


def test_an_events_time_counts_the_gaps_of_a_run_in_segments():
    # the fit run's 8 h in two segments, 2 h of nothing between 3 h and 5 h: a step at 6.4 h of clock time
    t, x, temp = _run(0, "none", 0.0, 0.5)
    clock = np.where(t < 3 * 3600, t, t + 2 * 3600.0)
    x = x + 0.002 * (clock >= 6.4 * 3600)
    held = _run(1000, "step", 0.002, 0.6)
    scale = TemperatureScale.of(temp)
    runs = [Problem(Run("gapped", clock, x, temp, 1.0, 40, 60.0, gapped=True), DiagnoseSettings(), scale, 3),
            Problem(Run("held", *held[:2], held[2], 1.0, 40, 60.0), DiagnoseSettings(), scale, 3)]
    model = extend(runs[0], fit_baseline(runs[0]), "rate_random_walk")
    step = cp.compare([("fit", runs[0]), ("holdout", runs[1])], model, "rate_random_walk", ("step",))["step"]
    assert abs(step["runs"][0]["time_s"] / 3600.0 - 6.4) < 0.1, step["runs"]
    assert abs(step["runs"][1]["time_s"] / 3600.0 - 0.6 * HOURS) < 0.1, step["runs"]
