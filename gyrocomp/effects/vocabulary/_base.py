"""The interface every effect of the vocabulary implements (:data:`gyrocomp.effects.vocabulary.KINDS`)."""

from __future__ import annotations

import abc

import numpy as np

__all__ = ["Effect", "Columns", "HOUR_S"]

HOUR_S = 3600.0


class Columns(tuple):
    """Design-column names that also hold their numbered repeats: ``"periodic_sin_3"`` is in ``Columns(("periodic_sin",))``.

    A periodic waveform's ``k``-th harmonic repeats its fundamental's
    columns with the suffix ``_k``; they are per-run columns like the
    fundamental's.

    >>> "periodic_cos_2" in Columns(("periodic_sin", "periodic_cos")), "periodic_cos_x" in Columns(("periodic_cos",))
    (True, False)
    """

    def __contains__(self, name):
        if tuple.__contains__(self, name):
            return True
        base, _, k = str(name).rpartition("_")
        return k.isdigit() and tuple.__contains__(self, base)


class Effect(abc.ABC):
    """One effect of the vocabulary: its simulator table, its regressors and its report.

    Class attributes
    ----------------
    name : str
        The vocabulary name (DESIGN.md).
    settings : type
        Frozen dataclass of the ``[gyro.<name>]`` table; every numeric field
        carries its unit (:func:`gyrocomp.sim.profile.unit_field`).
    stochastic : bool
        A noise term (a covariance term of the likelihood), not a regressor.
    needs_temperature : bool
    nonlinear : str or None
        The parameter searched on a grid (``tau_s``, ``deadband_c``,
        ``period_s``); the others enter linearly.
    grid_setting : str or None
        The ``[diagnose]`` setting (:class:`gyrocomp.diagnose.DiagnoseSettings`)
        holding that grid.
    n_params : int
        Free parameters on one run (a grid-searched one counts as one); of
        the plainest form when the effect has :attr:`forms` (a sinusoid for
        ``periodic``; :meth:`n_params_of` for a fitted one).
    per_run : Columns
        Design columns re-estimated on every run (an interference phase, a
        hysteresis' state at power-on).
    amplitude_per_run : bool
        Whether the per-run columns carry the effect's amplitude itself (an
        interference, whose amplitude and phase are the run's), rather than
        a nuisance beside an amplitude shared by the runs (a hysteresis'
        state at power-on).
    unit_columns : int or None
        How many leading columns make the unit shape of the reported
        amplitude (:meth:`amplitude`; detection limits); None: all of them,
        averaged (a sinusoid's phases).
    forms : tuple of dict
        The effect's forms, plainest first, as ``params`` of :meth:`columns`
        beside the nonlinear parameter (``temp_rate``: one sensitivity, or
        heating and cooling apart; ``hysteresis``: a relay or a play). The
        diagnosis fits each (its nonlinear parameter too) and keeps the one
        of lowest BIC (:meth:`n_params_of` counts its parameters): a
        richer form's extra columns must earn their place like an effect.
        A form may carry a second nonlinear parameter (:meth:`paired`).
    """

    name: str = ""
    settings: type = object
    stochastic: bool = False
    needs_temperature: bool = False
    nonlinear: str | None = None
    grid_setting: str | None = None
    n_params: int = 1
    per_run: Columns = Columns()
    amplitude_per_run: bool = False
    unit_columns: int | None = None
    forms: tuple = ()

    def __repr__(self):
        return f"<effect {self.name}>"

    def n_per_run(self, params=None) -> int:
        """Design columns re-estimated on every run at `params`."""
        return len(self.per_run)

    def n_params_runs(self, n_runs: int, params=None) -> int:
        """Free parameters when fitted on `n_runs` runs together: the per-run columns count once per run.

        >>> from gyrocomp.effects.vocabulary import KINDS
        >>> KINDS["periodic"].n_params_runs(2), KINDS["warmup"].n_params_runs(2), KINDS["periodic"].n_params_runs(2, {"harmonics": 3})
        (5, 2, 13)
        """
        return self.n_params_of(params or {}) + self.n_per_run(params) * (n_runs - 1)

    def n_params_of(self, params: dict) -> int:
        """Free parameters on one run of the form `params` (:attr:`forms`); :attr:`n_params` without forms."""
        return self.n_params

    def paired(self, form: dict, settings, length_s: float):
        """``(key, min_ratio, max_value)`` when `form` has a second nonlinear parameter ``key`` on the same grid, whose
        column is the plain form's at that value (``warmup``'s second time constant), at least `min_ratio` times the
        first and at most `max_value` on a run `length_s` long (`settings`: the ``[diagnose]`` table); None (the
        default) when it has not. The paired columns are shared by the runs."""
        return None

    def bias(self, time_s, housing_c, gyro) -> np.ndarray:
        """The simulated bias contribution [deg/s] of a deterministic effect.

        Parameters
        ----------
        time_s : ndarray, shape (n,)
        housing_c : ndarray, shape (n,)
            The true (noise-free) housing temperature [degC].
        gyro : gyrocomp.sim.model.GyroSettings
            The whole gyro (``thermal_lag`` needs its polynomial); this
            effect's table is ``getattr(gyro, self.name)``.
        """
        raise TypeError(f"{self.name} is a noise term: it has no deterministic bias")

    def noise(self, n, fs_hz, table, rng) -> np.ndarray:
        """``n`` samples [deg/s] of a noise term at `fs_hz` from its table and generator."""
        raise TypeError(f"{self.name} is deterministic: it draws no noise")

    def columns(self, run, params: dict, poly_degree: int = 3, scale=None):
        """Full-rate design columns of a deterministic effect.

        Parameters
        ----------
        run : gyrocomp.diagnose.effects.Run
        params : dict
            ``{nonlinear parameter: value}`` (empty without one).
        poly_degree, scale
            The baseline polynomial (``thermal_lag`` re-evaluates it at the
            element temperature).

        Returns
        -------
        X : ndarray, shape (n, p)
        names : list of str
        """
        raise TypeError(f"{self.name} is a noise term: it has no design columns")

    def grid(self, settings, length_s: float, block_s: float) -> np.ndarray:
        """The grid of the nonlinear parameter for a run `length_s` long in blocks of `block_s`."""
        lo, hi = getattr(settings, self.grid_setting)
        return np.geomspace(lo, hi, settings.tau_grid_points)

    @abc.abstractmethod
    def report(self, coef: dict, params: dict, noise) -> dict:
        """Fitted parameters ``{name: {"value", "unit"}}`` in the simulator's names.

        Parameters
        ----------
        coef : dict
            Fitted design coefficients by column name.
        params : dict
            The fitted nonlinear parameter.
        noise : gyrocomp.effects.likelihood.NoiseModel
        """

    def amplitude(self, value: float) -> dict:
        """A unit-column coefficient `value` as the reported amplitude (detection limits)."""
        return {"amplitude_dps": {"value": value, "unit": "deg/s"}}
