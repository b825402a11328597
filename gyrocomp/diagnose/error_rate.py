"""The error rates the diagnosis states for its list of named effects and for its "unexplained" verdict.

Two errors are possible on a recording the vocabulary explains:

* **a false name** -- an effect the gyro does not have is listed. An effect
  enters when it lowers the BIC of the selection runs by more than
  ``bic_margin``: for a candidate with ``k`` parameters, absent from the
  gyro, the likelihood-ratio statistic is ``chi^2_k`` (Wilks) and it enters
  with probability ``P(chi^2_k > k ln n + bic_margin)`` (``n`` block means
  of the selection runs). By Bonferroni over the candidates of the
  registry, the family-wise probability that the first forward step names
  any absent effect is at most the sum of these: the stated
  ``family_rate``. It holds for a fixed shape; a search over a nonlinear
  parameter (a time constant, a period) takes the best of many shapes and
  raises each term, so the figure is a floor, not a ceiling, for those
  candidates, and the benchmarks' effect-free pairs are its check;
* **a false "unexplained"** -- the residual tests (every test on every
  run, one family) reject by Holm's step-down procedure at
  ``family_alpha``: the family-wise rate is at most ``family_alpha``; a
  selected noise term's signature adds its own ``[diagnose.signature]
  refusal_alpha`` (Bonferroni).
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from gyrocomp.diagnose.effects import KINDS

__all__ = ["error_rate"]


def error_rate(candidates, first_step, n_blocks, bic_margin, family_alpha, signature_alpha) -> dict:
    """The stated error rates of one diagnosis (module docstring).

    Parameters
    ----------
    candidates : sequence of str
        The effects that could be added.
    first_step : dict
        ``{effect: Fitted}``, each candidate fitted alone (its parameter count).
    n_blocks : int
        Block means of the selection runs.
    bic_margin, family_alpha, signature_alpha : float

    Returns
    -------
    dict
        ``per_candidate`` (each one's entry probability when absent),
        ``family_rate`` (their Bonferroni sum, at most 1), ``unexplained_rate``
        (``family_alpha``), ``signature_rate`` and ``statement`` (words).

    Examples
    --------
    >>> f"{float(stats.chi2.sf(np.log(720) + 10.0, 1)):.2e}"  # one parameter on 720 blocks
    '4.67e-05'
    """
    per = {}
    for effect in candidates:
        model = first_step.get(effect)
        k = KINDS[effect].n_params_of(model.spec.get(effect, {}) if model is not None else {})
        per[effect] = float(stats.chi2.sf(k * np.log(n_blocks) + bic_margin, k))
    family = float(min(1.0, sum(per.values())))
    statement = (
        f"named effects: the probability that the first selection step names an effect the gyro does not have is at most "
        f"{family:.2g} (Bonferroni over the {len(per)} candidates, each P(chi2_k > k ln {n_blocks} + {bic_margin:g}); "
        "exact for fixed shapes, a floor where a nonlinear parameter is searched); "
        f"'unexplained': family-wise at most {family_alpha:g} (Holm over every residual test on every run)"
        + (f", plus {signature_alpha:g} per selected noise term's signature" if signature_alpha else "")
    )
    return {"per_candidate": per, "family_rate": family, "unexplained_rate": family_alpha, "signature_rate": signature_alpha,
            "statement": statement}
