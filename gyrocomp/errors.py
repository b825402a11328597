"""Exceptions of gyrocomp, each carrying the process exit code it maps to.

The command line turns any of these into one line on stderr and the exit
code below; ``--debug`` shows the traceback instead.

==========================  =========  ======================================
class                       exit code  meaning
==========================  =========  ======================================
:class:`GyrocompError`      1          anything else that went wrong
:class:`InputError`         2          bad input file, bad option or config
:class:`SchemaError`        2          artefact of a foreign or newer schema
:class:`ThresholdError`     3          a CI threshold was crossed
==========================  =========  ======================================
"""


class GyrocompError(Exception):
    """Base class; exit code 1."""

    exit_code = 1


class InputError(GyrocompError, ValueError):
    """A recording, artefact, option or config is unusable; exit code 2.

    The message names the file, and the row and column where there is one.
    """

    exit_code = 2


class SchemaError(InputError):
    """An artefact has a foreign schema name or a newer major version."""


class ThresholdError(GyrocompError):
    """A figure crossed a CI threshold given on the command line; exit code 3."""

    exit_code = 3


class RecordingNote(UserWarning):
    """What reading a recording changed (duplicate stamps merged, gaps filled, segments found).

    Not an error: the command line prints it as one line on stderr, and the
    recording's ``inputs`` entry in every artefact keeps it.
    """
