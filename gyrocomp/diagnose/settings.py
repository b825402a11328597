"""The settings of the diagnosis: one tree, every key once, read from ``configs/diagnose.toml``.

:class:`DiagnoseSettings` is the ``[diagnose]`` table: the baseline, the
likelihood's blocks, the selection, the gap and the localization. Its
sections are the tables under it:

* ``[diagnose.checks]`` (:class:`ChecksSettings`): the parameters of the
  residual checks (:mod:`gyrocomp.diagnose.checks`), which the verdict and a
  noise term's signature both run;
* ``[diagnose.signature]`` (:class:`SignatureSettings`): the false-refusal
  rate of a true noise term (:func:`gyrocomp.diagnose.signature.check`);
* ``[diagnose.unexplained]`` (:class:`UnexplainedSettings`): the family
  false-alarm rate of the verdict (:func:`gyrocomp.diagnose.unexplained.verdict`);
* ``[diagnose.confirm]`` (:class:`ConfirmSettings`): the unlisting rules'
  own numbers (:mod:`gyrocomp.diagnose.confirm`);
* ``[diagnose.competing]`` (:class:`CompetingSettings`): the events a
  listed noise term is compared with (:mod:`gyrocomp.diagnose.competing`).

Every default equals the shipped TOML, where each number has its reason
(``tests/diagnose/test_config.py`` checks both, and that no key appears
twice in the tree). A config of the layout before the tree (top-level
``[signature]`` and ``[unexplained]`` tables, ``configs/unexplained.toml``)
is refused with one line naming where its first moved key went
(:data:`MOVED`).
"""

from __future__ import annotations

import dataclasses

from gyrocomp.config import bind, check_tables, load_config
from gyrocomp.errors import InputError

__all__ = ["DiagnoseSettings", "ChecksSettings", "SignatureSettings", "UnexplainedSettings", "ConfirmSettings", "CompetingSettings", "MOVED", "get_config"]


@dataclasses.dataclass(frozen=True)
class ChecksSettings:
    """The ``[diagnose.checks]`` table: what every residual check reads as ``frame.settings``."""

    temperature_bins: int = 8
    temperature_scan_bins: tuple = (8, 16, 32, 64)
    temperature_step_bins: int = 64
    min_step_blocks: int = 4
    soak_rate_c_per_min: float = 0.05
    poweron_edges_s: tuple = (300.0, 900.0, 2700.0, 7200.0)
    time_segments: int = 8
    line_min_cycles: int = 3
    line_segments: int = 4
    noise_segments: int = 8
    noise_min_ratio: float = 1.25
    ljung_box_lags: int = 10
    agreement_max_blocks: int = 240
    profile_span: tuple = (-10.0, 6.0)
    profile_points: int = 33
    explains_share: float = 0.5
    min_allan_windows: int = 4
    time_bins: int = 16
    stationarity_segments: int = 4
    min_segment_increments: int = 4
    two_level_draws: int = 100
    two_level_iterations: int = 40
    two_level_seed: int = 0
    spectrum_parts: tuple = (2, 4, 8)


@dataclasses.dataclass(frozen=True)
class SignatureSettings:
    """The ``[diagnose.signature]`` table."""

    refusal_alpha: float = 0.01


@dataclasses.dataclass(frozen=True)
class UnexplainedSettings:
    """The ``[diagnose.unexplained]`` table."""

    family_alpha: float = 0.01


@dataclasses.dataclass(frozen=True)
class ConfirmSettings:
    """The ``[diagnose.confirm]`` table."""

    replication_alpha: float = 0.01
    steady_segments: int = 4
    steady_min_cycles: float = 1.0


@dataclasses.dataclass(frozen=True)
class CompetingSettings:
    """The ``[diagnose.competing]`` table."""

    bump_widths: int = 10

    def __post_init__(self):
        if self.bump_widths < 1:
            raise InputError(f"diagnose.competing.bump_widths = {self.bump_widths!r} must be at least 1")


@dataclasses.dataclass(frozen=True)
class DiagnoseSettings:
    """The ``[diagnose]`` table and its sections; defaults equal ``configs/diagnose.toml`` (reasons there)."""

    poly_degree: int = 3
    block_s: float = 10.0
    max_blocks: int = 720
    max_rate_hz: float = 1.0
    bic_margin: float = 10.0
    detection_power: float = 0.95
    max_effects: int = 8
    min_temperature_span_c: float = 2.0
    identifiable_min_unique: float = 0.01
    temp_rate_smooth_s: float = 60.0
    thermal_lag_tau_s: tuple = (2.0, 28800.0)
    warmup_tau_s: tuple = (60.0, 14400.0)
    warmup_min_ratio: float = 2.0
    warmup_min_decays: float = 2.0
    rate_ramp_power: tuple = (0.25, 4.0)
    tau_grid_points: int = 24
    bias_correlation_s: tuple = (20.0, 7200.0)
    bias_correlation_points: int = 9
    bias_correlation_max_fraction: float = 4.0
    bias_correlation_search_blocks: int = 240
    hysteresis_deadband_c: tuple = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0)
    periodic_min_blocks: float = 4.0
    periodic_oversample: float = 3.0
    periodic_harmonics: int = 8
    periodic_harmonic_min_cycles: float = 4.0
    periodic_harmonic_min_blocks: float = 2.0
    gap_block_s: float = 100.0
    gap_min_windows: int = 16
    smooth_s: float = 100.0
    warmup_window_s: float = 1800.0
    temperature_bin_c: float = 20.0
    emd_max_imfs: int = 8
    emd_max_sift: int = 50
    checks: ChecksSettings = ChecksSettings()
    signature: SignatureSettings = SignatureSettings()
    unexplained: UnexplainedSettings = UnexplainedSettings()
    confirm: ConfirmSettings = ConfirmSettings()
    competing: CompetingSettings = CompetingSettings()

    def __post_init__(self):
        for name in ("block_s", "max_rate_hz", "bias_correlation_max_fraction", "gap_block_s", "smooth_s", "periodic_oversample", "periodic_min_blocks",
                     "periodic_harmonic_min_cycles", "periodic_harmonic_min_blocks", "temperature_bin_c", "warmup_min_decays"):
            if not getattr(self, name) > 0:
                raise InputError(f"diagnose.{name} = {getattr(self, name)!r} must be > 0")
        if not self.warmup_min_ratio > 1.0:
            raise InputError(f"diagnose.warmup_min_ratio = {self.warmup_min_ratio!r} must be > 1 (the second warm-up is the slower)")
        if not 0 <= self.poly_degree <= 3:
            raise InputError(f"diagnose.poly_degree = {self.poly_degree!r}: the baseline is at most cubic (0..3)")
        if not 0.0 < self.detection_power < 1.0:
            raise InputError(f"diagnose.detection_power = {self.detection_power!r} must be between 0 and 1")
        for name, least, why in (("tau_grid_points", 2, " (a grid from lo to hi)"), ("bias_correlation_points", 2, " (a grid from lo to hi)"),
                                 ("periodic_harmonics", 1, " (the sinusoid)"), ("bias_correlation_search_blocks", 16, ""), ("max_blocks", 16, "")):
            if getattr(self, name) < least:
                raise InputError(f"diagnose.{name} = {getattr(self, name)!r} must be at least {least}{why}")
        for name in _SECTIONS:
            if not isinstance(getattr(self, name), _SECTIONS[name]):
                raise InputError(f"diagnose.{name} = {getattr(self, name)!r} must be a table ([diagnose.{name}])")


_SECTIONS = {"checks": ChecksSettings, "signature": SignatureSettings, "unexplained": UnexplainedSettings, "confirm": ConfirmSettings,
             "competing": CompetingSettings}

MOVED = {
    **{f"unexplained.{k}": f"diagnose.checks.{k}" for k in (
        "temperature_bins", "temperature_scan_bins", "poweron_edges_s", "min_step_blocks", "temperature_step_bins",
        "noise_segments", "noise_min_ratio", "soak_rate_c_per_min", "time_segments", "line_min_cycles", "line_segments")},
    **{f"signature.{k}": f"diagnose.checks.{k}" for k in (
        "ljung_box_lags", "profile_span", "profile_points", "explains_share", "min_allan_windows", "temperature_bins", "time_bins",
        "min_step_blocks", "temperature_step_bins", "stationarity_segments", "min_segment_increments", "two_level_draws",
        "two_level_iterations", "two_level_seed", "spectrum_parts")},
    **{f"unexplained.{k}": f"diagnose.confirm.{k}" for k in ("replication_alpha", "steady_segments", "steady_min_cycles")},
    "unexplained.family_alpha": "diagnose.unexplained.family_alpha",
    "unexplained.whiteness_lags": "diagnose.checks.ljung_box_lags",
    "unexplained.gap_block_s": "diagnose.gap_block_s",
    "signature.family_alpha": "diagnose.signature.refusal_alpha",
    "signature.max_blocks": "diagnose.checks.agreement_max_blocks",
    "diagnose.soak_rate_c_per_min": "diagnose.checks.soak_rate_c_per_min",
}
"""Keys of the layout before the one tree (``configs/unexplained.toml``'s tables, ``[diagnose]``), by their new place."""


def get_config(path="diagnose") -> DiagnoseSettings:
    """Bind the ``[diagnose]`` table and its sections of a TOML file (default: the shipped ``configs/diagnose.toml``).

    Raises
    ------
    InputError
        A key of the earlier layout (:data:`MOVED`), naming where it went; an
        unknown table or key.
    """
    config = load_config(path)
    flat = [f"{table}.{key}" for table in ("diagnose", "unexplained", "signature") for key in config.get(table, {})]
    moved = [key for key in flat if key in MOVED]
    if moved:
        raise InputError(f"{path}: `{moved[0]}` moved to `{MOVED[moved[0]]}`" + (f" (and {len(moved) - 1} more keys: see configs/diagnose.toml)" if len(moved) > 1 else ""))
    table = check_tables(config, ("diagnose",), str(path)).get("diagnose", {})
    return bind(DiagnoseSettings, table, f"{path} [diagnose]")
