"""Compiled ANFIS forward pass (numba): one fused pass per row instead of some 20 array passes.

:func:`gyrocomp.models.anfis._predict` with NumPy builds, per row block,
the log memberships of every input, their outer sum over the rule grid,
its exponential and its normalisation, then the rule outputs: on 7.2e6
rows of the 16 + 4 rules of PE-LCD-ANFIS that took 15 s of a 30 s
``compensate`` (cProfile). This kernel computes the same output row by
row in registers, using that the normalised firing strength of the grid
partition factorises ([2] eqs. (23)-(24)):

    wbar_r = prod_j mu_j,k_j / sum_r prod_j mu_j,k_j = prod_j nu_j,k_j,
    nu_j,k = mu_j,k / sum_k mu_j,k,

so each input is normalised over its own membership functions. With
``gbell`` mu = 1 / (1 + exp(s)), s = 2 b log|u|, u = (z - c) / a; with
``gauss`` log mu = -q, q = u^2 / 2, u = (z - c) / sigma. Where every
membership of an input is below exp(-`SHIFT_ABOVE`) (an input far outside
the training range, never after clamping), nu is taken from the shifted
logarithms, exp(s_min - s_k) (there log mu = -s to double precision), as
the NumPy path does with its row maximum. The output is
sum_r wbar_r (c_r . z + c_r0) ([2] eq. (25)); it equals the NumPy path to
rounding (tests/models/test_anfis.py). Imported lazily by
:func:`gyrocomp.models.anfis._predict`; numba compiles on first use and
caches the machine code beside this file (``cache=True``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

SHIFT_ABOVE = 600.0
"""Smallest exponent s (or q) of an input's largest membership from which nu comes from shifted logarithms."""


@numba.njit(cache=True)
def forward(Z, centre, width, slope, first, n_mfs, consequents, gbell, out):
    """Model output of every row of `Z` (n_rows, n_inputs) into `out`.

    Membership k of input j is at ``first[j] + k`` of `centre`, `width`
    (a or sigma) and `slope` (b; unused for ``gauss``); rule r combines
    the memberships of the digits of r in the mixed radix `n_mfs`, the
    first input the most significant, as the rows of `consequents`.
    """
    n_rows, n_in = Z.shape
    n_rules = consequents.shape[0]
    exponent = np.empty(centre.size)
    nu = np.empty(centre.size)
    wbar = np.empty(n_rules)
    for i in range(n_rows):
        for j in range(n_in):
            lo, hi = first[j], first[j] + n_mfs[j]
            smallest = np.inf
            for k in range(lo, hi):
                u = (Z[i, j] - centre[k]) / width[k]
                if gbell:
                    e = 2.0 * slope[k] * math.log(max(abs(u), 1e-300))
                else:
                    e = 0.5 * u * u
                exponent[k] = e
                smallest = min(smallest, e)
            total = 0.0
            for k in range(lo, hi):
                if smallest >= SHIFT_ABOVE:
                    mu = math.exp(smallest - exponent[k])
                elif gbell:
                    mu = 1.0 / (1.0 + math.exp(exponent[k]))
                else:
                    mu = math.exp(-exponent[k])
                nu[k] = mu
                total += mu
            for k in range(lo, hi):
                nu[k] /= total
        # wbar over the rule grid, the last input varying fastest
        wbar[0] = 1.0
        size = 1
        for j in range(n_in):
            m = n_mfs[j]
            for t in range(size - 1, -1, -1):
                w = wbar[t]
                for k in range(m - 1, -1, -1):
                    wbar[t * m + k] = w * nu[first[j] + k]
            size *= m
        acc = 0.0
        for r in range(n_rules):
            rule = consequents[r, n_in]
            for j in range(n_in):
                rule += consequents[r, j] * Z[i, j]
            acc += wbar[r] * rule
        out[i] = acc
    return out
