"""``rate_random_walk``: a random walk of the bias (Allan slope +1/2)."""

from __future__ import annotations

import dataclasses

from gyrocomp.effects.vocabulary._base import Effect
from gyrocomp.effects import noise as sim_noise
from gyrocomp.effects._fields import unit_field


@dataclasses.dataclass(frozen=True)
class RateRandomWalk:
    """``rate_random_walk``: random walk of the bias with IEEE coefficient ``K``."""

    enabled: bool = True
    k_deg_per_h_per_sqrt_h: float = unit_field(5.0, "deg/h/sqrt(h)")


class _RateRandomWalk(Effect):
    """A covariance term of the likelihood (:mod:`gyrocomp.effects.likelihood`), ``K`` free."""

    name = "rate_random_walk"
    settings = RateRandomWalk
    stochastic = True
    n_params = 1

    def noise(self, n, fs_hz, table, rng):
        return sim_noise.random_walk(n, fs_hz, table.k_deg_per_h_per_sqrt_h, rng)

    def report(self, coef, params, noise):
        return {"k_deg_per_h_per_sqrt_h": noise.datasheet_units()[self.name]}


EFFECT = _RateRandomWalk()
