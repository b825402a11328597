"""Compiled ANFIS forward pass (numba): one fused pass per block of rows, vectorised across rows.

:func:`gyrocomp.models.anfis._predict` with NumPy builds, per row block,
the log memberships of every input, their outer sum over the rule grid,
its exponential and its normalisation, then the rule outputs: on 7.2e6
rows of the 16 + 4 rules of PE-LCD-ANFIS that took 15 s of a 30 s
``compensate`` (cProfile). This kernel computes the same output `BLOCK`
rows at a time in scratch arrays that stay in the L1 cache, using that
the normalised firing strength of the grid partition factorises ([2]
eqs. (23)-(24)):

    wbar_r = prod_j mu_j,k_j / sum_r prod_j mu_j,k_j = prod_j nu_j,k_j,
    nu_j,k = mu_j,k / sum_k mu_j,k,

so each input is normalised over its own membership functions. With
``gbell`` mu = 1 / (1 + exp(s)), s = 2 b log|u|, u = (z - c) / a; with
``gauss`` log mu = -q, q = u^2 / 2, u = (z - c) / sigma. Where every
membership of an input is below exp(-`SHIFT_ABOVE`) (an input far outside
the training range, never after clamping), nu is taken from the shifted
logarithms, exp(s_min - s_k) (there log mu = -s to double precision), as
the NumPy path does with its row maximum. The output is
sum_r wbar_r (c_r . z + c_r0) ([2] eq. (25)).

Every loop runs over the rows of a block with the same arithmetic for
each row, so LLVM compiles it to AVX2 instructions, four rows at a time.
libm's ``log`` and ``exp`` are function calls that stop that; :func:`_log`
and :func:`_exp` are the same functions in plain arithmetic (fdlibm's
``__ieee754_log`` and ``__ieee754_exp`` [3]), within one unit in the last
place of libm's (tests/models/test_anfis.py). On 7.2e6 rows of the two
models of PE-LCD-ANFIS this took 1.25 s against 3.33 s for the row-by-row
kernel with libm calls (same run). Without ``fastmath`` LLVM neither
reorders nor fuses the arithmetic, so each row gets the same bytes
whether it falls in the vector body or the scalar tail of a loop, and
whatever the rows around it: chunked and one-shot evaluations agree bit
for bit. ``error_model="numpy"`` lets a division by zero give inf as in
NumPy instead of a Python exception check in every iteration, which also
stops vectorisation. Imported lazily by :func:`gyrocomp.models.anfis._predict`;
numba compiles on first use and caches the machine code beside this file
(``cache=True``).

References
----------
.. [1] J.-S. R. Jang, IEEE Trans. Syst., Man, Cybern. 23(3), 665-685 (1993).
.. [2] H. Cao et al., IEEE Access 9, 95180 (2021).
.. [3] Sun Microsystems, fdlibm 5.3, ``e_log.c`` and ``e_exp.c`` (1993).
"""

from __future__ import annotations

import numba
import numpy as np

SHIFT_ABOVE = 600.0
"""Smallest exponent s (or q) of an input's largest membership from which nu comes from shifted logarithms."""
FAR_TOTAL = 1e-200
"""A row whose memberships of an input sum below this is checked for the shifted path (> n_mfs exp(-SHIFT_ABOVE))."""
BLOCK = 256
"""Rows per block: the scratch arrays (memberships, rule outputs) then fit in 32 KB of L1 cache."""

_TINY = 1e-300
"""|u| is held in [_TINY, 1 / _TINY] before its logarithm (as the NumPy path floors it at 1e-300)."""
_EXP_ARG = 708.0
"""_exp clamps its argument to +-_EXP_ARG: exp(708) = 3e307 stays a normal number, 2^k in range."""
_LN2_HI = 6.93147180369123816490e-01
"""ln 2 rounded to 32 bits: k * _LN2_HI is exact for |k| < 2^20 (fdlibm)."""
_LN2_LO = 1.90821492927058770002e-10
"""ln 2 - _LN2_HI (fdlibm)."""
_LOG2E = 1.4426950408889634
"""1 / ln 2."""
_SHIFTER = 6755399441055744.0
"""1.5 * 2^52: x + _SHIFTER rounds x to an integer held in the low bits of the mantissa."""
_SQRT2 = 1.4142135623730951
_P1, _P2, _P3 = 1.66666666666666019037e-01, -2.77777777770155933842e-03, 6.61375632143793436117e-05
_P4, _P5 = -1.65339022054652515390e-06, 4.13813679705723846039e-08
"""fdlibm's minimax coefficients of R(r^2) = r (e^r + 1) / (e^r - 1) (error < 2^-59)."""
_LG1, _LG2, _LG3, _LG4 = 6.666666666666735130e-01, 3.999999999940941908e-01, 2.857142874366239149e-01, 2.222219843214978396e-01
_LG5, _LG6, _LG7 = 1.818357216161805012e-01, 1.531383769920937332e-01, 1.479819860511658591e-01
"""fdlibm's minimax coefficients of (log(1 + f) - 2 s) / s, s = f / (2 + f), in s^2 (error < 2^-58.45)."""


@numba.njit(inline="always", error_model="numpy")
def _exp(x):
    """e^x for x in [-708, 708] (clamped there), within 1 ulp of libm (fdlibm ``__ieee754_exp``).

    e^x = 2^k e^r with r = x - k ln 2, |r| <= ln 2 / 2, and e^r from
    fdlibm's rational form 1 + 2r / (R(r^2) - r).
    """
    x = min(max(x, -_EXP_ARG), _EXP_ARG)
    shifted = x * _LOG2E + _SHIFTER
    k = shifted - _SHIFTER
    hi = x - k * _LN2_HI
    lo = k * _LN2_LO
    r = hi - lo
    t = r * r
    c = r - t * (_P1 + t * (_P2 + t * (_P3 + t * (_P4 + t * _P5))))
    p = 1.0 - ((lo - (r * c) / (2.0 - c)) - hi)
    # the low bits of `shifted` hold k: 2^k is k + 1023 in the exponent field
    k_bits = np.float64(shifted).view(np.int64) - np.float64(_SHIFTER).view(np.int64)
    return p * np.int64((k_bits + 1023) << 52).view(np.float64)


@numba.njit(inline="always", error_model="numpy")
def _log(x):
    """Natural logarithm of a normal positive x, within 1 ulp of libm (fdlibm ``__ieee754_log``).

    x = 2^e m with m in [sqrt(2)/2, sqrt(2)); log x = e ln 2 + log(1 + f),
    f = m - 1, by fdlibm's polynomial in s = f / (2 + f).
    """
    bits = np.float64(x).view(np.int64)
    e = (bits >> 52) - 1023
    m = np.int64((bits & 0x000FFFFFFFFFFFFF) | 0x3FF0000000000000).view(np.float64)
    above = m > _SQRT2
    m = m * 0.5 if above else m
    e = e + 1 if above else e
    # e as a double without an int64 conversion (none in AVX2): e + 1.5 * 2^52, exactly
    k = np.int64(np.float64(_SHIFTER).view(np.int64) + e).view(np.float64) - _SHIFTER
    f = m - 1.0
    s = f / (2.0 + f)
    z = s * s
    w = z * z
    R = z * (_LG1 + w * (_LG3 + w * (_LG5 + w * _LG7))) + w * (_LG2 + w * (_LG4 + w * _LG6))
    half_f2 = 0.5 * f * f
    return k * _LN2_HI - ((half_f2 - (s * (half_f2 + R) + k * _LN2_LO)) - f)


@numba.njit(cache=True, error_model="numpy")
def forward(Zt, centre, width, slope, first, n_mfs, consequents, gbell, out):
    """Model output of every column of `Zt` (n_inputs, n_rows), i.e. every row of Z, into `out`.

    Membership k of input j is at ``first[j] + k`` of `centre`, `width`
    (a or sigma) and `slope` (b; unused for ``gauss``); rule r combines
    the memberships of the digits of r in the mixed radix `n_mfs`, the
    first input the most significant, as the rows of `consequents`.
    """
    n_in, n_rows = Zt.shape
    n_rules = consequents.shape[0]
    exponent = np.empty((centre.size, BLOCK))
    nu = np.empty((centre.size, BLOCK))
    total = np.empty(BLOCK)
    wbar = np.empty(BLOCK)
    rule = np.empty(BLOCK)
    digit = np.empty(n_in, dtype=np.int64)
    for start in range(0, n_rows, BLOCK):
        rows = min(BLOCK, n_rows - start)
        for j in range(n_in):
            lo, hi = first[j], first[j] + n_mfs[j]
            for i in range(rows):
                total[i] = 0.0
            # the exponent s (gbell) or q (gauss) and mu, one pass per membership function
            for k in range(lo, hi):
                c, per_a, two_b = centre[k], 1.0 / width[k], 2.0 * slope[k]
                if gbell:
                    for i in range(rows):
                        e = two_b * _log(min(max(abs((Zt[j, start + i] - c) * per_a), _TINY), 1.0 / _TINY))
                        mu = 1.0 / (1.0 + _exp(e))
                        exponent[k, i] = e
                        nu[k, i] = mu
                        total[i] += mu
                else:
                    for i in range(rows):
                        u = (Zt[j, start + i] - c) * per_a
                        e = 0.5 * u * u
                        mu = _exp(-e)
                        exponent[k, i] = e
                        nu[k, i] = mu
                        total[i] += mu
            # rows whose every membership is below exp(-SHIFT_ABOVE) (then the sum is below
            # n_mfs exp(-SHIFT_ABOVE) < FAR_TOTAL) take the shifted logarithms instead
            far = 0
            for i in range(rows):
                far += total[i] < FAR_TOTAL
            if far:
                for i in range(rows):
                    smallest = np.inf
                    for k in range(lo, hi):
                        smallest = min(smallest, exponent[k, i])
                    if smallest >= SHIFT_ABOVE:
                        total[i] = 0.0
                        for k in range(lo, hi):
                            nu[k, i] = _exp(smallest - exponent[k, i])
                            total[i] += nu[k, i]
            for i in range(rows):
                total[i] = 1.0 / total[i]
            for k in range(lo, hi):
                for i in range(rows):
                    nu[k, i] *= total[i]
        # wbar_r and the rule outputs, the last input's digit varying fastest
        for i in range(rows):
            out[start + i] = 0.0
        for r in range(n_rules):
            rest = r
            for j in range(n_in - 1, -1, -1):
                digit[j] = first[j] + rest % n_mfs[j]
                rest //= n_mfs[j]
            if n_in == 2:  # T and dT/dt: the same operations in one pass
                d0, d1 = digit[0], digit[1]
                c0, c1, c2 = consequents[r, 0], consequents[r, 1], consequents[r, 2]
                for i in range(rows):
                    out[start + i] += (nu[d0, i] * nu[d1, i]) * ((c2 + c0 * Zt[0, start + i]) + c1 * Zt[1, start + i])
                continue
            for i in range(rows):
                wbar[i] = nu[digit[0], i]
                rule[i] = consequents[r, n_in]
            for j in range(1, n_in):
                for i in range(rows):
                    wbar[i] *= nu[digit[j], i]
            for j in range(n_in):
                for i in range(rows):
                    rule[i] += consequents[r, j] * Zt[j, start + i]
            for i in range(rows):
                out[start + i] += wbar[i] * rule[i]
    return out
