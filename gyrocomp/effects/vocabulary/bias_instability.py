"""``bias_instability``: flicker (1/f) bias noise, the flat floor of the Allan curve, or its Markov form."""

from __future__ import annotations

import dataclasses

import numpy as np

from gyrocomp.errors import InputError
from gyrocomp.effects.vocabulary._base import Effect
from gyrocomp.effects import noise as sim_noise
from gyrocomp.effects._fields import unit_field


@dataclasses.dataclass(frozen=True)
class BiasInstability:
    """``bias_instability``: flicker bias noise of IEEE bias instability ``B``.

    With ``correlation_s`` > 0, its Markov form: one Gauss-Markov process of
    that correlation time whose Allan deviation peaks at ``0.664 B``.
    """

    enabled: bool = True
    b_deg_per_h: float = unit_field(10.0, "deg/h")
    correlation_s: float = unit_field(0.0, "s")

    def __post_init__(self):
        if not self.correlation_s >= 0.0:
            raise InputError(f"gyro.bias_instability.correlation_s = {self.correlation_s!r} must be >= 0 s (0: flicker)")


class _BiasInstability(Effect):
    """A covariance term of the likelihood (:mod:`gyrocomp.effects.likelihood`), ``B`` free.

    Two forms: flicker (``B`` alone) and Markov (``B`` and the correlation
    time ``correlation_s`` on the ``bias_correlation_s`` grid, one parameter
    more), the one of lowest BIC kept.
    """

    name = "bias_instability"
    settings = BiasInstability
    stochastic = True
    nonlinear = "correlation_s"
    grid_setting = "bias_correlation_s"
    n_params = 1

    def n_params_of(self, params):
        return self.n_params + bool(params.get(self.nonlinear))

    def grid(self, settings, length_s, block_s):
        """Correlation times of the Markov form: ``bias_correlation_points`` on the log range of the setting,
        within ``[2 T_b, L / bias_correlation_max_fraction]`` (shorter looks white in the block means; longer, a random walk)."""
        lo, hi = getattr(settings, self.grid_setting)
        lo, hi = max(lo, 2.0 * block_s), min(hi, length_s / settings.bias_correlation_max_fraction)
        return np.geomspace(lo, hi, settings.bias_correlation_points) if hi > lo else np.empty(0)

    def noise(self, n, fs_hz, table, rng):
        if table.correlation_s:
            return sim_noise.markov(n, fs_hz, table.b_deg_per_h, table.correlation_s, rng)
        return sim_noise.flicker(n, fs_hz, table.b_deg_per_h, rng)

    def report(self, coef, params, noise):
        units = noise.datasheet_units()
        out = {"b_deg_per_h": units[self.name]}
        if "bias_correlation_s" in units:
            out["correlation_s"] = units["bias_correlation_s"]
        return out


EFFECT = _BiasInstability()
