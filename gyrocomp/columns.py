"""How a user's column name selects columns: the name itself when the file has it, else a shell glob.

One rule for every reader (:mod:`gyrocomp.recordings`, :mod:`gyrocomp.flightlogs`),
so ``--temp-col 'Temperatur [°C]'`` means the same column in a CSV and in a log.
"""

from __future__ import annotations

import fnmatch
from typing import Sequence

__all__ = ["matching_columns"]


def matching_columns(names: Sequence[str], pattern: str) -> list[str]:
    """The names that `pattern` selects: the name itself when the file has it, else the names matching it as a shell glob.

    An exact name comes first, so a name with brackets (``"Temperatur [°C]"``)
    is not read as the glob character class ``[°C]`` (issue 35 item 6).
    """
    if pattern in names:
        return [pattern]
    return [c for c in names if fnmatch.fnmatchcase(c, pattern)]
