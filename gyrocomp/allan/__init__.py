"""Overlapping Allan deviation with confidence intervals and IEEE Std 952 noise terms.

================================  ==============================================
:mod:`~gyrocomp.allan.deviation`  the phase (in memory or a file) and the
                                  overlapping Allan deviation
:mod:`~gyrocomp.allan.noise_id`   power-law noise identification, Greenhall's
                                  equivalent degrees of freedom, chi-square interval
:mod:`~gyrocomp.allan.chi2`       the chi-square quantiles of that interval
:mod:`~gyrocomp.allan.ieee952`    the five-term noise model, its constants and units
:mod:`~gyrocomp.allan.fit`        the five-term fit and the classic read-offs
:mod:`~gyrocomp.allan.analysis`   the analysis of a recording and its artefact
================================  ==============================================
"""

from gyrocomp.allan.analysis import (
    AllanConfig,
    AllanSeries,
    allan_artefact,
    analyse,
    analyse_chunks,
    analyse_segment_chunks,
    pool_segments,
    check_thresholds,
    get_config,
)
from gyrocomp.allan.deviation import oadev

__all__ = [
    "AllanConfig",
    "AllanSeries",
    "get_config",
    "oadev",
    "analyse",
    "analyse_chunks",
    "analyse_segment_chunks",
    "pool_segments",
    "allan_artefact",
    "check_thresholds",
]
