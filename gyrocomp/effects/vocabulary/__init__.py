"""The effect vocabulary: one object per effect, shared by the simulator and the diagnosis.

DESIGN.md ("The simulator and the sim-to-real gap") names eight effects
that the baseline gyro model (per-run offset + polynomial in temperature +
white noise) leaves out. Each lives in one module of this package as an
:class:`~gyrocomp.effects.vocabulary._base.Effect` object that holds everything the
rest of the code needs to know about it:

* its ``[gyro.<name>]`` settings table (the simulator's parameters, each
  with its unit) and, from it, the bias :meth:`~Effect.bias` it adds to a
  simulated run (or the noise :meth:`~Effect.noise` it draws);
* its columns of the diagnosis' design matrix (:meth:`~Effect.columns`),
  the nonlinear parameter searched on a grid and the ``[diagnose]`` setting
  that holds that grid (:meth:`~Effect.grid`), its free parameters per run
  (:meth:`~Effect.n_params_runs`) and whether it needs a temperature;
* how its fitted parameters are reported, in the simulator's names and
  units (:meth:`~Effect.report`).

:data:`KINDS` maps each name to its object, in the order reports list them
(the pattern of :data:`gyrocomp.models.KINDS`); a new effect is one module
added to it.

==================  ==================  =========================  ============
effect              nonlinear param     grid (configs/diagnose)    temperature
==================  ==================  =========================  ============
thermal_lag         ``tau_s``           ``thermal_lag_tau_s``      yes
temp_rate           (form: symmetric    --                         yes
                    or asymmetric)
hysteresis          ``deadband_c``      ``hysteresis_deadband_c``  yes
                    (form: relay or
                    play)
warmup              ``tau_s``           ``warmup_tau_s``           no
rate_ramp           ``power`` (form:    ``rate_ramp_power``        no
                    line or power law)
periodic            ``period_s``, H     ``periodic_*`` (Fourier)   no
bias_instability    (noise term)        ``bias_correlation_s``     no
                    ``correlation_s``
                    (form: flicker or
                    Markov)
rate_random_walk    (noise term)        --                         no
==================  ==================  =========================  ============
"""

from __future__ import annotations

from gyrocomp.effects.vocabulary import (
    bias_instability,
    hysteresis,
    periodic,
    rate_ramp,
    rate_random_walk,
    temp_rate,
    thermal_lag,
    warmup,
)
from gyrocomp.effects.vocabulary._base import Columns, Effect

__all__ = ["Effect", "KINDS", "EFFECTS", "DETERMINISTIC", "STOCHASTIC", "NEEDS_TEMPERATURE", "PER_RUN"]

KINDS: dict[str, Effect] = {
    module.EFFECT.name: module.EFFECT
    for module in (thermal_lag, temp_rate, hysteresis, warmup, rate_ramp, periodic, bias_instability, rate_random_walk)
}
"""Effect object by its name (the vocabulary of DESIGN.md), in report order."""

EFFECTS = tuple(KINDS)
"""The vocabulary's names, in report order."""
STOCHASTIC = tuple(name for name, e in KINDS.items() if e.stochastic)
"""Effects that enter the likelihood as covariance terms."""
DETERMINISTIC = tuple(name for name, e in KINDS.items() if not e.stochastic)
"""Effects that enter as regressors on the rate."""
NEEDS_TEMPERATURE = tuple(name for name, e in KINDS.items() if e.needs_temperature)
"""Effects that cannot be simulated or diagnosed without a temperature."""
PER_RUN = Columns(("offset",) + tuple(c for e in KINDS.values() for c in e.per_run))
"""Design columns re-estimated on every run (a power-on constant, an interference phase and its harmonics)."""
