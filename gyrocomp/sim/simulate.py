"""Turn a temperature profile and a gyro error model into a recording.

The output rate is, sample by sample (all terms in deg/s)::

    rate = reference_rate + truth_scale_factor      (turntable input, scale-factor error)
         + truth_drift                              (offset + polynomial + deterministic effects)
         + truth_noise                              (white, ARW)
         + truth_bias_instability + truth_rate_random_walk
         + truth_quantization                       (rounding to the output LSB)

with ``truth_drift = truth_baseline + truth_thermal_lag + truth_temp_rate +
truth_hysteresis + truth_warmup + truth_rate_ramp + truth_periodic`` (the
enabled ones) and ``truth_baseline = offset + sum_k c_k (T_h - T_ref)^k``
in the true housing temperature ``T_h``. The papers' baseline model is
``offset + polynomial + white noise``; every other term is an effect of
the vocabulary. The truth (every parameter with its unit) does not depend
on the seed; the noise does.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from gyrocomp.config import settings_dict
from gyrocomp.errors import InputError
from gyrocomp.effects import shapes as effects
from gyrocomp.effects import noise
from gyrocomp.sim.model import GyroSettings, ReferenceSettings, SimConfig, units_of
from gyrocomp.sim.profile import Profile, ProfileSettings, profile_duration_s, temperature_profile
from gyrocomp.effects.vocabulary import DETERMINISTIC, EFFECTS, KINDS, STOCHASTIC

__all__ = ["simulate", "run", "reference_rate", "RECORDING_SCHEMA"]

RECORDING_SCHEMA = "gyrocomp.recording"

_STREAMS = ("temperature_sensor", "white") + STOCHASTIC
"""Independent random streams, spawned from the seed in this order, so that
switching one noise source on or off leaves the others' draws unchanged."""

_COLUMN_UNITS = {"time": "s", "rate": "deg/s", "temperature": "degC", "reference_rate": "deg/s", "truth_temperature": "degC"}


def simulate(
    gyro: GyroSettings,
    profile: ProfileSettings | Profile,
    *,
    fs_hz: float | None = 1.0,
    seed: int | None = 0,
    truth_columns: bool = False,
    reference: ReferenceSettings | np.ndarray | None = None,
    duration_s: float = 0.0,
    progress=None,
) -> tuple[pd.DataFrame, dict]:
    """Simulate one gyro run.

    Parameters
    ----------
    gyro : GyroSettings
        Baseline error model and effects.
    profile : ProfileSettings or Profile
        An oven profile, or temperatures on a time grid
        (:func:`~gyrocomp.sim.profile.profile_from_recording`).
    fs_hz : float or None, default=1.0
        Sample rate [Hz]. ``None`` keeps a :class:`Profile`'s own grid.
    seed : int or None, default=0
        Seed of every random draw (sensor noise and the three rate noises).
    truth_columns : bool, default=False
        Add ``truth_*`` columns, one per contribution (module docstring).
    reference : ReferenceSettings or array_like or None
        Reference angular rate [deg/s] (turntable), written as
        ``reference_rate``; an array must match the number of samples.
    duration_s : float, default=0.0
        Length [s]; 0 takes the profile's (the last level holds beyond it).
    progress : callable, optional
        ``progress(done, total)`` after each generation step.

    Returns
    -------
    frame : pandas.DataFrame
        ``time`` [s], ``rate`` [deg/s], ``temperature`` [degC, measured],
        ``reference_rate`` [deg/s] when a reference is given, then the
        ``truth_*`` columns when requested.
    truth : dict
        Every effect and parameter with its unit (independent of `seed`).
    """
    steps = 9
    report = progress or (lambda done, total: None)
    streams = [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(len(_STREAMS))]
    rng = dict(zip(_STREAMS, streams))
    temps = _profile_on_grid(profile, fs_hz, duration_s, rng["temperature_sensor"])
    time_s, housing = temps.time_s, temps.housing_c
    n = time_s.size
    fs = fs_hz if fs_hz is not None else 1.0 / float(np.median(np.diff(time_s)))
    report(1, steps)

    parts: dict[str, np.ndarray] = {}
    keep = truth_columns

    def add(total, name, values):
        if keep:
            parts[name] = values
        if total is None:
            return values.copy()
        total += values
        return total

    drift = add(None, "truth_baseline", effects.bias_polynomial(housing, gyro.temperature_coefficients, gyro.reference_c) + gyro.offset_dps)
    report(2, steps)
    for name in DETERMINISTIC:
        if getattr(gyro, name).enabled:
            drift = add(drift, f"truth_{name}", KINDS[name].bias(time_s, housing, gyro))
    if keep:
        parts["truth_drift"] = drift.copy()
    report(4, steps)

    rate = drift
    rate = add(rate, "truth_noise", noise.white(n, fs, gyro.arw, rng["white"]))
    report(5, steps)
    for name in STOCHASTIC:
        table = getattr(gyro, name)
        if table.enabled:
            rate = add(rate, f"truth_{name}", KINDS[name].noise(n, fs, table, rng[name]))
    report(7, steps)

    columns = {"time": time_s, "rate": rate, "temperature": temps.measured_c}
    if reference is not None:
        ref = reference_rate(reference, time_s) if isinstance(reference, ReferenceSettings) else np.asarray(reference, dtype=float)
        if ref is not None:
            if ref.shape != (n,):
                raise InputError(f"reference: {ref.shape} values for {n} samples")
            scale = 1e-6 * (gyro.scale_factor_ppm + gyro.scale_factor_ppm_per_c * (housing - gyro.reference_c))
            rate = add(rate, "truth_scale_factor", scale * ref)
            rate += ref
            columns["reference_rate"] = ref
    if gyro.resolution_dps > 0:
        quantised = np.round(rate / gyro.resolution_dps) * gyro.resolution_dps
        if keep:
            parts["truth_quantization"] = quantised - rate
        rate = quantised
    columns["rate"] = rate
    report(8, steps)
    if keep:
        parts["truth_temperature"] = housing
        columns.update(sorted(parts.items()))
    frame = pd.DataFrame(columns)
    truth = _truth(gyro, profile, temps, fs, n, reference)
    report(9, steps)
    return frame, truth


def run(config: SimConfig, *, temperature_from=None, progress=None) -> tuple[pd.DataFrame, dict]:
    """Run a resolved config; return the frame and its ``gyrocomp.recording`` header.

    Parameters
    ----------
    config : SimConfig
        From :func:`~gyrocomp.sim.model.load_sim_config`.
    temperature_from : gyrocomp.recordings.Recording, optional
        Drive the run by this recording's measured temperature instead of
        the config's profile (its time axis, unless ``run.fs_hz`` differs).
    progress : callable, optional
        ``progress(done, total)``.

    Returns
    -------
    frame : pandas.DataFrame
    header : dict
        :func:`gyrocomp.artefacts.artefact_header` with the resolved settings, the
        seed, and the truth under ``"truth"``.
    """
    from gyrocomp import artefacts
    from gyrocomp.sim.profile import profile_from_recording

    inputs = []
    profile: ProfileSettings | Profile = config.profile
    if temperature_from is not None:
        profile = profile_from_recording(temperature_from)
        inputs.append(temperature_from.input_record())
    reference = config.reference if config.reference.kind != "none" else None
    frame, truth = simulate(
        config.gyro,
        profile,
        fs_hz=config.run.fs_hz,
        seed=config.run.seed,
        truth_columns=config.run.truth_columns,
        reference=reference,
        duration_s=config.run.duration_s,
        progress=progress,
    )
    settings = {name: settings_dict(getattr(config, name)) for name in ("run", "gyro", "profile", "reference")}
    if temperature_from is not None:
        settings["profile"] = {"recording": temperature_from.input_record()}
    header = artefacts.artefact_header(RECORDING_SCHEMA, inputs=inputs, settings=settings, seed=config.run.seed)
    header["truth"] = truth
    return frame, header


def reference_rate(settings: ReferenceSettings, time_s) -> np.ndarray | None:
    """The turntable rate [deg/s] of `settings` at `time_s` [s] (``None`` for kind "none")."""
    t = np.asarray(time_s, dtype=float)
    if settings.kind == "steps":
        levels = np.asarray(settings.levels_dps, dtype=float)
        index = np.floor((t - t[0]) / settings.step_s).astype(np.int64) % levels.size
        return levels[index]
    if settings.kind == "sine":
        return settings.amplitude_dps * np.sin(2.0 * np.pi * t / settings.period_s)
    return None


def _profile_on_grid(profile, fs_hz, duration_s, rng) -> Profile:
    if isinstance(profile, ProfileSettings):
        if fs_hz is None:
            raise InputError("simulate: fs_hz is needed for a profile given by settings")
        length = duration_s or profile_duration_s(profile)
        return temperature_profile(profile, _grid(length, fs_hz), rng)
    if not isinstance(profile, Profile):
        raise InputError(f"simulate: profile must be ProfileSettings or Profile, not {type(profile).__name__}")
    if fs_hz is None and not duration_s:
        return profile
    fs = fs_hz if fs_hz is not None else 1.0 / float(np.median(np.diff(profile.time_s)))
    length = duration_s or float(profile.time_s[-1])
    return profile.on_grid(_grid(length, fs))


def _grid(length_s: float, fs_hz: float) -> np.ndarray:
    """Sample times [s] of a run of `length_s` at `fs_hz`; refused beyond ``simulate_max_samples`` (``configs/recordings.toml`` ``[lengths]``)."""
    from gyrocomp.recordings import check_length

    n = np.floor(length_s * fs_hz + 1e-9) + 1
    check_length("simulate_max_samples", n, f"simulate: {length_s:.6g} s at {fs_hz:g} Hz")
    return np.arange(int(n)) / fs_hz


def _truth(gyro: GyroSettings, profile, temps: Profile, fs, n, reference) -> dict:
    gyro_dict = settings_dict(gyro)
    units = units_of(gyro)
    effects_truth = {}
    for name in EFFECTS:
        params = {k: v for k, v in gyro_dict[name].items() if k != "enabled"}
        effects_truth[name] = {"enabled": gyro_dict[name]["enabled"], "params": params, "units": units[name]}
    baseline_keys = ("offset_dps", "reference_c", "temperature_coefficients", "arw")
    output_keys = ("resolution_dps", "scale_factor_ppm", "scale_factor_ppm_per_c")
    if isinstance(profile, ProfileSettings):
        profile_truth = {"source": "settings", "params": settings_dict(profile), "units": units_of(profile)}
    else:
        profile_truth = {"source": profile.source}
    if isinstance(reference, ReferenceSettings):
        reference_truth = settings_dict(reference)
    else:
        reference_truth = {"kind": "none" if reference is None else "array"}
    columns = dict(_COLUMN_UNITS)
    return {
        "gyro": gyro.name,
        "baseline": {
            "params": {k: gyro_dict[k] for k in baseline_keys},
            "units": {k: units[k] for k in baseline_keys},
            "temperature": "housing (the measured column without sensor noise and rounding)",
        },
        "effects": effects_truth,
        "active_effects": gyro.active_effects(),
        "output": {"params": {k: gyro_dict[k] for k in output_keys}, "units": {k: units[k] for k in output_keys}},
        "profile": profile_truth,
        "reference": reference_truth,
        "fs_hz": float(fs),
        "n_samples": int(n),
        "duration_s": float(temps.time_s[-1] - temps.time_s[0]) if n else 0.0,
        "column_units": columns,
        "identity": (
            "rate = reference_rate + truth_scale_factor + truth_drift + truth_noise "
            "+ truth_bias_instability + truth_rate_random_walk + truth_quantization; "
            "truth_drift = truth_baseline + the enabled deterministic effects"
        ),
    }

