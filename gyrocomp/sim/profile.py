"""Temperature profiles: oven set-point, chamber response and temperature sensor.

A profile starts at `start_c` for `start_hold_s` (power-on at room
temperature), then visits each of `levels_c` in turn: a linear set-point
ramp at `ramp_c_per_min`, then a soak of `hold_s`. The papers' oven test
(``configs/profiles/oven-paper.toml``; Cao et al. 2021 Sec. IV-A, Zhang et
al. 2024 Sec. 5.1) is one hour at room temperature, a fast heat to 60 degC
and an hour's hold, then 10 degC steps down to -40 degC with an hour's soak
each.

The gyro housing follows the set-point through a first-order chamber
response of time constant `chamber_tau_s`; that housing temperature drives
the bias. The recording's ``temperature`` column is what the on-board
sensor reports: housing temperature plus white sensor noise of
`sensor_noise_c`, rounded to `sensor_resolution_c`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gyrocomp.errors import InputError
from gyrocomp.effects._fields import check_numbers, unit_field
from gyrocomp.effects.shapes import element_temperature

__all__ = ["ProfileSettings", "Profile", "setpoint", "profile_duration_s", "temperature_profile", "measure", "profile_from_recording"]


@dataclasses.dataclass(frozen=True)
class ProfileSettings:
    """A piecewise oven profile (defaults: the papers' oven test).

    `hold_s` and `ramp_c_per_min` hold one value per level, or one value for
    all levels.
    """

    start_c: float = unit_field(25.0, "degC")
    start_hold_s: float = unit_field(3600.0, "s")
    levels_c: tuple = unit_field((60.0, 50.0, 40.0, 30.0, 20.0, 10.0, 0.0, -10.0, -20.0, -30.0, -40.0), "degC")
    hold_s: tuple = unit_field((3600.0,), "s")
    ramp_c_per_min: tuple = unit_field((5.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0), "degC/min")
    chamber_tau_s: float = unit_field(480.0, "s")
    sensor_noise_c: float = unit_field(0.02, "degC")
    sensor_resolution_c: float = unit_field(0.0625, "degC")

    def __post_init__(self):
        check_numbers(self, "profile")
        n = len(self.levels_c)
        for name in ("hold_s", "ramp_c_per_min"):
            values = getattr(self, name)
            if len(values) not in (1, n):
                raise InputError(f"profile.{name}: {len(values)} values for {n} levels; give 1 or {n}")
            if any(not v > 0 for v in values) and name == "ramp_c_per_min":
                raise InputError(f"profile.ramp_c_per_min: {values!r} must all be > 0")
            if any(not v >= 0 for v in values):
                raise InputError(f"profile.{name}: {values!r} must all be >= 0")
        for name in ("start_hold_s", "chamber_tau_s", "sensor_noise_c", "sensor_resolution_c"):
            if not getattr(self, name) >= 0:
                raise InputError(f"profile.{name} = {getattr(self, name)!r} must be >= 0")
        from gyrocomp.recordings import PLAUSIBLE_DEGC

        lo, hi = PLAUSIBLE_DEGC
        for name, values in (("start_c", (self.start_c,)), ("levels_c", self.levels_c)):
            if any(not lo <= v <= hi for v in values):
                raise InputError(
                    f"profile.{name} = {getattr(self, name)!r} leaves [{lo:g}, {hi:g}] degC, "
                    "the temperatures the recording reader accepts: the simulated recording could not be read back"
                )

    def breakpoints(self) -> tuple[np.ndarray, np.ndarray]:
        """Corners ``(time_s, setpoint_c)`` of the piecewise-linear set-point."""
        n = len(self.levels_c)
        holds = np.broadcast_to(np.asarray(self.hold_s, dtype=float), (n,))
        ramps = np.broadcast_to(np.asarray(self.ramp_c_per_min, dtype=float), (n,)) / 60.0
        times, temps = [0.0, self.start_hold_s], [self.start_c, self.start_c]
        for level, hold, ramp in zip(self.levels_c, holds, ramps):
            times.append(times[-1] + abs(level - temps[-1]) / ramp)
            temps.append(level)
            times.append(times[-1] + hold)
            temps.append(level)
        return np.asarray(times), np.asarray(temps, dtype=float)


@dataclasses.dataclass(frozen=True)
class Profile:
    """Temperatures on a time grid.

    Attributes
    ----------
    time_s : numpy.ndarray
        Time [s] from power-on.
    housing_c : numpy.ndarray
        True housing temperature [degC], the driver of the bias.
    measured_c : numpy.ndarray
        The sensor's reading [degC], written as ``temperature``.
    source : str
        ``"settings"`` or the recording's name.
    """

    time_s: np.ndarray
    housing_c: np.ndarray
    measured_c: np.ndarray
    source: str = "settings"

    def on_grid(self, time_s: np.ndarray) -> "Profile":
        """The same profile interpolated linearly onto `time_s` (held at its ends)."""
        return Profile(
            time_s=time_s,
            housing_c=np.interp(time_s, self.time_s, self.housing_c),
            measured_c=np.interp(time_s, self.time_s, self.measured_c),
            source=self.source,
        )


def profile_duration_s(settings: ProfileSettings) -> float:
    """Length of the profile [s]: start hold, every ramp and every soak."""
    return float(settings.breakpoints()[0][-1])


def setpoint(settings: ProfileSettings, time_s) -> np.ndarray:
    """Oven set-point [degC] at `time_s` [s]; the last level holds after the end."""
    times, temps = settings.breakpoints()
    return np.interp(np.asarray(time_s, dtype=float), times, temps)


def temperature_profile(settings: ProfileSettings, time_s, rng: np.random.Generator) -> Profile:
    """Housing and measured temperature of an oven run.

    Parameters
    ----------
    settings : ProfileSettings
    time_s : array_like, shape (n,)
        Uniform time grid [s] from power-on.
    rng : numpy.random.Generator
        Draws the sensor noise.

    Returns
    -------
    Profile
        ``housing_c`` is the set-point through the first-order chamber
        response (:func:`~gyrocomp.effects.shapes.element_temperature` with
        `chamber_tau_s`); ``measured_c`` is :func:`measure` of it.
    """
    time_s = np.asarray(time_s, dtype=float)
    housing = element_temperature(time_s, setpoint(settings, time_s), settings.chamber_tau_s)
    measured = measure(housing, settings.sensor_noise_c, settings.sensor_resolution_c, rng)
    return Profile(time_s=time_s, housing_c=housing, measured_c=measured)


def measure(temperature_c, noise_c, resolution_c, rng: np.random.Generator) -> np.ndarray:
    """A temperature sensor's reading: white noise of `noise_c` [degC], rounded to `resolution_c` [degC] (0: none)."""
    reading = np.asarray(temperature_c, dtype=float) + noise_c * rng.standard_normal(np.shape(temperature_c))
    if resolution_c > 0:
        reading = np.round(reading / resolution_c) * resolution_c
    return reading


def profile_from_recording(recording) -> Profile:
    """Drive the simulator by the measured temperature of a recording.

    The recorded temperature is the reading (it is already noisy and
    quantised). The housing temperature, which the effects differentiate
    (``temp_rate``) and lag (``thermal_lag``), is the reading smoothed by a
    local straight line over the temperature-rate estimator's window
    (``[rate] window_s``, :mod:`gyrocomp.pipeline.rate`): a staircase of
    1/16 degC steps differentiated raw puts spikes of ``g * step * fs`` into
    the rate, which read as extra white noise (ARW 1.11-1.29 deg/sqrt(h)
    against 1.0 configured on the sample data). Both on the recording's own
    time axis shifted to start at 0.

    Parameters
    ----------
    recording : gyrocomp.recordings.Recording
        Must have a ``temperature`` column.

    Raises
    ------
    InputError
        The recording has no temperature.
    """
    temperature = recording.temperature_c
    if temperature is None:
        raise InputError(f"{recording.name}: no `temperature` column to drive the simulator (map it with --temp-col)")
    from scipy.signal import savgol_filter

    from gyrocomp.pipeline.rate import window_samples
    from gyrocomp.pipeline.settings import RateSettings

    time_s = recording.time_s - recording.time_s[0]
    settings = RateSettings()
    n = window_samples(settings, recording.fs_hz, temperature.size)
    housing = savgol_filter(temperature, n, min(settings.polyorder, n - 1), mode="interp") if n >= 3 else temperature.copy()
    return Profile(time_s=time_s, housing_c=housing, measured_c=temperature.copy(), source=recording.name)
