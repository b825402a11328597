"""Contract test over every deterministic effect of the vocabulary: the simulated bias lies in the span of its diagnosis columns.

The simulator (:func:`gyrocomp.sim.simulate`, each effect's ``bias``) and
the diagnosis (:func:`gyrocomp.diagnose.effects.design`, each effect's
``columns``) are two generators of one effect. For every effect and every
form the simulator draws, the baseline plus that effect alone (its
``truth_*`` columns, on the true housing temperature) is fitted by least
squares on the diagnosis design at the true nonlinear parameter: it must be
in its span to rounding, and the baseline's columns alone must leave most
of the effect (the test can fail).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gyrocomp import sim
from gyrocomp.diagnose.effects import Run, TemperatureScale, design
from gyrocomp.effects.vocabulary import DETERMINISTIC

PROFILE = sim.ProfileSettings(start_hold_s=600.0, levels_c=(40.0, 10.0, 35.0), hold_s=(1200.0,), ramp_c_per_min=(1.0,))
"""Heats, cools and heats again: every effect's columns are identifiable."""

CASES = [
    ("thermal_lag", {}, {"tau_s": 400.0}),
    ("temp_rate", {}, {"asymmetric": False}),
    ("temp_rate", {"asymmetry_dps_per_c_per_s": 0.5}, {"asymmetric": True}),
    ("hysteresis", {"deadband_c": 0.5, "operator": "relay"}, {"deadband_c": 0.5, "operator": "relay"}),
    ("hysteresis", {"deadband_c": 9.0, "operator": "play"}, {"deadband_c": 9.0, "operator": "play"}),
    ("warmup", {}, {"tau_s": 900.0}),
    ("rate_ramp", {}, {"form": "linear", "power": 1.0}),
    ("periodic", {}, {"period_s": 1800.0, "harmonics": 1}),
]


def test_every_deterministic_effect_has_a_case():
    assert {effect for effect, *_ in CASES} == set(DETERMINISTIC)


def _left(target, X):
    coef, *_ = np.linalg.lstsq(X, target, rcond=None)
    return float(np.sqrt(np.mean((target - X @ coef) ** 2)))


@pytest.mark.parametrize("effect, table, params", CASES, ids=[f"{e}-{p}" for e, _, p in CASES])
def test_the_simulated_bias_lies_in_the_span_of_its_diagnosis_columns(effect, table, params):
    base = sim.GyroSettings()
    tables = {n: dataclasses.replace(getattr(base, n), enabled=(n == effect), **(table if n == effect else {})) for n in DETERMINISTIC}
    frame, _ = sim.simulate(dataclasses.replace(base, **tables), PROFILE, fs_hz=1.0, seed=0, truth_columns=True)
    t, housing = frame["time"].to_numpy(), frame["truth_temperature"].to_numpy()
    run = Run("sim", t, frame["rate"].to_numpy(), housing, 1.0, 10)
    bias = frame[f"truth_{effect}"].to_numpy()
    target = frame["truth_baseline"].to_numpy() + bias
    scale = TemperatureScale.of(housing)
    size = float(np.std(bias))
    assert _left(target, design(run, {effect: params}, 3, scale)[0]) < 1e-6 * size
    assert _left(target, design(run, {}, 3, scale)[0]) > 0.3 * size
