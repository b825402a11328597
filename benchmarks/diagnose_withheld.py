"""Score `gyrocomp diagnose` on simulated runs whose effects are withheld (the in-sim benchmark).

Each case ("pair") is one gyro (the default gyro's baseline: offset, cubic in
temperature, ARW 1 deg/sqrt(h), 1e-4 deg/s LSB; the measured temperature has
the profile's sensor noise and LSB) carrying none, one or two effects drawn at
random, on 8-hour runs of a random oven profile at 1 or 2 Hz: a fit run, a
second selection run A and a holdout B, which share the gyro and the
profile and differ in their noise seed. Only the recordings go to
:func:`gyrocomp.diagnose.diagnose` as ``diagnose(fit, [A, B])``: the effects
are selected on the pair (fit, A), and the held-out gap comes from B, which
took no part in the selection. Its selection is scored against the hidden
truth. The recordings are drawn by :mod:`gyrocomp.sim`, whose effect shapes
the diagnosis fits: an independent check is ``diagnose_independent.py``.

Amplitudes (``--draw``):

* ``edge`` (default): each effect's strength is drawn log-uniformly from
  its **edge of detectability** to ten times it. The edge is the strength
  at which an ideal detector -- told the effect's shape and the true noise,
  seeing both runs, beside the pair's other effect -- crosses diagnose's
  threshold with probability 0.95 (:mod:`gyrocomp.diagnose.detectability`).
  The strength is the effect's amplitude; for the thermal lag, the
  ``tau_s`` whose evidence is that of the drawn amplitude multiple; for the
  noise terms ``b`` and ``k``. The shape parameters (time constants,
  deadband, period, phase, sign) are drawn as below.
* ``absolute``: fixed physical ranges (log-uniform), whose lower ends reach
  below the edge when the other effect is a random walk or flicker; every
  drawn effect's detection probability is still computed, so the score is
  also given for the pairs whose effects are all above the edge.

The pair's evidence is twice the fit run's (the runs share gyro, profile and
rate; only the temperature-sensor noise differs); its threshold is diagnose's
``k ln(2 n_blocks) + bic_margin``, where a sinusoid's ``k`` counts its
amplitude and phase once per run (each run re-estimates them).

Prints and writes the summary to ``benchmarks/results/diagnose_withheld.json``
(one entry per seed and draw, with the commit, machine and load) and every
case to ``benchmarks/_data/diagnose_withheld/<seed>[-absolute].json``
(seed 2024 unsuffixed): the confusion matrix (rows: true effect present,
columns: effect selected), the exact-match rate (overall and on pairs
above the edge), false positives on effect-free pairs, the held-out gap
shrink ``1 - G_selected / G_baseline`` on pairs with an effect (all, and
those whose baseline held-out gap is above its sampling noise), and the time
per pair on one core: each worker runs one BLAS thread (set here before
numpy loads, unless the environment says otherwise), so `W` workers on `W`
cores do not oversubscribe them (two workers with two BLAS threads each on
two cores took three times as long per pair).

Usage: ``python benchmarks/diagnose_withheld.py [--pairs N] [--workers W] [--seed S] [--draw edge|absolute]``
"""

from __future__ import annotations

import argparse
import json
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from gyrocomp.sim import EFFECTS  # the vocabulary of DESIGN.md, in report order

HERE = Path(__file__).resolve().parent
PROFILES = ("oven-paper", "oven-reverse")
RATES_HZ = (1.0, 2.0)
DURATION_S = 8 * 3600.0
POWER = 0.95
"""Detection probability of the ideal detector at the edge of detectability."""

SCALE = {
    "thermal_lag": "tau_s",
    "temp_rate": "coefficient_dps_per_c_per_s",
    "hysteresis": "amplitude_dps",
    "warmup": "amplitude_dps",
    "rate_ramp": "slope_dps_per_s",
    "periodic": "amplitude_dps",
    "bias_instability": "b_deg_per_h",
    "rate_random_walk": "k_deg_per_h_per_sqrt_h",
}
"""The parameter that sets each effect's strength."""

SEARCH = {"thermal_lag": (1.0, 20000.0), "bias_instability": (0.01, 3000.0), "rate_random_walk": (0.01, 3000.0)}
"""Brackets of the strength parameters that are solved for (not linear in the bias)."""

STOCHASTIC = ("bias_instability", "rate_random_walk")

SCORING = ("strength_x_edge", "evidence", "detection")
"""Keys of a case's effect that describe its strength, not the gyro."""


def draw_effect(name, rng):
    """Parameters of one effect (log-uniform amplitude, random sign)."""

    def lu(lo, hi):
        return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))

    sign = float(rng.choice([-1.0, 1.0]))
    if name == "thermal_lag":
        return {"tau_s": lu(60.0, 900.0)}
    if name == "temp_rate":
        return {"coefficient_dps_per_c_per_s": sign * lu(0.15, 2.0)}
    if name == "hysteresis":
        return {"amplitude_dps": lu(0.002, 0.02), "deadband_c": lu(0.3, 2.0)}
    if name == "warmup":
        return {"amplitude_dps": sign * lu(0.005, 0.05), "tau_s": lu(300.0, 1800.0)}
    if name == "rate_ramp":
        return {"slope_dps_per_s": sign * lu(1e-7, 1e-6)}
    if name == "periodic":
        return {"amplitude_dps": lu(0.002, 0.01), "period_s": lu(300.0, 3600.0), "phase_rad": float(rng.uniform(0, 2 * np.pi))}
    if name == "bias_instability":
        return {"b_deg_per_h": lu(6.0, 30.0)}
    return {"k_deg_per_h_per_sqrt_h": lu(6.0, 30.0)}


def make_case(index, seed, draw="edge"):
    """The hidden truth of pair `index`: profile, rate, effects and their parameters.

    With ``draw="edge"`` every effect also carries ``strength_x_edge``,
    log-uniform in [1, 10]: the multiple of its edge of detectability that
    :func:`resolve_case` sets its strength to (the drawn amplitude is then
    replaced).
    """
    rng = np.random.default_rng([seed, index])
    k = int(rng.choice([0, 1, 2], p=[0.25, 0.4, 0.35]))
    effects = sorted(rng.choice(EFFECTS, size=k, replace=False).tolist(), key=EFFECTS.index)
    case = {
        "index": index,
        "draw": draw,
        "profile": PROFILES[int(rng.integers(len(PROFILES)))],
        "fs_hz": float(RATES_HZ[int(rng.integers(len(RATES_HZ)))]),
        "effects": {e: draw_effect(e, rng) for e in effects},
        "seeds": [int(s) for s in rng.integers(0, 2**31, size=3)],
    }
    if draw == "edge":
        strength = np.random.default_rng([seed, index, 1]).uniform(0.0, 1.0, size=len(effects))
        for e, u in zip(effects, strength):
            case["effects"][e]["strength_x_edge"] = float(10.0**u)
    return case


def _gyro(case):
    from gyrocomp.config import bind, load_config
    from gyrocomp.sim.model import GyroSettings

    table = load_config(HERE.parent / "configs/gyro/default.toml")["gyro"]
    for e in EFFECTS:
        params = {k: v for k, v in case["effects"].get(e, {}).items() if k not in SCORING}
        table[e] = {"enabled": e in case["effects"], **params}
    return bind(GyroSettings, table, "benchmark gyro")


def simulate_pair(case, truth_columns=False):
    """Three recordings (fit, A, B) of the case's gyro, and the fit run's frame."""
    from gyrocomp.config import bind, load_config
    from gyrocomp.recordings import recording_from_frame
    from gyrocomp.sim.profile import ProfileSettings
    from gyrocomp.sim.simulate import simulate

    gyro = _gyro(case)
    profile = bind(ProfileSettings, load_config(HERE.parent / f"configs/profiles/{case['profile']}.toml")["profile"], "profile")
    recs, frames = [], []
    for name, seed in zip(("fit", "A", "B"), case["seeds"]):
        frame, _ = simulate(gyro, profile, fs_hz=case["fs_hz"], seed=seed, duration_s=DURATION_S, truth_columns=truth_columns)
        recs.append(recording_from_frame(frame[["time", "rate", "temperature"]], name=name))
        frames.append(frame)
    return recs, frames[0]


class _Detector:
    """The ideal detector of a case: each effect's pair evidence and detection probability vs its strength."""

    def __init__(self, case, settings):
        from gyrocomp.diagnose import problems

        self.case = case
        self.gyro = _gyro(case)
        (fit, _, _), frame = simulate_pair(case, truth_columns=True)
        self.problem, _, _ = problems(fit, [], settings)
        # diagnose averages each run to at most max_rate_hz at entry: the truth on the same grid
        m = int(round(case["fs_hz"] / self.problem.run.fs_hz))
        k = self.problem.run.time_s.size

        def reduced(column):
            return frame[column].to_numpy()[: k * m].reshape(k, m).mean(axis=1)

        self.housing = reduced("truth_temperature")
        self.unit = {}
        for e in case["effects"]:
            column = f"truth_{e}"
            if column in frame and e != "thermal_lag":
                self.unit[e] = reduced(column) / case["effects"][e][SCALE[e]]
        self.n_pair = 2 * self.problem.y.size
        self.margin = settings.bic_margin

    def threshold(self, effect):
        from gyrocomp.diagnose.detectability import threshold

        return threshold(self.n_pair, effect, self.margin, n_runs=2)

    def noise(self):
        from gyrocomp.effects.likelihood import NoiseModel

        e = self.case["effects"]
        return NoiseModel(
            arw=self.gyro.arw / 60.0,
            bias_instability=e.get("bias_instability", {}).get("b_deg_per_h", 0.0) / 3600.0,
            rate_random_walk=e.get("rate_random_walk", {}).get("k_deg_per_h_per_sqrt_h", 0.0) / 216000.0,
        )

    def spec(self, without=None):
        """The deterministic effects' nonlinear parameters, as :func:`gyrocomp.diagnose.effects.design` takes them.

        A parameter the simulator does not draw (``rate_ramp``'s exponent: it draws the line) is left to the
        effect's plainest form, which its columns default to.
        """
        from gyrocomp.diagnose.effects import DETERMINISTIC
        from gyrocomp.effects.vocabulary import KINDS

        return {
            e: ({KINDS[e].nonlinear: p[KINDS[e].nonlinear]} if KINDS[e].nonlinear in p else {})
            for e, p in self.case["effects"].items()
            if e in DETERMINISTIC and e != without
        }

    def evidence(self, effect, value):
        """Pair evidence of `effect` with its strength parameter at `value`, and its detection probability."""
        from gyrocomp.diagnose import detectability as dt
        from gyrocomp.effects import shapes

        params = self.case["effects"][effect]
        saved = params[SCALE[effect]]
        params[SCALE[effect]] = value
        try:
            if effect in STOCHASTIC:
                ratios = np.tile(dt.noise_ratios(self.problem, self.spec(), self.noise(), effect), 2)
                return dt.noise_evidence(ratios), dt.noise_detection(ratios, self.threshold(effect))
            if effect == "thermal_lag":
                t, c = self.problem.run.time_s, self.gyro.temperature_coefficients
                element = shapes.element_temperature(t, self.housing, value)
                ref = self.gyro.reference_c
                contribution = shapes.bias_polynomial(element, c, ref) - shapes.bias_polynomial(self.housing, c, ref)
            else:
                contribution = value * self.unit[effect]
            lam = 2.0 * dt.deterministic_evidence(self.problem, contribution, self.spec(without=effect), self.noise())
            return lam, dt.deterministic_detection(lam, self.threshold(effect))
        finally:
            params[SCALE[effect]] = saved

    def solve(self, effect, target, alone=False):
        """The strength of `effect` whose pair evidence (deterministic) or detection probability (noise) is `target`.

        With `alone`, a noise term is solved beside white noise only.
        """
        from scipy import optimize

        if alone:
            saved = {e: self.case["effects"].pop(e) for e in STOCHASTIC if e != effect and e in self.case["effects"]}
            try:
                return self.solve(effect, target)
            finally:
                self.case["effects"].update(saved)
        value = self.case["effects"][effect][SCALE[effect]]
        if effect not in SEARCH:
            return float(value * np.sqrt(target / self.evidence(effect, value)[0]))
        which = 1 if effect in STOCHASTIC else 0
        lo, hi = np.log(SEARCH[effect])

        def f(z):
            got = self.evidence(effect, float(np.exp(z)))[which]
            return np.log(max(got, 1e-300) / target)

        return float(np.exp(optimize.brentq(f, lo, hi, xtol=1e-3) if f(hi) > 0 else hi))


def resolve_case(case):
    """Set each effect's strength from its draw (``draw="edge"``) and record its evidence and detection probability.

    An effect's edge is the strength at which the ideal detector
    (:mod:`gyrocomp.diagnose.detectability`, both runs) finds it with
    probability :data:`POWER`; the drawn strength is ``strength_x_edge``
    times it (deterministic effects: in amplitude, i.e. evidence times its
    square; thermal lag: the ``tau_s`` of that evidence). Noise terms are
    solved first (the deterministic effects' evidence depends on them), each
    beside white noise alone: the edges of two noise terms have no common
    fixed point (scaled together, flicker and a random walk keep absorbing
    each other), so a pair with both may fall below the edge, which its
    recorded detection probabilities show. The thermal lag comes next (its
    columns are the others' nuisance).
    """
    from gyrocomp.diagnose import DiagnoseSettings
    from gyrocomp.diagnose.detectability import edge_evidence

    case = json.loads(json.dumps(case))
    detector = _Detector(case, DiagnoseSettings())
    effects = case["effects"]
    if case["draw"] == "edge":
        noise = [e for e in STOCHASTIC if e in effects]
        edges = {e: detector.solve(e, POWER, alone=True) for e in noise}
        for e in noise:
            effects[e][SCALE[e]] = edges[e] * effects[e]["strength_x_edge"]
        for e in sorted((e for e in effects if e not in noise), key=lambda e: e != "thermal_lag"):
            effects[e][SCALE[e]] = detector.solve(e, edge_evidence(detector.threshold(e), POWER) * effects[e]["strength_x_edge"] ** 2)
    for e in effects:
        effects[e]["evidence"], effects[e]["detection"] = detector.evidence(e, effects[e][SCALE[e]])
    return case


def run_case(case):
    from gyrocomp.diagnose import diagnose, get_config

    case = resolve_case(case)
    (fit, a, b), _ = simulate_pair(case)
    t0 = time.perf_counter()
    report = diagnose(fit, [a, b], get_config())
    elapsed = time.perf_counter() - t0
    return {
        **case,
        "selected": report["selected_effects"],
        "gap_baseline_holdout": report["gap"]["baseline"]["holdout"],
        "gap_selected_holdout": report["gap"]["selected"]["holdout"],
        "gap_noise_level_holdout": report["gap"]["baseline"]["parts"]["holdout"]["noise_level"],
        "gap_noise_level_selected_holdout": report["gap"]["selected"]["parts"]["holdout"]["noise_level"],
        "seconds": elapsed,
    }


def above_edge(result):
    """Whether the ideal detector finds every effect of a pair with probability at least :data:`POWER`."""
    return all(p["detection"] >= POWER - 1e-6 for p in result["effects"].values())


def score(results):
    """Confusion matrix, exact-match rate (all pairs and pairs above the edge), false positives, held-out shrink.

    The shrink is also given on the pairs whose baseline held-out gap is
    above its sampling noise (``noise_level`` of :mod:`gyrocomp.diagnose.gap`,
    the 95th percentile of the gap of a recording that is the simulation):
    an effect near its edge of detectability can be plain to the likelihood
    of the selection and lost in the gap scalar's noise, whose halving then
    means nothing. On those pairs ``holdout_explained`` also counts a
    selected model whose held-out gap is within *its own* sampling noise
    (a random walk's 100 s spread has about three degrees of freedom: a
    model that is right can leave a gap of order 1 on one realisation).
    """
    labels = list(EFFECTS)
    confusion = {t: {p: 0 for p in labels + ["(none)"]} for t in labels + ["(none)"]}
    exact = exact_above = n_above = 0
    fp_free = 0
    n_free = 0
    shrinks, visible, explained = [], [], []
    for r in results:
        truth = set(r["effects"])
        sel = set(r["selected"])
        exact += truth == sel
        if above_edge(r):
            n_above += 1
            exact_above += truth == sel
        for t in truth or {"(none)"}:
            for p in sel or {"(none)"}:
                confusion[t][p] += 1
        if not truth:
            n_free += 1
            fp_free += bool(sel)
        else:
            base = r["gap_baseline_holdout"]
            shrinks.append(1.0 - r["gap_selected_holdout"] / base if base else 0.0)
            visible.append(base > r["gap_noise_level_holdout"])
            explained.append(shrinks[-1] >= 0.5 or r["gap_selected_holdout"] <= r["gap_noise_level_selected_holdout"])
    shrinks, visible, explained = np.array(shrinks), np.array(visible, dtype=bool), np.array(explained, dtype=bool)
    return {
        "pairs": len(results),
        "exact_match_rate": exact / len(results),
        "pairs_above_edge": n_above,
        "exact_match_rate_above_edge": exact_above / n_above if n_above else None,
        "effect_free_pairs": n_free,
        "false_positive_pairs": fp_free,
        "holdout_shrink_median": float(np.median(shrinks)) if shrinks.size else None,
        "holdout_shrink_at_least_half": float(np.mean(shrinks >= 0.5)) if shrinks.size else None,
        "pairs_with_effect_visible_in_gap": int(visible.sum()),
        "holdout_shrink_at_least_half_visible": float(np.mean(shrinks[visible] >= 0.5)) if visible.any() else None,
        "holdout_explained_visible": float(np.mean(explained[visible])) if visible.any() else None,
        "seconds_per_pair_median": float(np.median([r["seconds"] for r in results])),
        "confusion": confusion,
    }


def confusion_markdown(confusion):
    """The confusion matrix as a markdown table (rows: truth, columns: selected)."""
    cols = list(next(iter(confusion.values())))
    short = {c: c.replace("bias_instability", "bias_inst").replace("rate_random_walk", "rrw") for c in cols}
    lines = ["| true \\ selected | " + " | ".join(short[c] for c in cols) + " |", "|---" * (len(cols) + 1) + "|"]
    for t, row in confusion.items():
        lines.append(f"| {short[t]} | " + " | ".join(str(row[c]) if row[c] else "." for c in cols) + " |")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=40)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=2024)
    parser.add_argument("--draw", choices=("edge", "absolute"), default="edge")
    args = parser.parse_args(argv)
    cases = [make_case(i, args.seed, args.draw) for i in range(args.pairs)]
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        results = list(pool.map(run_case, cases))
    for r in results:
        ok = "ok " if set(r["effects"]) == set(r["selected"]) else "MISS"
        strength = ", ".join(f"{e} P={p['detection']:.2f} ev={p['evidence']:.3g}" for e, p in r["effects"].items())
        print(f"{ok} #{r['index']:3d} {r['profile']:12s} {r['fs_hz']:.0f} Hz truth=[{strength}] selected={r['selected']}")
    summary = score(results)
    print(confusion_markdown(summary["confusion"]))
    for key, value in summary.items():
        if key != "confusion":
            print(f"{key}: {value}")
    import provenance  # benchmarks/ is on the path when this runs as a script

    key = f"{args.seed}" + ("-absolute" if args.draw == "absolute" else "")
    provenance.detail_path(f"diagnose_withheld/{key}.json").write_text(json.dumps({"summary": summary, "cases": results}, indent=2, default=float) + "\n")
    provenance.write("diagnose_withheld", {"summary": summary}, key=key)
    rate = summary["exact_match_rate"] if args.draw == "edge" else summary["exact_match_rate_above_edge"]
    return 0 if (rate or 0.0) >= 0.95 and summary["false_positive_pairs"] == 0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
