"""Progress of a command made of several parts, counted as one: what its callback reports.

The library reports progress through a callback ``callback(done, total,
description=None)`` (the command line draws it: :func:`gyrocomp.cli._app.progress`).
A command that runs one stage per axis or per segment would otherwise
report each part from 0 to its own total, so the user sees "100 %" once per
part and then nothing while the output is written. :func:`part` maps one
part's own count onto the whole: ``TICKS`` per part, ``parts * TICKS`` in
all, and a description naming the part, so the count rises once, to 100 %
at the end of the last part; :func:`stage` names a last stage (writing)
that has no count of its own.
"""

from __future__ import annotations

from typing import Callable

__all__ = ["TICKS", "part", "stage"]

TICKS = 1000
"""Counts of one part in the whole."""

Callback = Callable[..., None]


def part(callback: Callback | None, index: int, parts: int, description: str) -> Callable[[int, int], None] | None:
    """The callback of part `index` (0-based) of `parts`: its ``(done, total)`` as the whole's count.

    >>> seen = []
    >>> second = part(lambda d, t, description=None: seen.append((d, t, description)), 1, 2, "axis gy")
    >>> second(1, 4); second(4, 4)
    >>> seen
    [(1250, 2000, 'axis gy (2/2)'), (2000, 2000, 'axis gy (2/2)')]
    """
    if callback is None:
        return None
    label = f"{description} ({index + 1}/{parts})"

    def report(done: int, total: int) -> None:
        share = min(max(done / total, 0.0), 1.0) if total else 0.0
        callback(int(round((index + share) * TICKS)), parts * TICKS, description=label)

    return report


def stage(callback: Callback | None, parts: int, description: str) -> None:
    """Name a last stage that counts nothing (the work of every part done): ``writing out.parquet``."""
    if callback is not None:
        callback(parts * TICKS, parts * TICKS, description=description)
