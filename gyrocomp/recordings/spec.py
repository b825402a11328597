"""Columns, units and limits of a recording: what a reader is told, and the bounds it checks against.

:class:`ColumnSpec` says which columns of a file are which and in what unit;
:class:`TimeLimits`, :class:`AxisLimits`, :class:`TemperatureLimits` and
:class:`LengthLimits` are the bounds of ``configs/recordings.toml``, with
the checks that use the last two (:func:`check_training_range`,
:func:`check_length`).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Sequence

from gyrocomp.errors import InputError

STANDARD_GRAVITY = 9.80665
"""m/s^2 per g (CGPM 1901, the value of g_n in the SI brochure)."""


RATE_UNITS = {"deg/s": 1.0, "deg/h": 1.0 / 3600.0, "rad/s": 180.0 / math.pi}
"""Factors that convert an angular-rate unit to deg/s."""


ACCELERATION_UNITS = {"m/s^2": 1.0, "m/s2": 1.0, "g": STANDARD_GRAVITY}
"""Factors that convert an acceleration unit to m/s^2."""


TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "datetime": None}
"""Factors that convert a numeric time unit to seconds; ``datetime`` is parsed by pandas."""


TEMPERATURE_UNITS = ("degC", "K")


_SEPARATOR_WORDS = {"\\t": "\t", "tab": "\t", "\\s+": "\\s+"}
"""Separators spelled out as words or escapes on a command line."""


PLAUSIBLE_DEGC = (-100.0, 200.0)
"""Temperatures outside this range are refused as a probable unit mistake."""


def _entries(value: str | Sequence[str]) -> tuple[str, ...]:
    """The comma-separated entries of an option (or the items of a sequence), stripped."""
    items = value.split(",") if isinstance(value, str) else list(value)
    return tuple(s.strip() for s in items if s.strip())


@dataclasses.dataclass(frozen=True)
class TimeLimits:
    """Sample rates and spans a gyro log has (``configs/recordings.toml``, ``[time]``).

    A time column read as seconds without ``--time-unit`` must give a
    sample rate in [`min_fs_hz`, `max_fs_hz`] and a span of at most
    `max_span_days`; otherwise it is refused, naming the unit that would
    fit (a µs ``timestamp`` read as seconds gives 1e-4 Hz at 100 Hz).

    Parameters
    ----------
    min_fs_hz : float, default=0.01
        One sample per 100 s: slower than any rate logger.
    max_fs_hz : float, default=1e5
        Above the fastest MEMS gyro output data rate (32 kHz).
    max_span_days : float, default=30
        Longer than any oven or Allan run (12-72 h).
    typical_fs_hz : float, default=100
        When several units would fit, the one giving the rate nearest to
        this (in decades) is named first.
    """

    min_fs_hz: float = 0.01
    max_fs_hz: float = 1e5
    max_span_days: float = 30.0
    typical_fs_hz: float = 100.0


@dataclasses.dataclass(frozen=True)
class AxisLimits:
    """Largest magnitude a sensor axis can read (``configs/recordings.toml``, ``[axes]``).

    A larger value is a corrupt cell or a unit mistake, refused naming the
    file, the row and the column (a ±1e300 rate overflows every statistic).

    Parameters
    ----------
    max_abs_deg_s : float, default=1e5
        Angular rate [deg/s]: 25x the widest MEMS gyro full scale (±4000 deg/s).
    max_abs_m_s2 : float, default=1e5
        Acceleration [m/s^2], about 10 000 g: 25x the widest IMU accelerometer
        full scale (±400 g).
    """

    max_abs_deg_s: float = 1e5
    max_abs_m_s2: float = 1e5

    def bound(self, unit: str) -> float:
        """The bound of a recording unit (``deg/s`` or ``m/s^2``)."""
        return self.max_abs_deg_s if unit == "deg/s" else self.max_abs_m_s2


@dataclasses.dataclass(frozen=True)
class ColumnSpec:
    """How to find, parse and convert the columns of a recording.

    Parameters
    ----------
    time : str, default="time"
        Name of the time column.
    rate : str, default="rate"
        The sensor axes: one name, comma-separated names (``"gx,gy,gz"``)
        or shell globs (``"gyro_*"``, ``"IMU_0_Gyr?"``), matched in the
        file's column order; the time and temperature columns never match a
        glob. The axes keep these names in every output.
    temperature : str, default="temperature"
        Temperature column(s), same syntax; the first is *the* temperature
        (column ``temperature`` of the recording), any others keep their
        names.
    time_unit : {None, "s", "ms", "us", "ns", "datetime"}, default=None
        Unit of the time column. ``None`` reads numbers as seconds, refused
        when implausible (:class:`TimeLimits`), and ISO 8601 text as
        datetimes; an explicit unit skips the plausibility check.
    rate_unit : str, default="deg/s"
        Unit of the axes: an angular rate (``deg/s``, ``deg/h``, ``rad/s``,
        converted to deg/s) or an acceleration (``m/s^2``, ``g``, converted
        to m/s^2). One unit for every axis, or comma-separated, one per
        entry of `rate` (``"deg/s,g"`` with ``rate="gyro_*,acc_*"``).
    temperature_unit : {"degC", "K"}, default="degC"
        Unit of the temperature column(s).
    sep : str, default=","
        CSV field separator (``";"``, a tab as ``"\\t"`` or ``"tab"``,
        ``"\\s+"`` for runs of blanks, ...).
    decimal : str, default="."
        CSV decimal mark (``","`` for decimal-comma files).
    dedupe : {None, "first", "mean"}, default=None
        Duplicate time stamps: refused (``None``), or merged keeping the
        first row or the mean of the rows.
    """

    time: str = "time"
    rate: str = "rate"
    temperature: str = "temperature"
    time_unit: str | None = None
    rate_unit: str = "deg/s"
    temperature_unit: str = "degC"
    sep: str = ","
    decimal: str = "."
    dedupe: str | None = None

    def __post_init__(self):
        for option, value, choices in (
            ("time unit", self.time_unit, (None, *TIME_UNITS)),
            ("temperature unit", self.temperature_unit, TEMPERATURE_UNITS),
            ("dedupe", self.dedupe, (None, "first", "mean")),
        ):
            if value not in choices:
                raise InputError(f"unknown {option} {value!r}; choose one of {', '.join(c for c in choices if c)}")
        for unit in self.rate_units:
            if unit not in RATE_UNITS and unit not in ACCELERATION_UNITS:
                raise InputError(f"unknown rate unit {unit!r}; choose one of {', '.join([*RATE_UNITS, *ACCELERATION_UNITS])}")
        if len(self.rate_units) not in (1, len(self.rate_patterns)):
            raise InputError(
                f"--rate-unit {self.rate_unit!r}: give one unit, or one per --rate-col entry ({len(self.rate_patterns)})"
            )
        if not self.rate_patterns:
            raise InputError("--rate-col: no column named")
        if len(self.sep) != 1 and self.sep not in _SEPARATOR_WORDS:
            raise InputError(f"--sep {self.sep!r}: give one character, or one of {', '.join(_SEPARATOR_WORDS)}")
        if len(self.decimal) != 1 or self.decimal == self.sep:
            raise InputError(f"--decimal {self.decimal!r}: give one character other than the separator")

    @property
    def rate_patterns(self) -> tuple[str, ...]:
        """The entries of `rate` (names or globs)."""
        return _entries(self.rate)

    @property
    def rate_units(self) -> tuple[str, ...]:
        """The entries of `rate_unit`."""
        return _entries(self.rate_unit)

    @property
    def temperature_patterns(self) -> tuple[str, ...]:
        """The entries of `temperature` (names or globs)."""
        return _entries(self.temperature)


@dataclasses.dataclass(frozen=True)
class Channel:
    """One sensor axis of a recording.

    Parameters
    ----------
    name : str
        The axis' name: its column in the file, kept in every output.
    column : str
        Its column in :attr:`Recording.data`: `name`, or ``rate`` in the
        one-axis recording of :meth:`Recording.axis`.
    quantity : {"angular_rate", "acceleration"}
    unit : {"deg/s", "m/s^2"}
        Unit of the recording's values.
    file_unit : str
        Unit in the file, converted to `unit`.
    """

    name: str
    column: str
    quantity: str
    unit: str
    file_unit: str


@dataclasses.dataclass(frozen=True)
class TemperatureLimits:
    """How fast a gyro's temperature can change (``configs/recordings.toml``, ``[temperature]``).

    Parameters
    ----------
    max_abs_rate_c_per_s : float, default=100
        Largest |dT/dt| [degC/s] of a model's training range: a thermal-shock
        chamber moves about 0.5 degC/s, a hot-air gun on the package some 50.
    """

    max_abs_rate_c_per_s: float = 100.0


@dataclasses.dataclass(frozen=True)
class LengthLimits:
    """Most samples a command makes up rather than reads (``configs/recordings.toml``, ``[lengths]``).

    Each is generous enough for a week at 1 kHz (6.05e8 samples); beyond
    it the request is refused, naming the setting, before memory runs out
    (a 29-day gap resampled at 1 kHz asked for 18.7 GiB).

    Parameters
    ----------
    resample_max_samples : int, default=1_000_000_000
        Samples of a recording interpolated onto a uniform grid (``--resample``).
    simulate_max_samples : int, default=1_000_000_000
        Samples of a simulated recording (duration times sample rate).
    export_max_vectors : int, default=1_000_000_000
        Test vectors of a C header (``export --n-vectors``).
    """

    resample_max_samples: int = 1_000_000_000
    simulate_max_samples: int = 1_000_000_000
    export_max_vectors: int = 1_000_000_000


def check_training_range(model: str, key: str, low: float, high: float) -> None:
    """Refuse a model's training range that no recording gives: it would switch the clamp (and its warning) off.

    `key` is ``temperature_c`` (within :data:`PLAUSIBLE_DEGC`, as a
    recording's temperature is) or ``temperature_rate_c_per_s`` (within
    :class:`TemperatureLimits`).

    Raises
    ------
    InputError
        Naming the model, the range and the bound (exit 2).
    """
    from gyrocomp.config import bind, load_config

    if key == "temperature_c":
        bound, source = PLAUSIBLE_DEGC, "a recording's plausible temperatures"
    else:
        limit = bind(TemperatureLimits, load_config("recordings").get("temperature"), "recordings.toml [temperature]").max_abs_rate_c_per_s
        bound, source = (-limit, limit), "max_abs_rate_c_per_s (configs/recordings.toml [temperature])"
    if low < bound[0] or high > bound[1]:
        raise InputError(f"{model}: training {key} = [{low:.6g}, {high:.6g}] leaves [{bound[0]:g}, {bound[1]:g}], {source}; a corrupted model")


def length_limits() -> LengthLimits:
    """The :class:`LengthLimits` of ``configs/recordings.toml``."""
    from gyrocomp.config import bind, load_config

    return bind(LengthLimits, load_config("recordings").get("lengths"), "recordings.toml [lengths]")


def check_length(setting: str, n: float, what: str) -> None:
    """Refuse making `n` samples where :class:`LengthLimits` field `setting` allows fewer; `what` says what asked for them.

    Raises
    ------
    InputError
        Naming `what`, the count and the setting (exit 2).
    """
    limit = getattr(length_limits(), setting)
    if not n <= limit:
        raise InputError(f"{what} needs {n:.4g} samples, more than {setting} = {limit} (configs/recordings.toml [lengths])")
