r"""Stepwise selection of effects by one criterion: BIC on the selection runs.

The method in one place; its code is in three modules: the criterion
(:mod:`gyrocomp.diagnose.criterion`), the nonlinear search of one effect
(:mod:`gyrocomp.diagnose.nonlinear`) and the stepwise search
(:mod:`gyrocomp.diagnose.search`).

Every model is the baseline (per-run offset, temperature polynomial, white
noise) plus a set of effects; it is scored by the block-mean likelihood of
:mod:`gyrocomp.effects.likelihood`, in which deterministic effects are
regressors and ``bias_instability`` / ``rate_random_walk`` are noise terms.

**The criterion.** A model's score is its BIC on the *selection runs* (the
fit run, plus the holdouts that take part in the selection; never the run
the held-out gap is reported on):

.. math:: \mathrm{BIC} = \sum_r -2 \log L_r + k \ln \sum_r n_r

with the deterministic coefficients shared by the runs, the per-run columns
(offset, a sinusoid's phase) and the noise levels fitted on each run, ``k``
counting each of those once per run (:meth:`gyrocomp.diagnose.search.Search.score`). An effect
**earns its place** in a model when removing it raises the score by more
than ``bic_margin`` (:meth:`gyrocomp.diagnose.search.Search.earns`), and a noise term must in
addition pass the admissibility check given to the search (its own
signature on the runs). Every move uses that one rule:

* **forward** adds the candidate that lowers the score most, if it earns
  its place;
* **backward** drops, after each addition, an effect that no longer earns
  its place (a random walk that stood in for a warm-up before the warm-up
  was in), when the model left still passes the admissibility check;
* **swap** replaces one selected effect by one or (for a noise term, which
  can stand in for two causes) two others, when the new model scores lower
  and every effect it brings earns its place.

For one deterministic parameter on 720 blocks the margin of 10 asks for a
``-2 log L`` drop of ``ln 720 + 10 = 16.6``: a false-alarm rate of
``P(chi^2_1 > 16.6) = 4.7e-5`` per tried effect and move, at most about
``4e-4`` over the eight candidates of a forward step (Bonferroni). For a
noise term at the boundary of its range the null distribution is half a
``chi^2_1`` (Self & Liang 1987), so the rate is halved.

Adding a deterministic effect refits the nonlinear parameters of those
already in (a warm-up fitted alone stretches its time constant over a
ramp), and an accepted model is settled at its own noise before the next
step (:meth:`gyrocomp.diagnose.search.Search.settle`), so that a later step is not credited with
the refit of an earlier effect's parameters. Look-alikes are told apart by
the likelihood of their shapes, not by a rule: thermal lag must reproduce
the decaying transient after every step, temperature-rate sensitivity the
square pulses of dT/dt that vanish in a soak, hysteresis an offset that
holds through a soak; a rate ramp is a line in time while a random walk
only widens the covariance.

References
----------
.. [1] G. Schwarz, "Estimating the dimension of a model", Ann. Stat. 6(2), 461-464 (1978).
.. [2] R. E. Kass, A. E. Raftery, "Bayes factors", JASA 90(430), 773-795 (1995).
.. [3] S. G. Self, K.-Y. Liang, "Asymptotic properties of maximum likelihood
   estimators and likelihood ratio tests under nonstandard conditions", JASA 82(398), 605-610 (1987).
"""

from __future__ import annotations

from gyrocomp.diagnose.criterion import Fitted, Problem, fit_baseline, holdout_fit, residual_of, sample_arw
from gyrocomp.diagnose.nonlinear import extend
from gyrocomp.diagnose.search import Search

__all__ = ["Fitted", "Problem", "Search", "fit_baseline", "extend", "holdout_fit", "residual_of", "sample_arw"]
