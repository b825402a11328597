"""``periodic``: a bias interference of fixed period and any waveform, unrelated to temperature.

The simulator draws a sinusoid; the diagnosis fits a Fourier series in the
fundamental ``f = 1 / P``,

.. math:: b(t) = \\sum_{k=1}^{H} a_k \\sin(2 \\pi k f t) + b_k \\cos(2 \\pi k f t),

of which the sinusoid is the one-harmonic case (``H = 1``). A square wave,
a sawtooth or a pulse train of a low duty cycle spreads its power over many
harmonics (a pulse train of duty ``d`` carries ``2 sin^2(pi k d) / (pi^2 k^2
d (1 - d))`` of its variance in harmonic ``k``: 13 % in the fundamental at
``d = 0.06``). The period and ``H`` are chosen by the selection's one
criterion on the multiharmonic periodogram (Schwarzenberg-Czerny 1996,
:func:`gyrocomp.diagnose.nonlinear._periodic_grid_deviances`); each harmonic's
sine and cosine are two more parameters, re-estimated on every run with the
fundamental's (an interference phase is not a property of the gyro).

References
----------
.. [1] A. Schwarzenberg-Czerny, "Fast and statistically optimal period search
   in uneven sampled observations", ApJ 460, L107-L110 (1996).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gyrocomp.effects.vocabulary._base import Columns, Effect
from gyrocomp.effects import shapes
from gyrocomp.effects._fields import unit_field


@dataclasses.dataclass(frozen=True)
class Periodic:
    """``periodic``: sinusoidal interference of fixed period."""

    enabled: bool = False
    amplitude_dps: float = unit_field(0.005, "deg/s")
    period_s: float = unit_field(1800.0, "s")
    phase_rad: float = unit_field(0.0, "rad")


def harmonic_names(harmonics: int) -> list:
    """Column names of a Fourier series of `harmonics` harmonics: ``periodic_sin``, ``periodic_cos``, ``periodic_sin_2``, ...

    >>> harmonic_names(2)
    ['periodic_sin', 'periodic_cos', 'periodic_sin_2', 'periodic_cos_2']
    """
    out = []
    for k in range(1, int(harmonics) + 1):
        suffix = "" if k == 1 else f"_{k}"
        out += [f"periodic_sin{suffix}", f"periodic_cos{suffix}"]
    return out


class _Periodic(Effect):
    """Columns: ``sin`` and ``cos(2 pi k t / P)``, ``k = 1..H``; every coefficient re-estimated on every run."""

    name = "periodic"
    settings = Periodic
    nonlinear = "period_s"
    grid_setting = None  # periodic_min_blocks and periodic_oversample: see grid()
    n_params = 3
    per_run = Columns(("periodic_sin", "periodic_cos"))
    amplitude_per_run = True
    unit_columns = 2  # detection limits are the fundamental sinusoid's (its phases averaged), as the simulator draws it

    def n_params_of(self, params=None):
        """The period and two coefficients per harmonic: ``1 + 2 H``."""
        return 1 + self.n_per_run(params)

    def n_per_run(self, params=None):
        """A sine and a cosine per harmonic: ``2 H``."""
        return 2 * int((params or {}).get("harmonics", 1))

    def bias(self, time_s, housing_c, gyro):
        p = gyro.periodic
        return shapes.periodic(time_s, p.amplitude_dps, p.period_s, p.phase_rad)

    def columns(self, run, params, poly_degree=3, scale=None):
        harmonics = int(params.get("harmonics", 1))
        cols = []
        for k in range(1, harmonics + 1):
            period = params["period_s"] / k
            cols += [shapes.periodic(run.time_s, 1.0, period, 0.0), shapes.periodic(run.time_s, 1.0, period, 0.5 * np.pi)]
        return np.column_stack(cols), harmonic_names(harmonics)

    def grid(self, settings, length_s, block_s):
        """Periods from half the run down to ``periodic_min_blocks`` blocks, frequency step ``1 / (periodic_oversample L)``."""
        f_lo = 2.0 / length_s
        f_hi = 1.0 / (settings.periodic_min_blocks * block_s)
        return 1.0 / np.arange(f_lo, f_hi, 1.0 / (settings.periodic_oversample * length_s))

    def max_harmonics(self, settings, period_s, length_s, block_s) -> int:
        """Most harmonics a period may carry: up to ``periodic_harmonics``, none shorter than
        ``periodic_harmonic_min_blocks`` blocks, and only one when the run holds fewer than
        ``periodic_harmonic_min_cycles`` periods (a waveform's shape is told from a slow drift only where it repeats)."""
        if length_s < settings.periodic_harmonic_min_cycles * period_s:
            return 1
        return int(max(1, min(settings.periodic_harmonics, period_s // (settings.periodic_harmonic_min_blocks * block_s))))

    def report(self, coef, params, noise):
        """The fundamental's amplitude and phase, and the fitted waveform's half peak-to-peak and RMS over one period."""
        harmonics = int(params.get("harmonics", 1))
        names = harmonic_names(harmonics)
        a = np.array([coef[n] for n in names[0::2]])
        b = np.array([coef[n] for n in names[1::2]])
        phase = np.linspace(0.0, 2.0 * np.pi, 512, endpoint=False)
        k = np.arange(1, harmonics + 1)
        wave = np.sin(np.outer(phase, k)) @ a + np.cos(np.outer(phase, k)) @ b
        return {
            "amplitude_dps": {"value": float(np.hypot(a[0], b[0])), "unit": "deg/s"},
            "period_s": {"value": params["period_s"], "unit": "s"},
            "phase_rad": {"value": float(np.arctan2(b[0], a[0])), "unit": "rad (fit run)"},
            "harmonics": {"value": harmonics, "unit": "1"},
            "half_peak_to_peak_dps": {"value": float(0.5 * np.ptp(wave)), "unit": "deg/s"},
            "rms_dps": {"value": float(np.sqrt(0.5 * np.sum(a * a + b * b))), "unit": "deg/s"},
        }


EFFECT = _Periodic()
