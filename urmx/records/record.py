"""The one record type that studies, the collapse-capacity search and the benchmarks hand to
the kernel (samples, time step, scale factor, digest; numpy only), and the one adapter that
makes it from a Trace, a manifest id, a record file or an ``(array, dt)`` pair.

One meaning of a manifest id everywhere: the record file's samples, **unscaled**, with the
manifest's scale factor kept beside them (:attr:`Record.scale_factor`). Studies and the
collapse-capacity search analyse the record as the manifest scales it,
``acceleration * scale_factor`` (:meth:`Record.scaled`); `urmx.simulate` and
`urmx.records.load` give the samples as they are.
"""

from __future__ import annotations

import hashlib
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import records as library  # its names looked up when called (tests serve fakes)
from ..errors import InputError, MissingFileError


@dataclass
class Record:
    """A ground-motion record as a worker holds it.

    Parameters
    ----------
    id : str
        Manifest id, trace id or ``"array"``.
    acceleration : ndarray
        Samples, unscaled (float64, contiguous). [m s-2]
    dt : float
        Time step. [s]
    scale_factor : float
        The record's own scale factor (the manifest's, or a study's override): the record
        is analysed as ``acceleration * scale_factor``. [1]
    digest : str
        First 16 hex digits of the SHA-256 of the samples' bytes and, for a record read
        from a file, of the file's SHA-256 (computed when not given); batch keys hold it,
        so a part computed on other samples, or on another version of the file, is never
        reused.
    file : str
        Provenance (empty when the record comes from no file): the record file as its
        study file or manifest names it (relative to the study file or the records
        folder).
    sha256 : str
        SHA-256 of the file's bytes (hex).
    format : str
        The file's format (``urmx.records.FORMATS`` or an ObsPy format name).
    channel : str
        The channel read (``""`` for files with one unnamed channel).
    unit : str
        Unit of the values in the file (stated by it or given).
    source : str
        Where the record is declared: ``manifest <file>`` or ``study <file> [records.<id>]``.
    processing : tuple of str
        What reading did (format, unit conversion, resampling).
    """

    id: str
    acceleration: np.ndarray
    dt: float
    scale_factor: float = 1.0
    digest: str = ""
    file: str = ""
    sha256: str = ""
    format: str = ""
    channel: str = ""
    unit: str = ""
    source: str = ""
    processing: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        self.acceleration = np.ascontiguousarray(self.acceleration, dtype=np.float64)
        self.processing = tuple(self.processing)
        if not self.digest:
            h = hashlib.sha256(self.acceleration.tobytes())
            if self.sha256:  # the file too: an edited file never keys as the old one
                h.update(f"\0file sha256 {self.sha256}".encode())
            self.digest = h.hexdigest()[:16]

    @property
    def pga(self) -> float:
        """Peak of the unscaled samples. [m s-2]"""
        return float(np.max(np.abs(self.acceleration)))

    @property
    def npts(self) -> int:
        """Number of samples. [1]"""
        return int(self.acceleration.size)

    def provenance(self) -> dict[str, Any]:
        """Where the record comes from, by the names of a study archive's coordinates on
        its ``record`` dimension (`PROVENANCE`; empty strings when it comes from no file)."""
        return {"record_file": self.file, "record_sha256": self.sha256,
                "record_format": self.format, "record_channel": self.channel,
                "record_unit": self.unit, "record_source": self.source,
                "record_processing": "; ".join(self.processing),
                "record_npts": self.npts}

    def scaled(self) -> np.ndarray:
        """The samples as analysed: ``acceleration * scale_factor``. [m s-2]"""
        return np.ascontiguousarray(self.acceleration * self.scale_factor, dtype=np.float64)

    @classmethod
    def from_trace(cls, trace, id: str | None = None, scale_factor: float = 1.0,
                   **provenance: Any) -> Record:
        """A Record of an ObsPy Trace's samples (as given) and time step; its provenance
        from what the reader and the manifest put in ``stats`` (``stats.record``: format,
        unit in the file, sha256; ``stats.channel``, ``stats.processing``), where a
        `provenance` field given here wins.

        Parameters
        ----------
        trace : obspy.Trace
            The samples [m s-2] and their time step.
        id : str, optional
            The record's id (default: from ``stats.record`` or the trace's id).
        scale_factor : float
            The record's own scale factor. [1]
        **provenance
            Provenance fields that win over the trace's.
        """
        stats = trace.stats
        got = stats.get("record") or {}
        found = dict(sha256=got.get("sha256") or "", format=got.get("format") or "",
                     unit=got.get("unit_in_file") or "",
                     channel=str(stats.get("channel") or "") if got else "",
                     processing=tuple(stats.get("processing") or ()) if got else ())
        found.update(provenance)
        return cls(str(trace.id) if id is None else id, trace.data, float(stats.delta),
                   float(scale_factor), **found)

    @classmethod
    def from_file(cls, rf, id: str, scale_factor: float = 1.0, **provenance: Any) -> Record:
        """A Record of one channel of a record file as `urmx.records.describe` gives it
        (a `urmx.records.RecordFile`: samples, dt and their provenance).

        Parameters
        ----------
        rf : urmx.records.RecordFile
            One channel of a file, as `urmx.records.describe` gives it.
        id : str
            The record's id.
        scale_factor : float
            The record's own scale factor. [1]
        **provenance
            Provenance fields that win over the file's.
        """
        found = dict(file=rf.name, sha256=rf.sha256, format=rf.format, channel=rf.channel,
                     unit=rf.unit, processing=rf.processing)
        found.update(provenance)
        return cls(id, np.array(rf.data), rf.dt, float(scale_factor), **found)


#: the coordinates of a study archive's ``record`` dimension that say where each record
#: comes from (:meth:`Record.provenance`), besides ``record_dt``, ``pga`` and ``scale_factor``
PROVENANCE = ("record_file", "record_sha256", "record_format", "record_channel",
              "record_unit", "record_source", "record_processing", "record_npts")


def load_named(name: str | os.PathLike, records_dir: str | os.PathLike | None = None):
    """A record named by a string, as an ObsPy Trace in m s-2 (unscaled): a record file
    (one channel), else a manifest record id.

    Raises
    ------
    urmx.errors.MissingFileError
        `name` is neither an existing file nor a manifest id.
    urmx.errors.InputError
        The file holds more than one channel.
    """
    path = Path(name)
    if path.is_file():
        stream = library.read(path)
        if len(stream) != 1:
            ids = ", ".join(tr.id for tr in stream)
            raise InputError(f"record file {str(name)!r} holds {len(stream)} channels "
                             f"({ids}); give a file with one channel")
        return stream[0]

    try:
        known = library.manifest(records_dir)
    except MissingFileError:
        known = {}
    if str(name) not in known:
        raise MissingFileError(f"record {str(name)!r} is neither a file nor a manifest "
                               "record id (see `urmx records list`)")
    return library.load(str(name), records_dir)


def _pair(acc: Any, dt: Any) -> Record:
    try:
        dt = float(dt)
    except (TypeError, ValueError):
        raise InputError(f"record: dt={dt!r} must be a number of seconds") from None
    acc = np.ascontiguousarray(acc, dtype=np.float64)
    if acc.ndim != 1 or acc.size < 2:
        raise InputError(f"record: the samples must be a 1-D array of at least 2 values "
                         f"(got shape {acc.shape})")
    if not (math.isfinite(dt) and dt > 0):
        raise InputError(f"record: dt={dt!r} must be a positive time step in seconds")
    return Record("array", acc, dt)


def as_record(record: Any, records_dir: str | os.PathLike | None = None) -> Record:
    """The `Record` of any record argument.

    Parameters
    ----------
    record : Record, obspy.Trace, str, path or (array, dt)
        A Record (as it is); a Trace (its samples as given, scale factor 1); a record file
        or a manifest id (unscaled samples, the manifest's scale factor beside them; module
        docstring); samples [m s-2] and their time step [s].
    records_dir : str or path, optional
        Records folder for a manifest id.

    Raises
    ------
    urmx.errors.InputError
        A bad pair or an argument of another type.
    """
    if isinstance(record, Record):
        return record
    if isinstance(record, (str, os.PathLike)):
        trace = load_named(record, records_dir)
        entry = trace.stats.get("record") or {}
        return Record.from_trace(trace, str(record), float(entry.get("scale_factor") or 1.0))
    if hasattr(record, "stats") and hasattr(record, "data"):
        return Record.from_trace(record)
    if isinstance(record, (tuple, list)) and len(record) == 2:
        return _pair(*record)
    raise InputError(f"record must be an obspy Trace, a manifest id or an (array, dt) pair, "
                     f"not {type(record).__name__}")
