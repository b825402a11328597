"""``hysteresis``: the bias keeps the branch of the last temperature direction through a soak."""

from __future__ import annotations

import dataclasses

import numpy as np

from gyrocomp.errors import InputError
from gyrocomp.effects.vocabulary._base import Columns, Effect
from gyrocomp.effects import shapes
from gyrocomp.effects._fields import unit_field


OPERATORS = {"relay": shapes.hysteresis_branch, "play": shapes.hysteresis_play}
"""The hysteresis operators by name: two-branch relay, play (backlash); both ``f(time_s, temperature_c, width_c)``."""


@dataclasses.dataclass(frozen=True)
class Hysteresis:
    """``hysteresis``: bias ``A`` times a hysteresis operator of width ``deadband_c``:
    ``relay``, ``+A`` on the heating branch and ``-A`` on the cooling one
    (:func:`~gyrocomp.effects.shapes.hysteresis_branch`), or ``play``, moving
    linearly between them over ``deadband_c`` after each reversal
    (:func:`~gyrocomp.effects.shapes.hysteresis_play`)."""

    enabled: bool = False
    amplitude_dps: float = unit_field(0.01, "deg/s")
    deadband_c: float = unit_field(0.5, "degC")
    operator: str = "relay"

    def __post_init__(self):
        if self.operator not in OPERATORS:
            raise InputError(f"[gyro.hysteresis] operator = {self.operator!r}: one of {', '.join(OPERATORS)}")


class _Hysteresis(Effect):
    """Columns: the operator's output (relay: heating +1 / cooling -1 branch; play: moving between them) for a width ``deadband_c``, and the power-on part.

    The relay and the play are the two limits of a spread of switching
    widths (a Preisach model): one width, or widths spread evenly up to
    ``deadband_c``. They are the effect's :attr:`forms`, with the same
    parameters; the diagnosis fits each over the width grid and keeps the
    one of lowest BIC (a play fitted by a relay leaves its ramps between
    the branches, slow structure a random walk then absorbs).

    The state the part was left in before power-on is not in the
    recording; what it adds is re-estimated on every run, as the offset is.
    A relay sits on an unknown branch until the temperature first moves
    beyond its width (:func:`~gyrocomp.effects.shapes.first_excursion`): one
    indicator, exact. A play powered on near a branch follows the
    temperature at once, while the centred start the operator assumes waits
    half the width: not a constant, so a play takes two columns, its start
    on either branch less its centred start
    (:func:`~gyrocomp.effects._stateful.play_start_spread`; exact at either
    branch, within a quarter of the amplitude between).
    """

    name = "hysteresis"
    settings = Hysteresis
    needs_temperature = True
    nonlinear = "deadband_c"
    grid_setting = "hysteresis_deadband_c"
    n_params = 3
    per_run = Columns(("hysteresis_power_on", "hysteresis_power_on_high", "hysteresis_power_on_low"))
    unit_columns = 1
    forms = tuple({"operator": name} for name in OPERATORS)

    def n_per_run(self, params=None):
        """The power-on part: one indicator for a relay, two columns for a play."""
        return 2 if (params or {}).get("operator", "relay") == "play" else 1

    def n_params_of(self, params):
        """Amplitude, width and the power-on part."""
        return 2 + self.n_per_run(params)

    def bias(self, time_s, housing_c, gyro):
        h = gyro.hysteresis
        return h.amplitude_dps * OPERATORS[h.operator](time_s, housing_c, h.deadband_c)

    def columns(self, run, params, poly_degree=3, scale=None):
        d = params["deadband_c"]
        if params.get("operator", "relay") == "relay":
            branch = shapes.hysteresis_branch(run.time_s, run.temperature_c, d)
            power_on = np.arange(branch.size) < shapes.first_excursion(run.temperature_c, d)
            return np.column_stack([branch, power_on]), [self.name, self.per_run[0]]
        from gyrocomp.effects._stateful import play_start_spread  # numba: loaded when a play is first fitted

        # One compiled pass: the two power-on columns and the centred play up to its first excursion.
        spread = np.empty((run.time_s.size, 3))
        restart = np.zeros(run.time_s.size, dtype=bool)
        restart[:1] = True
        play_start_spread(np.ascontiguousarray(run.temperature_c, dtype=float), restart, 0.5 * d, spread)
        branch = shapes.hysteresis_play(run.time_s, run.temperature_c, d, centred=spread[:, 2])
        return np.column_stack([branch, spread[:, :2]]), [self.name, *self.per_run[1:]]

    def grid(self, settings, length_s, block_s):
        return np.array([float(v) for v in getattr(settings, self.grid_setting)])

    def report(self, coef, params, noise):
        return {
            "amplitude_dps": {"value": coef[self.name], "unit": "deg/s"},
            "deadband_c": {"value": params["deadband_c"], "unit": "degC"},
            "operator": {"value": params.get("operator", "relay"), "unit": ""},
        }


EFFECT = _Hysteresis()
