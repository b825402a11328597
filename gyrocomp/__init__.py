"""gyrocomp: temperature-drift compensation of MEMS gyroscope oven-test logs.

Stages (one module per concept): :mod:`gyrocomp.recordings` (reading recordings),
:mod:`gyrocomp.artefacts` (writing artefacts), :mod:`gyrocomp.allan`, :mod:`gyrocomp.sim`,
:mod:`gyrocomp.decompose`, :mod:`gyrocomp.entropy`, :mod:`gyrocomp.denoise`,
:mod:`gyrocomp.models`, :mod:`gyrocomp.pipeline`, :mod:`gyrocomp.diagnose`
and the command line in :mod:`gyrocomp.cli`.
"""

__version__ = "0.1.0"
