"""A validated recording (:class:`Recording`): its columns, axes, temperatures, segments and notes."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Mapping, Sequence

import numpy as np

from gyrocomp.errors import InputError
from gyrocomp.recordings.spec import Channel

if TYPE_CHECKING:  # pandas is imported where a function needs it: the Parquet path of a recording never does
    import pandas as pd

class Recording:
    """A validated recording.

    Parameters
    ----------
    data : pandas.DataFrame or mapping of str to numpy.ndarray
        ``time`` [s] (strictly increasing, uniform within the tolerance in
        each segment), one column per axis (:attr:`axes`), ``temperature``
        [degC] when present (and any further temperatures by name), and any
        further numeric columns of the file unchanged, as a frame or as one
        1-D array per column (kept as given, not copied).
    name : str
        The file's name (``"-"`` for standard input), used in messages.
    sha256 : str
        SHA-256 of the file's bytes.
    fs_hz : float
        Sample rate, from the median sampling interval.
    metadata : dict, optional
        The ``gyrocomp`` metadata of a Parquet file written by this tool
        (the simulator stores its truth there); for one stream of a flight
        log (:func:`read_recordings`), ``stream``, its key (``sensor_gyro_0``),
        ``autopilot``, ``instance`` and PX4's ``device_id``; else empty.
    axes : sequence of Channel, optional
        The sensor axes; default one angular rate in column ``rate``.
    temperatures : sequence of str, optional
        Temperature columns, ``temperature`` first; default ``temperature``
        when the data has it.
    segments : sequence of slice, optional
        Row ranges sampled without a gap (default: one, all rows).
    notes : sequence of str, optional
        What reading changed (merged duplicates, filled gaps), one line each.
    time_origin : str, optional
        What ``time`` = 0 was in the file when its time stamps were not in
        seconds: an ISO 8601 date and time, or the first stamp and its unit
        (``"1700000000000000 us"``).

    Notes
    -----
    A recording built from arrays makes its :attr:`data` frame (and
    imports pandas) only when asked; from then on the frame is the
    recording's content, so changes made through it are what
    :meth:`column` and the properties return.
    """

    def __init__(
        self,
        data: pd.DataFrame | Mapping[str, np.ndarray],
        name: str,
        sha256: str,
        fs_hz: float,
        metadata: dict | None = None,
        *,
        axes: Sequence[Channel] | None = None,
        temperatures: Sequence[str] | None = None,
        segments: Sequence[slice] | None = None,
        notes: Sequence[str] = (),
        time_origin: str | None = None,
    ):
        self._frame = None
        self._arrays = None
        if isinstance(data, Mapping):
            self._arrays = dict(data)
        else:
            self._frame = data
        self.name = name
        self.sha256 = sha256
        self.fs_hz = fs_hz
        self.metadata = {} if metadata is None else metadata
        self.axes = tuple(axes) if axes is not None else (Channel("rate", "rate", "angular_rate", "deg/s", "deg/s"),)
        if temperatures is None:
            temperatures = ("temperature",) if "temperature" in self.columns else ()
        self.temperatures = tuple(temperatures)
        self.segments = tuple(segments) if segments is not None else (slice(0, self.n_samples),)
        self.notes = tuple(notes)
        self.time_origin = time_origin

    def __repr__(self) -> str:
        return (
            f"Recording(name={self.name!r}, axes={self.axis_names!r}, fs_hz={self.fs_hz!r}, "
            f"segments={len(self.segments)})"
        )

    @property
    def data(self) -> pd.DataFrame:
        """The columns as a pandas DataFrame (built once, sharing the arrays' memory)."""
        if self._frame is None:
            import pandas as pd

            self._frame = pd.DataFrame(self._arrays, copy=False)  # one block per column: no 2-D stacking copy
            self._arrays = None
        return self._frame

    @data.setter
    def data(self, frame: pd.DataFrame) -> None:
        self._frame, self._arrays = frame, None

    @property
    def columns(self) -> list[str]:
        """Column names, in order."""
        if self._frame is not None:
            return [str(c) for c in self._frame.columns]
        return list(self._arrays)

    @property
    def n_samples(self) -> int:
        """Number of rows."""
        return len(self.column("time"))

    def column(self, name: str) -> np.ndarray:
        """One column as a NumPy array (a view, not a copy, where possible).

        Raises
        ------
        KeyError
            No such column.
        """
        if self._frame is not None:
            return self._frame[name].to_numpy()
        return self._arrays[name]

    @property
    def axis_names(self) -> tuple[str, ...]:
        """The axes' names, in order (the names outputs keep)."""
        return tuple(a.name for a in self.axes)

    def axis(self, name: str | None = None) -> Recording:
        """One axis as a one-axis recording, its values in column ``rate``.

        Time, temperatures, segments, notes and the other non-axis columns
        are shared (no copy); :attr:`axes` holds the one channel, still
        under its own `name`.

        Parameters
        ----------
        name : str, optional
            The axis; may be omitted when the recording has one.

        Raises
        ------
        InputError
            No such axis, or several and no `name`.
        """
        if name is None:
            if len(self.axes) != 1:
                raise InputError(
                    f"{self.name}: {len(self.axes)} axes ({', '.join(self.axis_names)}); "
                    f"this command takes one: pick it with --rate-col"
                )
            channel = self.axes[0]
        else:
            found = [a for a in self.axes if a.name == name]
            if not found:
                raise InputError(f"{self.name}: no axis {name!r}; the axes are {', '.join(self.axis_names)}")
            channel = found[0]
        others = {a.column for a in self.axes}
        arrays = {"time": self.column("time"), "rate": self.column(channel.column)}
        for c in self.columns:
            if c not in others and c not in arrays:
                arrays[c] = self.column(c)
        return self._like(arrays, axes=(dataclasses.replace(channel, column="rate"),))

    def split(self) -> list[Recording]:
        """One recording per segment (rows shared, not copied), in time order."""
        if len(self.segments) == 1:
            return [self]
        parts = []
        for seg in self.segments:
            arrays = {c: self.column(c)[seg] for c in self.columns}
            parts.append(self._like(arrays, segments=(slice(0, seg.stop - seg.start),)))
        return parts

    @property
    def time_s(self) -> np.ndarray:
        return self.column("time")

    @property
    def rate_dps(self) -> np.ndarray:
        """The values of the recording's one axis (see :meth:`axis`)."""
        if len(self.axes) == 1:
            return self.column(self.axes[0].column)
        return self.axis().column("rate")  # refuses several axes, naming them

    @property
    def temperature_c(self) -> np.ndarray | None:
        if "temperature" not in self.columns:
            return None
        return self.column("temperature")

    def input_record(self) -> dict:
        """The ``inputs`` entry of an artefact header for this recording (with its :attr:`notes`, if any)."""
        record = {"name": Path(self.name).name, "sha256": self.sha256}
        if self.notes:
            record["notes"] = list(self.notes)
        return record

    def _like(self, arrays: dict, **changes) -> Recording:
        kwargs = dict(
            axes=self.axes,
            temperatures=[t for t in self.temperatures if t in arrays],
            segments=self.segments,
            notes=self.notes,
            time_origin=self.time_origin,
        )
        kwargs.update(changes)
        return Recording(arrays, self.name, self.sha256, self.fs_hz, self.metadata, **kwargs)


def check_distinct(runs: Sequence[Recording]) -> None:
    """Refuse two runs with the same bytes among recordings that must be different runs (a fit run and its held-out ones).

    A held-out figure is only one when its run took no part in the fit: the
    same file given twice, or a byte-identical copy of it, would report the
    fit as held out. Compared by content (:attr:`Recording.sha256`), so a
    path, a link or a copy are all caught.

    Raises
    ------
    InputError
        Naming both files and the shared digest (exit 2).
    """
    seen: dict[str, Recording] = {}
    for run in runs:
        first = seen.setdefault(run.sha256, run)
        if first is not run:
            raise InputError(
                f"{run.name}: the same bytes as {first.name} (SHA-256 {run.sha256[:12]}...); a held-out run must be another recording"
            )
