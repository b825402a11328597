"""Settings of the simulator, bound from TOML into frozen dataclasses.

A simulation config has up to four tables: ``[run]`` (:class:`RunSettings`),
``[gyro]`` (:class:`GyroSettings`, one sub-table per effect of the
vocabulary), ``[profile]`` (:class:`~gyrocomp.sim.profile.ProfileSettings`)
and ``[reference]`` (:class:`ReferenceSettings`). ``run.gyro`` and
``run.profile`` name a base file in ``configs/gyro/`` and
``configs/profiles/`` whose table the config's own table updates key by
key. The defaults below equal ``configs/gyro/default.toml`` and
``configs/profiles/oven-paper.toml`` (a test checks it).

Every numeric field carries its unit in ``dataclasses.field(metadata=...)``;
:func:`units_of` reads them for the truth record.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from gyrocomp.config import CONFIG_DIR, apply_overrides, bind, check_seed, load_config
from gyrocomp.errors import InputError
from gyrocomp.effects._fields import check_numbers, unit_field
from gyrocomp.sim.profile import ProfileSettings
from gyrocomp.effects.vocabulary import EFFECTS, KINDS
from gyrocomp.effects.vocabulary.bias_instability import BiasInstability
from gyrocomp.effects.vocabulary.hysteresis import Hysteresis
from gyrocomp.effects.vocabulary.periodic import Periodic
from gyrocomp.effects.vocabulary.rate_ramp import RateRamp
from gyrocomp.effects.vocabulary.rate_random_walk import RateRandomWalk
from gyrocomp.effects.vocabulary.temp_rate import TempRate
from gyrocomp.effects.vocabulary.thermal_lag import ThermalLag
from gyrocomp.effects.vocabulary.warmup import Warmup

__all__ = [
    "EFFECTS",
    "ThermalLag",
    "TempRate",
    "Hysteresis",
    "Warmup",
    "RateRamp",
    "Periodic",
    "BiasInstability",
    "RateRandomWalk",
    "GyroSettings",
    "ReferenceSettings",
    "RunSettings",
    "SimConfig",
    "load_sim_config",
    "resolve_config_path",
    "units_of",
]

@dataclasses.dataclass(frozen=True)
class _Baseline:
    """One gyro: the baseline error model and the effects beyond it.

    The baseline (both papers' model) is
    ``rate = offset + sum_k c_k (T - T_ref)^k + white noise(ARW)``;
    each effect table adds one term of the vocabulary. Scale factor
    ``(1 + s_0 + s_1 (T - T_ref))`` multiplies an optional reference rate,
    and the output is quantised to `resolution_dps`. :class:`GyroSettings`
    adds one table per effect of :data:`gyrocomp.effects.vocabulary.KINDS`.
    """

    name: str = "dual-mass-default"
    offset_dps: float = unit_field(0.12, "deg/s")
    reference_c: float = unit_field(25.0, "degC")
    temperature_coefficients: tuple = unit_field((1.5e-3, 2.0e-5, 8.0e-7), "deg/s/degC^k, k = 1, 2, 3")
    arw: float = unit_field(1.0, "deg/sqrt(h)")
    resolution_dps: float = unit_field(1e-4, "deg/s")
    scale_factor_ppm: float = unit_field(0.0, "ppm")
    scale_factor_ppm_per_c: float = unit_field(100.0, "ppm/degC")

    def __post_init__(self):
        if len(self.temperature_coefficients) > 3:
            raise InputError(
                f"gyro.temperature_coefficients: {len(self.temperature_coefficients)} given, at most 3 (cubic)"
            )
        for name, value in (("arw", self.arw), ("resolution_dps", self.resolution_dps)):
            if not value >= 0:
                raise InputError(f"gyro.{name} = {value!r} must be >= 0")

        check_numbers(self, "gyro")
        for name in KINDS:
            check_numbers(getattr(self, name), f"gyro.{name}")

    def active_effects(self) -> list[str]:
        """Names of the enabled effects, in vocabulary order."""
        return [name for name in EFFECTS if getattr(self, name).enabled]


GyroSettings = dataclasses.make_dataclass(
    "GyroSettings",
    [(name, effect.settings, dataclasses.field(default=effect.settings())) for name, effect in KINDS.items()],
    bases=(_Baseline,),
    frozen=True,
    namespace={"__doc__": _Baseline.__doc__, "__module__": __name__},
)


@dataclasses.dataclass(frozen=True)
class ReferenceSettings:
    """A reference angular rate (turntable) the gyro measures, written as ``reference_rate``.

    ``kind = "none"`` (static), ``"steps"`` (the `levels_dps` in turn, each
    for `step_s`, cycling) or ``"sine"`` (`amplitude_dps` at `period_s`).
    """

    kind: str = "none"
    levels_dps: tuple = unit_field((0.0, 10.0, 0.0, -10.0), "deg/s")
    step_s: float = unit_field(600.0, "s")
    amplitude_dps: float = unit_field(10.0, "deg/s")
    period_s: float = unit_field(60.0, "s")

    def __post_init__(self):
        check_numbers(self, "reference")
        if self.kind not in ("none", "steps", "sine"):
            raise InputError(f"reference.kind = {self.kind!r}; choose none, steps or sine")
        if self.kind == "steps" and (not self.levels_dps or not self.step_s > 0):
            raise InputError("reference: steps need levels_dps and step_s > 0")
        if self.kind == "sine" and not self.period_s > 0:
            raise InputError(f"reference.period_s = {self.period_s!r} must be > 0")


@dataclasses.dataclass(frozen=True)
class RunSettings:
    """How to run: sample rate, length, seed and the base gyro and profile files."""

    fs_hz: float = unit_field(1.0, "Hz")
    duration_s: float = unit_field(0.0, "s")
    seed: int = 0
    gyro: str = "default"
    profile: str = "oven-paper"
    truth_columns: bool = False

    def __post_init__(self):
        from gyrocomp.recordings import TimeLimits

        limits = TimeLimits()
        if not limits.min_fs_hz <= self.fs_hz <= limits.max_fs_hz:
            raise InputError(
                f"run.fs_hz (--fs) = {self.fs_hz!r} must be in [{limits.min_fs_hz:g}, {limits.max_fs_hz:g}] Hz, "
                "the sample rates the recording reader accepts (configs/recordings.toml [time])"
            )
        check_seed(self.seed, "run.seed")
        if not self.duration_s >= 0:
            raise InputError(f"run.duration_s = {self.duration_s!r} must be >= 0 (0: the profile's length)")


@dataclasses.dataclass(frozen=True)
class SimConfig:
    """A resolved simulation config (what ``gyrocomp simulate`` runs)."""

    run: RunSettings
    gyro: GyroSettings
    profile: ProfileSettings
    reference: ReferenceSettings


def resolve_config_path(name: str | Path, kind: str) -> Path:
    """A config path as given, else ``configs/<kind>/<name>.toml``, else ``configs/<name>.toml``."""
    path = Path(name)
    if path.is_file():  # a folder or device of that name does not shadow a shipped config
        return path
    for candidate in (CONFIG_DIR / kind / f"{path.name}.toml", CONFIG_DIR / f"{name}.toml", CONFIG_DIR / kind / path.name):
        if candidate.exists():
            return candidate
    raise InputError(f"{name}: no such {kind} config (looked in the working folder and {CONFIG_DIR / kind})")


def load_sim_config(config=None, *, profile=None, overrides=(), seed=None, fs_hz=None, truth_columns=None) -> SimConfig:
    """Read, merge, override and bind a simulation config.

    Parameters
    ----------
    config : path-like or None
        A TOML with ``[run]``, ``[gyro]``, ``[profile]``, ``[reference]``;
        ``None`` runs the defaults (the papers' oven test on the default gyro).
    profile : path-like or None
        A profile TOML (path or name in ``configs/profiles/``) whose
        ``[profile]`` table replaces the config's.
    overrides : sequence of str
        ``table.key=value`` assignments applied last (``--set``).
    seed, fs_hz, truth_columns : optional
        Explicit options; they beat the config.

    Raises
    ------
    InputError
        Unknown table or key (named with its file), a bad value, a missing file.
    """
    source = str(config) if config is not None else "defaults"
    table = load_config(resolve_config_path(config, "sample")) if config is not None else {}
    table = apply_overrides(table, overrides)
    _check_tables(table, source)
    run_table = dict(table.get("run", {}))
    for key, value in (("seed", seed), ("fs_hz", fs_hz), ("truth_columns", truth_columns)):
        if value is not None:
            run_table[key] = value
    run = bind(RunSettings, run_table, f"{source} [run]")
    gyro_base_path = resolve_config_path(run.gyro, "gyro")
    gyro_table = _merge(_table_of(gyro_base_path, "gyro"), table.get("gyro", {}))
    if profile is not None:
        profile_path = resolve_config_path(profile, "profiles")
        profile_table = _table_of(profile_path, "profile")
        profile_table = _merge(profile_table, _overrides_of(overrides, "profile"))
        profile_source = str(profile_path)
    else:
        profile_path = resolve_config_path(run.profile, "profiles")
        profile_table = _merge(_table_of(profile_path, "profile"), table.get("profile", {}))
        profile_source = f"{source} (base {profile_path.name})"
    return SimConfig(
        run=run,
        gyro=bind(GyroSettings, gyro_table, f"{source} (base {gyro_base_path.name}) [gyro]"),
        profile=bind(ProfileSettings, profile_table, f"{profile_source} [profile]"),
        reference=bind(ReferenceSettings, table.get("reference", {}), f"{source} [reference]"),
    )


def units_of(settings) -> dict:
    """The unit of every numeric field of a settings dataclass, nested tables included."""
    out = {}
    for f in dataclasses.fields(settings):
        value = getattr(settings, f.name)
        if dataclasses.is_dataclass(value):
            out[f.name] = units_of(value)
        elif "unit" in f.metadata:
            out[f.name] = f.metadata["unit"]
    return out


_TABLES = ("run", "gyro", "profile", "reference")


def _check_tables(table, source):
    unknown = sorted(set(table) - set(_TABLES))
    if unknown:
        raise InputError(f"{source}: unknown table or key {', '.join(unknown)}; known: {', '.join(_TABLES)}")
    for name in _TABLES:
        if name in table and not isinstance(table[name], dict):
            raise InputError(f"{source}: `{name}` should be a table")


def _table_of(path, name):
    table = load_config(path)
    unknown = sorted(set(table) - {name})
    if unknown:
        raise InputError(f"{path}: unknown table or key {', '.join(unknown)}; a {name} file holds only [{name}]")
    return table.get(name, {})


def _overrides_of(overrides, name):
    return apply_overrides({}, overrides).get(name, {})


def _merge(base, update):
    out = dict(base)
    for key, value in update.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merge(out[key], value)
        else:
            out[key] = value
    return out
