"""``c``: a self-contained C99 header that runs a causal model, one sample per call.

The header holds the model of :mod:`gyrocomp.export.plain` (physical units),
and three steps per sample, the same as ``compensate --mode causal``:

1. **dT/dt in O(1) per sample**, the recursion of :mod:`gyrocomp.pipeline.rate`
   (its module notes, :func:`~gyrocomp.pipeline.rate.moment_weights`): with
   ``u_k = (k - kbar) / kbar`` the window's positions scaled to [-1, 1], the
   estimate is ``sum_r a_r M_r`` over the moments ``M_r = sum_k u_k^r x_k``.
   When the window slides by one sample (``x_0`` leaves, ``x_new`` enters)
   every u drops by ``h = 1 / kbar``, so each moment updates from the others
   by the binomial shift
   ``M_r' = sum_{m<=r} C(r, m) (-h)^(r-m) (M_m - (-1)^m x_0) + x_new``:
   ``(p + 1)^2`` operations whatever the window. A second set of moments
   summed afresh over W samples replaces the recursive one every W samples,
   so rounding cannot random-walk over a long run (as the Python estimator
   re-sums its rows). The readings are taken relative to the first one
   (``sum_k c_k = 0``), and the window is primed with the first reading, as
   the FIR is. A ring buffer of W readings supplies ``x_0``.
2. **Clamping** of temperature and dT/dt to the training ranges
   (``GYROCOMP_NO_CLAMP`` extrapolates, as ``--no-clamp``).
3. **The segments' forward passes**, summed, subtracted from the rate.

No ``malloc``, nothing from libm but ``exp`` (a logarithm for the
generalised bell and a sine for the ``sin`` activation are written out),
fixed-size state, ``GYROCOMP_REAL`` = ``double`` or ``float``. With
``GYROCOMP_TEST_VECTORS`` defined, the header also holds inputs and the
outputs ``compensate --mode causal`` gave for them.
"""

from __future__ import annotations

from math import comb

import numpy as np

from gyrocomp.errors import InputError

__all__ = ["rate_moments", "recursive_rate", "c_header"]


def rate_moments(window: int, polyorder: int, fs_hz: float) -> tuple[np.ndarray, float]:
    """Moment weights a and kbar of the causal estimator (:func:`gyrocomp.pipeline.rate.moment_weights`)."""
    from gyrocomp.pipeline.rate import moment_weights

    w = int(window)
    return moment_weights(w, min(int(polyorder), w - 1), float(fs_hz), w - 1), (w - 1) / 2.0


def recursive_rate(temperature_c, window: int, polyorder: int, fs_hz: float) -> np.ndarray:
    """dT/dt by the C header's recursion (module notes), in numpy: a check that it equals the FIR."""
    x_all = np.asarray(temperature_c, dtype=float)
    a, kbar = rate_moments(window, polyorder, fs_hz)
    w, p = int(window), len(a) - 1
    shift = _shift_matrix(p, 1.0 / kbar)
    powers = np.arange(p + 1)
    u_old, u_new = (-1.0) ** powers, np.ones(p + 1)
    ring, moments, fresh = np.zeros(w), np.zeros(p + 1), np.zeros(p + 1)
    first = x_all[0]
    out = np.empty_like(x_all)
    for i, value in enumerate(x_all):
        x = value - first
        oldest = ring[i % w]
        moments = shift @ (moments - u_old * oldest) + u_new * x
        ring[i % w] = x
        k = i % w
        fresh += ((k - kbar) / kbar) ** powers * x
        if k == w - 1:
            moments, fresh = fresh, np.zeros(p + 1)
        out[i] = a @ moments
    return out


def c_header(plain: dict, vectors: dict | None = None, *, prefix: str = "gyrocomp") -> str:
    """C99 header text for a plain model (:func:`gyrocomp.export.plain.plain_model`).

    Parameters
    ----------
    plain : dict
        Best in the centred basis (``plain_model(model, centred=True)``),
        the learners' own.
    vectors : dict or None
        ``temperature_c``, ``rate_dps``, ``temperature_rate_c_per_s``,
        ``drift_dps``, ``compensated_dps`` arrays (the test vectors).
    prefix : str
        Prefix of every name the header defines.
    """
    if not prefix.isidentifier():
        raise InputError(f"--prefix {prefix!r} is not a C identifier")
    est = plain["rate_estimator"]
    w = int(est["window_samples"])
    a, kbar = rate_moments(w, est["polyorder"], plain["fs_hz"])
    u = (np.arange(w) - kbar) / kbar
    if not np.allclose(np.polynomial.polynomial.polyval(u, a), est["causal_coefficients"], rtol=1e-6, atol=1e-9 * np.max(np.abs(a))):
        raise InputError("rate estimator: the stored causal FIR is not the Savitzky-Golay slope of its window and order")
    p = len(a) - 1
    P, U = prefix, prefix.upper()
    out = [
        f"/* {prefix}.h: causal gyro drift compensation ({plain['kind']}), written by gyrocomp export --format c.",
        " * compensated = rate - sum of segments f(clamp(T), clamp(dT/dt)), rate in deg/s, T in degC.",
        f" * dT/dt: causal Savitzky-Golay slope over {w} samples at {plain['fs_hz']:.17g} Hz, O(1) per sample by moments.",
        " * Define GYROCOMP_REAL as float for single precision, GYROCOMP_NO_CLAMP to extrapolate.",
        " * Usage: " + f"{P}_state s; {P}_init(&s); for each sample: y = {P}_update(&s, T, rate); */",
        f"#ifndef {U}_H",
        f"#define {U}_H",
        "#include <math.h> /* exp only */",
        "#ifndef GYROCOMP_REAL",
        "#define GYROCOMP_REAL double",
        "#endif",
        f"typedef GYROCOMP_REAL {P}_real;",
        f"#define {U}_WINDOW {w}",
        f"#define {U}_ORDER {p}",
        "",
        "typedef struct {",
        f"    {P}_real ring[{U}_WINDOW]; /* readings relative to the first, oldest at head */",
        f"    {P}_real moment[{U}_ORDER + 1];",
        f"    {P}_real fresh[{U}_ORDER + 1]; /* the same moments summed afresh since the last block start */",
        "    long k; /* position of the newest reading in the fresh block */",
        f"    {P}_real first;",
        "    long head;",
        "    int started;",
        f"    {P}_real temperature_rate; /* last dT/dt [degC/s], before clamping */",
        f"    {P}_real drift; /* last drift [deg/s] */",
        f"}} {P}_state;",
        "",
        f"static const {P}_real {P}_rate_poly[{U}_ORDER + 1] = {{{_list(a)}}};",
        f"static const {P}_real {P}_shift[{U}_ORDER + 1][{U}_ORDER + 1] = {{{', '.join('{' + _list(row) + '}' for row in _shift_matrix(p, 1.0 / kbar))}}};",
        f"static const {P}_real {P}_u_old[{U}_ORDER + 1] = {{{_list((-1.0) ** np.arange(p + 1))}}};",
        f"#define {U}_KBAR (({P}_real){_num(kbar)})",
        "",
    ]
    needs = set()
    bodies = []
    for index, segment in enumerate(plain["segments"]):
        body, uses = _SEGMENT_C[segment["learner"]](segment, f"{P}_seg{index}", P)
        bodies.append(body)
        needs |= uses
    out += _helpers(needs, P)
    out += bodies
    (t_lo, t_hi), (r_lo, r_hi) = plain["clamp"]["temperature_c"], plain["clamp"]["temperature_rate_c_per_s"]
    basis = plain["input_basis"]
    out += [
        f"static inline void {P}_init({P}_state *s) {{",
        "    int i;",
        f"    for (i = 0; i < {U}_WINDOW; ++i) s->ring[i] = 0;",
        f"    for (i = 0; i <= {U}_ORDER; ++i) {{ s->moment[i] = 0; s->fresh[i] = 0; }}",
        "    s->first = 0; s->head = 0; s->k = 0; s->started = 0; s->temperature_rate = 0; s->drift = 0;",
        "}",
        "",
        "/* One sample: temperature [degC] and measured rate [deg/s] in, compensated rate [deg/s] out. */",
        f"static inline {P}_real {P}_update({P}_state *s, {P}_real temperature_c, {P}_real rate_dps) {{",
        f"    {P}_real x, oldest, next[{U}_ORDER + 1], slope = 0, t, r, drift = 0, u, power;",
        "    int j, m;",
        "    if (!s->started) { s->first = temperature_c; s->started = 1; }",
        "    x = temperature_c - s->first;",
        "    oldest = s->ring[s->head];",
        f"    for (j = 0; j <= {U}_ORDER; ++j) {{",
        "        next[j] = 0;",
        f"        for (m = 0; m <= j; ++m) next[j] += {P}_shift[j][m] * (s->moment[m] - {P}_u_old[m] * oldest);",
        "        next[j] += x;",
        "    }",
        f"    u = (({P}_real)s->k - {U}_KBAR) / {U}_KBAR; power = 1;",
        f"    for (j = 0; j <= {U}_ORDER; ++j) {{ s->fresh[j] += power * x; power *= u; }}",
        f"    if (s->k == {U}_WINDOW - 1) {{ /* the fresh sums hold exactly this window: rounding restarts */",
        f"        for (j = 0; j <= {U}_ORDER; ++j) {{ next[j] = s->fresh[j]; s->fresh[j] = 0; }}",
        "        s->k = 0;",
        "    } else {",
        "        s->k += 1;",
        "    }",
        f"    for (j = 0; j <= {U}_ORDER; ++j) {{ s->moment[j] = next[j]; slope += {P}_rate_poly[j] * next[j]; }}",
        "    s->ring[s->head] = x;",
        f"    s->head = (s->head + 1) % {U}_WINDOW;",
        "    s->temperature_rate = slope;",
        "    t = temperature_c; r = slope;",
        "#ifndef GYROCOMP_NO_CLAMP",
        f"    if (t < ({P}_real){_num(t_lo)}) t = ({P}_real){_num(t_lo)};",
        f"    if (t > ({P}_real){_num(t_hi)}) t = ({P}_real){_num(t_hi)};",
        f"    if (r < ({P}_real){_num(r_lo)}) r = ({P}_real){_num(r_lo)};",
        f"    if (r > ({P}_real){_num(r_hi)}) r = ({P}_real){_num(r_hi)};",
        "#endif",
        f"    t = (t - ({P}_real){_num(basis['centre'][0])}) / ({P}_real){_num(basis['half_range'][0])};",
        f"    r = (r - ({P}_real){_num(basis['centre'][1])}) / ({P}_real){_num(basis['half_range'][1])};",
    ]
    for index, segment in enumerate(plain["segments"]):
        if segment.get("output_range_dps"):
            lo, hi = segment["output_range_dps"]
            out.append(f"    drift += {P}_clip({P}_seg{index}(t, r), ({P}_real){_num(lo)}, ({P}_real){_num(hi)});")
        else:
            out.append(f"    drift += {P}_seg{index}(t, r);")
    out += ["    s->drift = drift;", "    return rate_dps - drift;", "}", ""]
    if vectors is not None:
        n = len(vectors["temperature_c"])
        out += [
            "#ifdef GYROCOMP_TEST_VECTORS",
            "/* inputs and the outputs of gyrocomp compensate --mode causal for them */",
            f"#define {U}_N_VECTORS {n}",
        ]
        for key in ("temperature_c", "rate_dps", "temperature_rate_c_per_s", "drift_dps", "compensated_dps"):
            out.append(f"static const double {P}_vector_{key}[{U}_N_VECTORS] = {{{_list(vectors[key])}}};")
        out.append("#endif")
    out += [f"#endif /* {U}_H */", ""]
    return "\n".join(out)


def _shift_matrix(p: int, h: float) -> np.ndarray:
    """S[j, m] = C(j, m) (-h)^(j - m): the moments of u expressed about u - h."""
    return np.array([[comb(j, m) * (-h) ** (j - m) if m <= j else 0.0 for m in range(p + 1)] for j in range(p + 1)], dtype=float)


def _num(value) -> str:
    """A C constant; refused beyond single precision, which ``GYROCOMP_REAL float`` would read as inf."""
    value = float(value)
    if not abs(value) <= _FLOAT32_MAX:
        raise InputError(f"export c: constant {value!r} is beyond single precision (+-{_FLOAT32_MAX:.7g}); the header must compile as float too")
    return repr(value)


_FLOAT32_MAX = float(np.finfo(np.float32).max)


def _list(values) -> str:
    return ", ".join(_num(v) for v in np.ravel(values))


def _helpers(needs: set, P: str) -> list[str]:
    lines = [
        f"static inline {P}_real {P}_clip({P}_real v, {P}_real lo, {P}_real hi) {{ return v < lo ? lo : (v > hi ? hi : v); }}",
    ]
    if "log" in needs:
        lines += [
            "/* natural logarithm of v > 0 without libm: v = m 2^k, m in [1, 2), log m = 2 atanh((m - 1) / (m + 1)) */",
            f"static inline {P}_real {P}_log({P}_real v) {{",
            f"    {P}_real k = 0, s, s2, term, sum = 0; int n;",
            "    while (v >= 2) { v /= 2; k += 1; }",
            "    while (v < 1) { v *= 2; k -= 1; }",
            "    s = (v - 1) / (v + 1); s2 = s * s; term = s;",
            "    for (n = 1; n < 40; n += 2) { sum += term / n; term *= s2; }",
            f"    return 2 * sum + k * ({P}_real)0.69314718055994530942;",
            "}",
        ]
    if "sin" in needs:
        lines += [
            "/* sine without libm: reduce to [-pi, pi], Taylor series to degree 33 */",
            f"static inline {P}_real {P}_sin({P}_real z) {{",
            f"    const {P}_real two_pi = ({P}_real)6.28318530717958647692;",
            f"    {P}_real turns = z / two_pi, term, sum, z2; long n; int k;",
            "    n = (long)(turns + (turns >= 0 ? 0.5 : -0.5));",
            "    z -= n * two_pi; z2 = z * z; term = z; sum = z;",
            "    for (k = 1; k <= 16; ++k) { term *= -z2 / ((2 * k) * (2 * k + 1)); sum += term; }",
            "    return sum;",
            "}",
        ]
    return lines + [""]


def _activation(name: str, z: str, P: str) -> tuple[str, set]:
    table = {
        "sigmoid": (f"1 / (1 + exp(-({z})))", set()),
        "logistic": (f"1 / (1 + exp(-({z})))", set()),
        "tanh": (f"1 - 2 / (exp(2 * ({z})) + 1)", set()),
        "sin": (f"{P}_sin({z})", {"sin"}),
        "hardlim": (f"(({z}) >= 0 ? 1 : 0)", set()),
        "tribas": (f"(({z}) > -1 && ({z}) < 1 ? 1 - (({z}) < 0 ? -({z}) : ({z})) : 0)", set()),
        "radbas": (f"exp(-({z}) * ({z}))", set()),
        "relu": (f"(({z}) > 0 ? ({z}) : 0)", set()),
        "identity": (f"({z})", set()),
    }
    if name not in table:
        raise InputError(f"export c: no C form of activation {name!r}; known: {', '.join(table)}")
    return table[name]


def _polynomial_c(seg: dict, fn: str, P: str) -> tuple[str, set]:
    coef = seg["coef_dps"]
    horner = _num(coef[-1])
    for c in coef[-2::-1]:
        horner = f"({horner}) * d + {_num(c)}"
    return "\n".join([
        f"static inline {P}_real {fn}({P}_real t, {P}_real r) {{",
        f"    const {P}_real d = t - ({P}_real){_num(seg['reference_c'])};",
        f"    return {horner} + ({P}_real){_num(seg['rate_coef_dps_per_c_per_s'])} * r;",
        "}", "",
    ]), set()


def _elm_c(seg: dict, fn: str, P: str) -> tuple[str, set]:
    w = np.asarray(seg["input_weights"])
    n = w.shape[1]
    g, uses = _activation(seg["activation"], "z", P)
    return "\n".join([
        f"static const {P}_real {fn}_w[2][{n}] = {{{{{_list(w[0])}}}, {{{_list(w[1])}}}}};",
        f"static const {P}_real {fn}_b[{n}] = {{{_list(seg['biases'])}}};",
        f"static const {P}_real {fn}_beta[{n}] = {{{_list(seg['beta'])}}};",
        f"static inline {P}_real {fn}({P}_real t, {P}_real r) {{",
        f"    {P}_real y = ({P}_real){_num(seg['offset_dps'])}, z; int h;",
        f"    for (h = 0; h < {n}; ++h) {{ z = {fn}_w[0][h] * t + {fn}_w[1][h] * r + {fn}_b[h]; y += {fn}_beta[h] * ({g}); }}",
        "    return y;",
        "}", "",
    ]), uses


def _anfis_c(seg: dict, fn: str, P: str) -> tuple[str, set]:
    premises = [np.asarray(p) for p in seg["premises"]]
    m0, m1 = len(premises[0]), len(premises[1])
    n_rules = m0 * m1
    k = premises[0].shape[1]
    lines = [
        f"static const {P}_real {fn}_p0[{m0}][{k}] = {{{', '.join('{' + _list(row) + '}' for row in premises[0])}}};",
        f"static const {P}_real {fn}_p1[{m1}][{k}] = {{{', '.join('{' + _list(row) + '}' for row in premises[1])}}};",
        f"static const {P}_real {fn}_slopes[{n_rules}][2] = {{{', '.join('{' + _list(row) + '}' for row in seg['slopes'])}}};",
        f"static const {P}_real {fn}_q[{n_rules}] = {{{_list(seg['intercepts'])}}};",
        f"static inline {P}_real {fn}_logmu(const {P}_real *p, {P}_real x) {{",
    ]
    if seg["mf"] == "gbell":  # log mu = -log(1 + |(x - c) / a|^(2b)), p = a, b, c
        lines += [
            f"    {P}_real u = (x - p[2]) / p[0], s;",
            "    if (u < 0) u = -u;",
            f"    if (u < ({P}_real)1e-30) u = ({P}_real)1e-30; /* gyrocomp floors |u| at 1e-300; float cannot */",
            f"    s = 2 * p[1] * {P}_log(u);",
            f"    return s > 0 ? -(s + {P}_log(1 + exp(-s))) : -{P}_log(1 + exp(s));",
        ]
        uses = {"log"}
    else:  # gaussian, p = c, sigma
        lines += [f"    {P}_real u = (x - p[0]) / p[1];", "    return -0.5 * u * u;"]
        uses = set()
    lines += [
        "}",
        f"static inline {P}_real {fn}({P}_real t, {P}_real r) {{",
        f"    {P}_real l0[{m0}], l1[{m1}], lw[{n_rules}], top, w, sw = 0, y = 0; int i, j;",
        f"    for (i = 0; i < {m0}; ++i) l0[i] = {fn}_logmu({fn}_p0[i], t);",
        f"    for (j = 0; j < {m1}; ++j) l1[j] = {fn}_logmu({fn}_p1[j], r);",
        f"    for (i = 0; i < {m0}; ++i) for (j = 0; j < {m1}; ++j) lw[i * {m1} + j] = l0[i] + l1[j];",
        "    top = lw[0];",
        f"    for (i = 1; i < {n_rules}; ++i) if (lw[i] > top) top = lw[i];",
        f"    for (i = 0; i < {n_rules}; ++i) {{",
        "        w = exp(lw[i] - top); sw += w;",
        f"        y += w * ({fn}_slopes[i][0] * t + {fn}_slopes[i][1] * r + {fn}_q[i]);",
        "    }",
        "    return y / sw;",
        "}", "",
    ]
    return "\n".join(lines), uses


def _bp_c(seg: dict, fn: str, P: str) -> tuple[str, set]:
    weights = [np.asarray(w) for w in seg["weights"]]
    biases = [np.asarray(b) for b in seg["biases"]]
    g, uses = _activation(seg["activation"], "z", P)
    lines = []
    for i, (w, b) in enumerate(zip(weights, biases)):
        lines.append(f"static const {P}_real {fn}_w{i}[{w.shape[0]}][{w.shape[1]}] = {{{', '.join('{' + _list(row) + '}' for row in w)}}};")
        lines.append(f"static const {P}_real {fn}_b{i}[{w.shape[1]}] = {{{_list(b)}}};")
    widest = max(w.shape[1] for w in weights)
    lines += [
        f"static inline {P}_real {fn}({P}_real t, {P}_real r) {{",
        f"    {P}_real a[{widest}], next[{widest}], z; int i, j;",
        "    a[0] = t; a[1] = r;",
    ]
    for i, w in enumerate(weights):
        last = i == len(weights) - 1
        value = "z" if last else g
        lines += [
            f"    for (j = 0; j < {w.shape[1]}; ++j) {{",
            f"        z = {fn}_b{i}[j];",
            f"        for (i = 0; i < {w.shape[0]}; ++i) z += a[i] * {fn}_w{i}[i][j];",
            f"        next[j] = {value};",
            "    }",
            f"    for (j = 0; j < {w.shape[1]}; ++j) a[j] = next[j];",
        ]
    lines += ["    return a[0];", "}", ""]
    return "\n".join(lines), uses


_SEGMENT_C = {"polynomial": _polynomial_c, "elm": _elm_c, "anfis": _anfis_c, "bp": _bp_c}
"""C forward pass of each plain learner (``nsga2elm`` exports as its picked ``elm``)."""
