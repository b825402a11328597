"""The residual checks of the diagnosis: one test per module, in one registry.

Every check asks one question of a run's innovations -- the block-mean
residual whitened under the model's noise, ``e = L^-1 (y - X beta)``,
``N(0, I - P)`` when the model holds -- and answers with a :class:`Result`
``(statistic, pvalue, where)``: the test statistic, its p-value under the
model, and where the structure lies (time, temperature, timescale) with the
details a report prints. :data:`KINDS` maps each name to its
:class:`Check`, in the order the reports list them (the pattern of
:data:`gyrocomp.effects.vocabulary.KINDS` and :data:`gyrocomp.models.KINDS`);
a new check is one module and one line here.

Two rooms read the registry:

* the verdict (:mod:`gyrocomp.diagnose.unexplained`) runs the checks of
  :data:`RESIDUAL` on every run of the selected model, and Holm's procedure
  keeps their family -- as many tests as the checks returned results --
  at its ``family_alpha``;
* a noise term's signature (:mod:`gyrocomp.diagnose.signature`) runs the
  checks of :data:`SIGNATURE`, per run and between runs, and Bonferroni
  shares its ``refusal_alpha`` among as many tests as they returned.

:func:`family_size` counts a family's tests from what its checks returned,
so that a check added to the registry enters its family's error rate.

Each check states whether its p-value is exact (uniform under the model:
``exact``) or a conservative bound (a union bound, Fisher's first term, a
Bonferroni over segments: ``P(p <= a) <= a``), and gives a structure of its
own shape (``shape``), which the contract tests
(``tests/diagnose/test_checks_contract.py``) add to a null draw and must find.
"""

from __future__ import annotations

__all__ = ["Result", "Check", "Frame", "KINDS", "RESIDUAL", "SIGNATURE", "DETERMINISTIC", "OWN", "family_size", "as_dict"]


from gyrocomp.diagnose.checks._base import Check, Frame, Result, as_dict, log10  # noqa: E402


def _registry():
    from gyrocomp.diagnose.checks import (
        agreement, allan, extreme, heating_cooling, levels, ljung_box, moving_line, noise_blocks, noise_correlation,
        noise_samples, noise_temperature, power_on, replication, spectral_line, spectrum, step, temperature,
        temperature_absorbed, temperature_step, time_segments, trend,
    )

    modules = (temperature, heating_cooling, power_on, time_segments, step, temperature_step, spectral_line,
               moving_line, noise_blocks, noise_correlation, noise_samples, noise_temperature,
               ljung_box, trend, temperature_absorbed, allan, extreme, levels, agreement, replication, spectrum)
    return {m.CHECK.name: m.CHECK for m in modules}


KINDS: dict[str, Check] = _registry()
RESIDUAL = tuple(name for name, c in KINDS.items() if "residual" in c.families and c.scope == "run")
"""The verdict's checks, in the order it reports them."""
DETERMINISTIC = tuple(name for name in RESIDUAL if not name.startswith("noise_"))
"""The verdict's checks of a deterministic structure (their columns can join the design)."""
SIGNATURE = ("ljung_box", "trend", "temperature_absorbed", "step")
"""The per-run checks of a noise term's signature, in its order (beside its timescale and between-run checks)."""
OWN = tuple(name for name, c in KINDS.items() if c.own)
"""The checks of a noise term's own statistics."""


def family_size(results) -> int:
    """The number of tests in a family: every result its checks returned (a list counts each of its entries).

    Examples
    --------
    >>> family_size({"step": {"p": 0.3}, "allan": [{"p": 0.1}, {"p": 0.5}], "spectrum": None})
    3
    """
    return int(sum(len(r) if isinstance(r, list) else (r is not None) for r in results.values()))
