"""``bias_instability``: flicker (1/f) bias noise, the flat floor of the Allan curve."""

from __future__ import annotations

import dataclasses

from gyrocomp.sim.vocabulary._base import Effect
from gyrocomp.sim import noise as sim_noise
from gyrocomp.sim.profile import unit_field


@dataclasses.dataclass(frozen=True)
class BiasInstability:
    """``bias_instability``: flicker bias noise of IEEE bias instability ``B``."""

    enabled: bool = True
    b_deg_per_h: float = unit_field(10.0, "deg/h")


class _BiasInstability(Effect):
    """A covariance term of the likelihood (:mod:`gyrocomp.diagnose.likelihood`), ``B`` free."""

    name = "bias_instability"
    settings = BiasInstability
    stochastic = True
    n_params = 1

    def noise(self, n, fs_hz, table, rng):
        return sim_noise.flicker(n, fs_hz, table.b_deg_per_h, rng)

    def report(self, coef, params, noise):
        return {"b_deg_per_h": noise.datasheet_units()[self.name]}


EFFECT = _BiasInstability()
