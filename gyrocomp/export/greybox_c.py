"""``c`` for a ``greybox`` model: a C99 header with the model's state, an init and an O(1) update.

The update is the arithmetic of :mod:`gyrocomp.effects._stateful` and
:class:`gyrocomp.models.greybox.GreyBoxStream`, in the same order, one
sample per call, with the time stamp of each sample (a gap is one long
step: the temperature bridged linearly, as ``bridge_gaps`` does):

* ``T_e <- a T_e + (1 - c) T + (c - a) T_prev`` with ``a = exp(-h / tau_e)``,
  ``c = -tau_e expm1(-h / tau_e) / h``; the rate filter ``T_f`` likewise;
* the play's centre ``p <- min(max(p, T - w/2), T + w/2)``, or the relay's
  branch ``br`` (0 until the first excursion of ``w``; then -1 once T falls
  ``w`` below its highest since the last switch, +1 once it rises ``w``
  above its lowest); a second play's centre ``p2`` as ``p``, of its own width;
  these switch on ``T`` or, where the model says so, on ``T_e``;
* a second element temperature ``T_e2`` as ``T_e``, a lag of T (in
  parallel) or of ``T_e`` (in series: the cubic is then of ``T_e2``);
* ``drift = offset + sum_k c_k z^k + g dT/dt + a |dT/dt| + h play (or h br)
  + h2 play2 + l (T_e2 - T_e) / half_range + A exp(-t_on / tau_w) + A2 exp(-t_on / tau_w2)``,
  ``z = (clamp(T_e) - centre) / half_range``, ``dT/dt = (T - T_f) / tau_r``,
  or ``s tanh((T - T_f) / (tau_r s))`` where the sensitivity saturates at ``s``.

No ``malloc``; ``exp``, ``expm1`` and ``tanh`` from libm (C99). ``GYROCOMP_REAL`` =
``double`` (default) or ``float``; ``GYROCOMP_NO_CLAMP`` extrapolates the
cubic. With ``GYROCOMP_TEST_VECTORS`` the header also holds time,
temperature, rate and the compensated rate Python gave for them.
"""

from __future__ import annotations

import numpy as np

from gyrocomp.errors import InputError

__all__ = ["greybox_header", "greybox_vectors"]


def _num(x: float) -> str:
    return repr(float(x))


def greybox_vectors(model, n: int = 2048) -> dict:
    """A sweep across and beyond the training range, with a gap of 60 samples at two thirds, and its causal compensation."""
    e = model.estimator
    lo, hi = model.temperature_range_c
    mid, half = 0.5 * (lo + hi), 0.55 * (hi - lo)
    k = np.arange(n, dtype=float)
    time_s = np.where(k < 2 * n // 3, k, k + 60.0) * 2.0  # 0.5 Hz, one gap
    temperature = np.round((mid + half * np.sin(2 * np.pi * k / (n / 1.5) - np.pi / 2)) * 16) / 16
    rate = 0.3 * np.sin(2 * np.pi * 7 * k / n)
    stream = e.stream(clamp=True)
    drift = stream(time_s, temperature)
    return {"time_s": time_s, "temperature_c": temperature, "rate_dps": rate, "drift_dps": drift, "compensated_dps": rate - drift}


def greybox_header(model, vectors: dict | None = None, *, prefix: str = "gyrocomp") -> str:
    """C99 header text of a loaded grey-box model (:class:`gyrocomp.pipeline.greybox.GreyBoxModel`)."""
    if not prefix.isidentifier():
        raise InputError(f"--prefix {prefix!r} is not a C identifier")
    e = model.estimator
    spec, coef = e.spec_, e.coef_
    P, U = prefix, prefix.upper()
    t_lo, t_hi = e.temperature_range_c_
    tau_r = spec["rate_tau_s"] or 1.0  # without a dT/dt term the filter's output is unused
    poly = " + ".join(f"({P}_real){_num(coef.get(f'z{k}', 0.0))} * {'*'.join(['z'] * k)}" for k in range(1, e.degree + 1))
    terms = [f"({P}_real){_num(e.offset_)}", poly]
    if spec["rate_form"]:
        terms.append(f"({P}_real){_num(coef['rate'])} * r")
        if spec["rate_form"] == 2:
            terms.append(f"({P}_real){_num(coef['rate_abs'])} * (r < 0 ? -r : r)")
    x = "s->te" if spec["hysteresis_input"] == "element" and spec["tau_e_s"] else "t_c"  # the hysteresis' input
    relay = spec["width_c"] and spec["hysteresis_operator"] == "relay"
    if relay:
        terms.append(f"({P}_real){_num(coef['relay'])} * s->br")
    elif spec["width_c"]:
        terms.append(f"({P}_real){_num(coef['play'])} * ({x} - s->p) / ({P}_real){_num(0.5 * spec['width_c'])}")
    if spec["width_c"] and spec["width2_c"]:
        terms.append(f"({P}_real){_num(coef['play2'])} * ({x} - s->p2) / ({P}_real){_num(0.5 * spec['width2_c'])}")
    series = bool(spec["tau_e_s"] and spec["tau_e2_s"] and spec["second_lag_path"] == "series")
    if spec["tau_e_s"] and spec["tau_e2_s"] and not series:
        terms.append(f"({P}_real){_num(coef['lag2'])} * (s->te2 - s->te) / ({P}_real){_num(e.half_range_c_)}")
    for key, tau in (("warmup", "tau_w_s"), ("warmup2", "tau_w2_s")):
        if spec["tau_w_s"] and spec[tau]:
            terms.append(f"({P}_real){_num(coef[key])} * exp(-(t - s->t_on) / ({P}_real){_num(spec[tau])})")
    half, half2 = _num(0.5 * spec["width_c"]), _num(0.5 * spec["width2_c"])
    lines = [
        f"/* {prefix}.h: causal grey-box gyro drift compensation, written by gyrocomp export --format c.",
        " * compensated = rate - drift(state, t, T); rate in deg/s, T in degC, t in s (any steps; a gap bridges T linearly).",
        f" * terms: element lag tau_e = {spec['tau_e_s']:.6g} s, dT/dt filter {tau_r:g} s, play width {spec['width_c']:.6g} degC,",
        f" * hysteresis operator {spec['hysteresis_operator']} on the {spec['hysteresis_input']}, second play width {spec['width2_c']:.6g} degC, second element lag {spec['tau_e2_s']:.6g} s ({spec['second_lag_path']}),",
        f" * warm-up tau = {spec['tau_w_s']:.6g} s and {spec['tau_w2_s']:.6g} s, dT/dt saturation {spec['rate_saturation_c_per_s']:.6g} degC/s",
        " * (0: absent). Define GYROCOMP_REAL as float for single precision,",
        " * GYROCOMP_NO_CLAMP to extrapolate the cubic beyond the training range.",
        f" * Usage: {P}_state s; {P}_init(&s); for each sample: y = {P}_update(&s, t, T, rate); */",
        f"#ifndef {U}_H",
        f"#define {U}_H",
        "#include <math.h> /* exp, expm1, tanh */",
        "#ifndef GYROCOMP_REAL",
        "#define GYROCOMP_REAL double",
        "#endif",
        f"typedef GYROCOMP_REAL {P}_real;",
        "",
        "typedef struct {",
        "    int started;",
        f"    {P}_real t_prev, T_prev, te, tf, p, t_on, br, hi, lo, te2, p2;",
        f"}} {P}_state;",
        "",
        f"static void {P}_init({P}_state *s) {{",
        "    s->started = 0; s->t_prev = s->T_prev = s->te = s->tf = s->p = s->t_on = s->br = s->hi = s->lo = s->te2 = s->p2 = 0;",
        "}",
        "",
        f"static {P}_real {P}_hold({P}_real x, {P}_real prev, {P}_real cur, {P}_real h, {P}_real tau) {{",
        "    if (tau <= 0) return cur;",
        "    {",
        f"        const {P}_real a = exp(-h / tau), c = tau * -expm1(-h / tau) / h;",
        "        return a * x + (1 - c) * cur + (c - a) * prev;",
        "    }",
        "}",
        "",
        f"/* One sample: updates the state, returns the compensated rate [deg/s]. */",
        f"static {P}_real {P}_update({P}_state *s, {P}_real t, {P}_real t_c, {P}_real rate) {{",
        f"    {P}_real r, z, te;",
        "    if (!s->started) {",
        "        s->started = 1; s->te = s->tf = s->p = s->hi = s->lo = s->te2 = s->p2 = t_c; s->br = 0; s->t_on = t;",
        "    } else {",
        f"        const {P}_real h = t - s->t_prev, te_prev = s->te;",
        f"        s->te = {P}_hold(s->te, s->T_prev, t_c, h, ({P}_real){_num(spec['tau_e_s'])});",
        f"        s->tf = {P}_hold(s->tf, s->T_prev, t_c, h, ({P}_real){_num(tau_r)});",
        f"        if (s->p < {x} - ({P}_real){half}) s->p = {x} - ({P}_real){half};",
        f"        if (s->p > {x} + ({P}_real){half}) s->p = {x} + ({P}_real){half};",
        f"        if (s->p2 < {x} - ({P}_real){half2}) s->p2 = {x} - ({P}_real){half2};",
        f"        if (s->p2 > {x} + ({P}_real){half2}) s->p2 = {x} + ({P}_real){half2};",
        f"        s->te2 = {P}_hold(s->te2, {'te_prev, s->te' if series else 's->T_prev, t_c'}, h, ({P}_real){_num(spec['tau_e2_s'])});",
        *([] if series else ["        (void)te_prev;"]),
        "    }",
        f"    if (s->br >= 0 && s->hi - {x} > ({P}_real){_num(spec['width_c'])}) {{ s->br = -1; s->lo = {x}; }}",
        f"    else if (s->br <= 0 && {x} - s->lo > ({P}_real){_num(spec['width_c'])}) {{ s->br = 1; s->hi = {x}; }}",
        f"    if ({x} > s->hi) s->hi = {x};",
        f"    if ({x} < s->lo) s->lo = {x};",
        "    s->t_prev = t; s->T_prev = t_c;",
        f"    r = (t_c - s->tf) / ({P}_real){_num(tau_r)};",
        f"    te = s->{'te2' if series else 'te'};",
        "#ifndef GYROCOMP_NO_CLAMP",
        f"    if (te < ({P}_real){_num(t_lo)}) te = ({P}_real){_num(t_lo)};",
        f"    if (te > ({P}_real){_num(t_hi)}) te = ({P}_real){_num(t_hi)};",
        "#endif",
        f"    z = (te - ({P}_real){_num(e.centre_c_)}) / ({P}_real){_num(e.half_range_c_)};",
        f"    return rate - ({' + '.join(terms)});",
        "}",
    ]
    if spec["rate_form"] and spec["rate_saturation_c_per_s"]:
        sat = f"({P}_real){_num(spec['rate_saturation_c_per_s'])}"
        lines.insert(lines.index(f"    r = (t_c - s->tf) / ({P}_real){_num(tau_r)};") + 1, f"    r = {sat} * tanh(r / {sat});")
    if not spec["rate_form"]:
        lines.insert(lines.index(f"    r = (t_c - s->tf) / ({P}_real){_num(tau_r)};") + 1, "    (void)r;")
    if vectors is not None:
        n = len(vectors["time_s"])
        lines += ["", "#ifdef GYROCOMP_TEST_VECTORS", f"#define {U}_N_VECTORS {n}"]
        for key in ("time_s", "temperature_c", "rate_dps", "drift_dps", "compensated_dps"):
            values = ", ".join(_num(v) for v in vectors[key])
            lines.append(f"static const double {P}_vector_{key}[{n}] = {{{values}}};")
        lines.append("#endif")
    lines.append(f"#endif /* {U}_H */")
    return "\n".join(lines) + "\n"
