"""Gyro simulator: oven temperature profiles, the baseline error model and every effect.

Public API
----------
:func:`simulate`
    ``simulate(gyro, profile, *, fs_hz, seed, truth_columns=False, reference=None)``
    -> ``(frame, truth)``.
:func:`profile_from_recording`
    Drive the simulator by a recording's measured temperature.
:mod:`gyrocomp.effects`
    The effect shapes and vocabulary the simulator shares with the diagnosis
    and the grey-box model.
:mod:`gyrocomp.sim.model`
    Settings dataclasses and :func:`load_sim_config`.
"""

from gyrocomp.sim.model import (
    EFFECTS,
    GyroSettings,
    ReferenceSettings,
    RunSettings,
    SimConfig,
    load_sim_config,
)
from gyrocomp.sim.profile import Profile, ProfileSettings, profile_from_recording, temperature_profile
from gyrocomp.sim.simulate import RECORDING_SCHEMA, run, simulate

__all__ = [
    "EFFECTS",
    "GyroSettings",
    "Profile",
    "ProfileSettings",
    "RECORDING_SCHEMA",
    "ReferenceSettings",
    "RunSettings",
    "SimConfig",
    "load_sim_config",
    "profile_from_recording",
    "run",
    "simulate",
    "temperature_profile",
]
