"""Readers: accelerogram files of many formats -> :class:`obspy.Stream` in m s-2.

The format is found from the file's first bytes (:func:`detect_format`, module ``detect``),
not its name or its whole content. Each format family has its module, whose parser returns
plain ``common.Channel`` objects: ``peer``, ``geonet``, ``cosmos``, ``dmg`` (CDMG/CSMIP and
USC), ``smc``, ``columns`` (plain number columns) and ``obspy_formats`` (K-NET/KiK-net and
ObsPy's formats); one builder (``samples.checked``) checks them (point count, NaN, a time
step and peak within what strong-motion records have, units stated twice that agree),
converts to m s-2, resamples uneven time steps (with a :class:`urmx.UrmxWarning`) and writes
every step to ``stats.processing``. :func:`describe` gives one channel of one file with its
provenance (SHA-256, format, unit, time step) for manifests and studies. This face holds
the entry points and the registry of urmx's own formats (`FORMATS` and their parsers), and
names the public names of its modules in ``__all__``.

Supported: PEER NGA ``.AT2``; GeoNet ``.V1A``/``.V2A``; COSMOS V1/V2 (``.V1c``/``.V2c``;
the raw-count ``V0c`` is refused); CDMG/CSMIP and USC Vol 1/Vol 2 text (including the
film records' unevenly spaced (time, accel) pairs); USGS SMC; K-NET/KiK-net ASCII (via
ObsPy); plain number columns (SLAMMER single column, several values per line, ``#``
comment lines, two-column time/accel); and the ObsPy formats of `OBSPY_FORMATS`. Text in
UTF-16 (with or without a byte-order mark) is decoded; compressed files and archives are
refused with what they are and how to unpack them.

Only formats whose readers parse data are ever tried: ObsPy's ``PICKLE`` format unpickles
the file (which can run any code), so it is neither detected nor accepted by name, and a
file that looks like a Python pickle is refused before ObsPy sees it.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...errors import MissingFileError, path_argument
from ..errors import (
    ChannelError,
    MissingTimeStepError,
    RecordError,
    RecordUnitError,
    UnsupportedRecordError,
)
from .columns import parse_columns
from .common import (
    OBSPY_FORMATS,
    STANDARD_GRAVITY,
    UNIT_FACTORS,
    Channel,
    decode,
    one_line,
    text_encoding,
)
from .cosmos import parse_cosmos
from .detect import MAX_RECORD_BYTES, SNIFF_BYTES, check_size, sniff
from .dmg import parse_dmg
from .geonet import parse_geonet
from .obspy_formats import parse_knet, parse_obspy
from .peer import parse_peer
from .samples import DT_RANGE, PGA_RANGE_G, Samples, check_finite, checked
from .smc import parse_smc

__all__ = [
    "read", "read_samples", "read_channel", "describe", "describe_all", "RecordFile",
    "detect_format", "stated_by_format", "read_file", "FileRead", "same_channel", "Samples",
    "check_finite", "FORMATS", "OBSPY_FORMATS", "UNIT_FACTORS", "STANDARD_GRAVITY",
    "DT_RANGE", "PGA_RANGE_G", "MAX_RECORD_BYTES", "SNIFF_BYTES",
]

#: urmx's own formats (``read(format=)`` takes these, their aliases and `OBSPY_FORMATS`)
FORMATS = ("peer", "geonet", "cosmos", "dmg", "smc", "knet", "columns")
_ALIASES = {"at2": "peer", "nga": "peer", "v1a": "geonet", "v2a": "geonet", "csmip": "dmg",
            "cdmg": "dmg", "usc": "dmg", "kiknet": "knet", "slammer": "columns",
            "plain": "columns", "text": "columns"}
_PARSERS = {"peer": parse_peer, "geonet": parse_geonet, "cosmos": parse_cosmos,
            "smc": parse_smc, "dmg": parse_dmg, "knet": parse_knet,
            "columns": None}  # read in blocks: parse_columns


# -- public entry points ---------------------------------------------------------------


def read(path: str | os.PathLike, format: str | None = None, dt: float | None = None,
         unit: str | None = None, *, channel: str | None = None, allow_unusual: bool = False,
         response: str | os.PathLike | None = None):
    """Read an accelerogram file into an :class:`obspy.Stream` in m s-2.

    Parameters
    ----------
    path : str or path-like
        The record file.
    format : str, optional
        One of ``FORMATS`` (aliases ``at2``, ``v2a``, ``csmip``, ``usc``, ``slammer``, ...)
        or an ObsPy format name of ``OBSPY_FORMATS`` (``MSEED``, ``SAC``, ...). Found from
        the file's first bytes if omitted. Python pickles are never read.
    dt : float, optional
        Time step [s] for files that do not carry it (plain columns). For files that
        do (a header, a ``# dt=`` comment, an evenly spaced time column) it must agree;
        for uneven records it is the resampling step.
    unit : {"g", "m/s2", "cm/s2", "mm/s2"}, optional
        Unit of the values, for files that do not state it; must agree with the file
        where it states one (a header, a ``# units:`` comment).
    channel : str, optional
        Only this channel of a multi-channel file (GeoNet, CDMG, ...), by its name as
        ``stats.channel`` gives it (``"S62W"``, ``"090"`` or ``"90"``, ``"UP"``; case is
        ignored). Without it every channel is returned.
    allow_unusual : bool
        Read a record whose time step lies outside `DT_RANGE`, whose PGA lies outside
        `PGA_RANGE_G` or whose file is larger than `MAX_RECORD_BYTES`, or that fails a
        check of `urmx.records.checks` (a header stating velocity, displacement or volts,
        a seismometer's channel, an instrument calibration or counts, a PGV or PGD beyond
        strong motion, a stated unit the values disagree with); such records are refused
        otherwise, as they are nearly always mistakes. What was overridden is written to
        ``stats.processing`` (``urmx: allow_unusual overrode: ...``).
    response : str or path-like, optional
        A StationXML file whose instrument response is removed (ObsPy
        ``remove_response(output="ACC")``) from the traces of a file in one of ObsPy's
        formats, turning a digitiser's counts into m s-2; without it integer samples are
        refused as counts.

    Returns
    -------
    obspy.Stream
        One trace per acceleration channel, data in m s-2 (float64). ``stats`` carries
        ``station``, ``channel``, ``starttime``, ``units`` (``"m/s2"``), ``record``
        (format, file, unit in the file, header peak [m s-2], ...) and
        ``processing`` (one entry per step).

    Raises
    ------
    RecordError
        A :class:`ValueError` subclass naming the file and the problem: unknown format
        (saying what was found: compressed, an archive, text whose first line is ...),
        a value that is not a number (with its line), truncated file, wrong point count,
        NaN, missing, non-positive or contradicting dt, unit mistakes, a time step or
        PGA outside what strong-motion records have (`UnusualRecordError`), an unknown
        channel (`ChannelError`), raw counts, a Python pickle.
    urmx.errors.MissingFileError
        The file does not exist (a :class:`FileNotFoundError`).
    """
    from obspy import Stream

    path_argument("read", "path", path)
    return Stream([c.trace() for c in read_file(path, format, dt, unit, channel,
                                                allow_unusual, response=response).samples])


def read_samples(path: str | os.PathLike, format: str | None = None, dt: float | None = None,
                 unit: str | None = None, *, channel: str | None = None,
                 allow_unusual: bool = False) -> list[Samples]:
    """:func:`read` without ObsPy: the checked channels as :class:`Samples` (data in m s-2,
    dt, header fields, provenance). Same arguments, checks and errors as :func:`read`;
    only ObsPy's own formats import ObsPy."""
    path_argument("read_samples", "path", path)
    return read_file(path, format, dt, unit, channel, allow_unusual).samples


def read_channel(path: str | os.PathLike, format: str | None = None, dt: float | None = None,
                 unit: str | None = None, *, channel: str | None = None,
                 allow_unusual: bool = False,
                 response: str | os.PathLike | None = None) -> Samples:
    """One channel of a record file as :class:`Samples`: `channel`, or the file's only
    one; a multi-channel file without `channel` is a :class:`ChannelError` listing its
    channels (never a silent first channel). Otherwise as :func:`read_samples`.

    Parameters
    ----------
    path : str or path-like
        The record file.
    format : str, optional
        Its format, as for :func:`read`; found from the file's first bytes if omitted.
    dt : float, optional
        Time step for files that do not state it; must agree where the file states one. [s]
    unit : {"g", "m/s2", "cm/s2", "mm/s2"}, optional
        Unit of the values for files that do not state it; must agree where one is stated.
    channel : str, optional
        The channel to read; required for a file of several channels.
    allow_unusual : bool
        Read a record outside the plausible time steps, peaks and sizes (as :func:`read`).
    response : str or path-like, optional
        A StationXML file whose instrument response is removed (as :func:`read`).
    """
    path_argument("read_channel", "path", path)
    return read_file(path, format, dt, unit, channel, allow_unusual, one=True,
                     response=response).samples[0]


@dataclass(frozen=True)
class RecordFile:
    """One channel of one record file with what a manifest or an archive keeps of it
    (:func:`describe`).

    Attributes
    ----------
    path : str
        The file, absolute.
    name : str
        Its file name.
    sha256 : str
        SHA-256 of the file's bytes (hex).
    format : str
        One of ``FORMATS`` or the ObsPy format name (``"SAC"``, ...): what
        ``read(format=)`` takes.
    channel : str
        The channel read (``""`` for files with one unnamed channel).
    channels : tuple of str
        Every channel the file holds.
    unit : str
        Unit of the values in the file (stated by it or given).
    dt : float
        Time step of the samples [s] (after resampling, for uneven records).
    npts : int
        Number of samples.
    pga : float
        Peak ground acceleration, unscaled. [m s-2]
    station : str
        Station code or name from the file (the file name's stem when it has none).
    description : str
        The header line that names the record (the event, for PEER files).
    processing : tuple of str
        What reading did (format, unit conversion, resampling), as in ``stats.processing``.
    data : numpy.ndarray
        The samples [m s-2], read-only.
    """

    path: str
    name: str
    sha256: str
    format: str
    channel: str
    channels: tuple[str, ...]
    unit: str
    dt: float
    npts: int
    pga: float
    station: str
    description: str
    processing: tuple[str, ...]
    data: np.ndarray = field(repr=False, compare=False)

    @property
    def pga_g(self) -> float:
        """Peak ground acceleration in units of standard gravity. [g]"""
        return self.pga / STANDARD_GRAVITY

    def samples(self) -> Samples:
        """The channel as :class:`Samples` (what :func:`read_samples` returns)."""
        record = dict(format=self.format, file=self.path, unit_in_file=self.unit,
                      sha256=self.sha256)
        return Samples(np.array(self.data), self.dt, self.station, "", self.channel, None,
                       record, list(self.processing))

    def trace(self):
        """The channel as an :class:`obspy.Trace` in m s-2 (unscaled)."""
        return self.samples().trace()


def describe(path: str | os.PathLike, *, channel: str | None = None, dt: float | None = None,
             unit: str | None = None, format: str | None = None,
             allow_unusual: bool = False,
             response: str | os.PathLike | None = None) -> RecordFile:
    """One channel of a record file with its provenance, reading the file once.

    Parameters
    ----------
    path : str or path-like
        The record file.
    channel : str, optional
        The channel to read; required for a file of several channels (the error lists
        them).
    dt, unit, format, allow_unusual, response
        As for :func:`read`: `dt` [s] and `unit` for files that do not state them; where
        the file states them they must agree; `response`, a StationXML file whose
        instrument response is removed.

    Returns
    -------
    RecordFile
        Path, file name, SHA-256 of the file's bytes, format, channel (and all channels
        of the file), unit in the file, dt [s], number of points, PGA [m s-2], station,
        description, processing steps and the samples [m s-2].

    Raises
    ------
    ChannelError
        A multi-channel file without `channel`, or a channel the file does not hold.
    RecordError, urmx.errors.MissingFileError
        As :func:`read`.
    """
    path_argument("describe", "path", path)
    return _record_files(path, read_file(path, format, dt, unit, channel, allow_unusual,
                                     one=True, response=response))[0]


def describe_all(path: str | os.PathLike, *, dt: float | None = None, unit: str | None = None,
                 format: str | None = None, allow_unusual: bool = False) -> list[RecordFile]:
    """Every channel of a record file as a :class:`RecordFile`, reading the file once (same
    arguments and errors as :func:`describe`).

    Parameters
    ----------
    path : str or path-like
        The record file.
    dt : float, optional
        Time step for files that do not state it; must agree where the file states one. [s]
    unit : {"g", "m/s2", "cm/s2", "mm/s2"}, optional
        Unit of the values for files that do not state it.
    format : str, optional
        Its format, as for :func:`read`; found from the file's first bytes if omitted.
    allow_unusual : bool
        Read a record outside the plausible time steps, peaks and sizes (as :func:`read`).
    """
    path_argument("describe_all", "path", path)
    return _record_files(path, read_file(path, format, dt, unit, None, allow_unusual))


def _record_files(path, got: FileRead) -> list[RecordFile]:
    out = []
    for s in got.samples:
        data = np.array(s.data)
        data.setflags(write=False)
        out.append(RecordFile(
            path=str(Path(path).absolute()), name=Path(path).name, sha256=got.sha256,
            format=s.record["format"], channel=s.channel, channels=got.channels,
            unit=s.record["unit_in_file"], dt=s.dt, npts=int(data.size),
            pga=float(np.max(np.abs(data))), station=s.station, description=got.description,
            processing=tuple(s.processing), data=data))
    return out


def stated_by_format(format: str) -> frozenset[str]:
    """What a file of `format` states itself (``"dt"``, ``"unit"``): headers state both,
    ObsPy's formats the time step, plain columns neither (a ``#`` comment may)."""
    fmt = _ALIASES.get(format.lower(), format.lower())
    if fmt == "columns":
        return frozenset()
    return frozenset({"dt", "unit"}) if fmt in FORMATS else frozenset({"dt"})


def detect_format(path: str | os.PathLike, *, allow_unusual: bool = False) -> str:
    """Find a record file's format from its first `SNIFF_BYTES` bytes.

    Parameters
    ----------
    path : str or path-like
        The record file.
    allow_unusual : bool
        Consult ObsPy's detectors also for files larger than `MAX_RECORD_BYTES`.

    Returns
    -------
    str
        One of ``FORMATS`` or ``"obspy"`` (a file one of ObsPy's detectors recognises).

    Raises
    ------
    UnknownFormatError
        The content matches no supported format; the message says what the file is
        (empty, zero bytes, compressed, an archive, binary, text whose first line is ...)
        and lists the formats urmx reads.
    UnsupportedRecordError
        A recognised file that holds no acceleration history (e.g. CSMIP Vol 3 spectra),
        or a Python pickle.
    UnusualRecordError
        A file larger than `MAX_RECORD_BYTES` that is none of urmx's text formats.
    """
    path_argument("detect_format", "path", path)
    return sniff(Path(path), allow_unusual)[0]


# -- reading: one pass over the file ---------------------------------------------------


class FileRead(NamedTuple):
    """What one pass over a record file gives (:func:`read_file`)."""

    samples: list  # the checked channels (:class:`Samples`), or the one chosen
    sha256: str  # of the file's bytes
    channels: tuple[str, ...]  # every channel the file holds
    description: str  # the header line that names the record


def read_file(path: str | os.PathLike, format: str | None = None, dt: float | None = None,
              unit: str | None = None, channel: str | None = None,
              allow_unusual: bool = False, one: bool = False,
              response: str | os.PathLike | None = None) -> FileRead:
    """Read a record file once: its checked channels, the SHA-256 of its bytes and the
    names of all its channels. Arguments and errors as :func:`read`; with ``one=True`` a
    multi-channel file without `channel` is a :class:`ChannelError` listing them;
    `response`: a StationXML file whose instrument response is removed from the traces of
    a file in one of ObsPy's formats (counts to m s-2)."""
    path = Path(path)
    if not path.is_file():
        raise MissingFileError(f"record file {str(path)!r} does not exist")
    if unit is not None and unit not in UNIT_FACTORS:
        raise RecordUnitError(path, f"unit {unit!r} is not one of {sorted(UNIT_FACTORS)}")
    if dt is not None and not (isinstance(dt, (int, float)) and np.isfinite(dt) and dt > 0):
        raise MissingTimeStepError(path, f"dt must be a positive number of seconds, got {dt!r}")
    if format is None:
        fmt, obspy_format = sniff(path, allow_unusual)
    else:
        fmt = _ALIASES.get(format.lower(), format.lower())
        obspy_format = None if fmt in _PARSERS else format.upper()
        if obspy_format is not None and obspy_format not in OBSPY_FORMATS:
            why = (" (ObsPy's PICKLE reader unpickles the file, which can run any code)"
                   if obspy_format == "PICKLE" else "")
            raise UnsupportedRecordError(
                path, f"format {format!r} is not read by urmx{why}; formats: "
                f"{', '.join(FORMATS)} or ObsPy's {', '.join(OBSPY_FORMATS)}")
        check_size(path, path.stat().st_size, allow_unusual)
    raw = path.read_bytes()
    digest = hashlib.sha256(raw).hexdigest()
    encoding = None
    try:
        if fmt == "knet":
            channels = parse_knet(path, raw)
        elif fmt == "columns":
            encoding = text_encoding(raw[:SNIFF_BYTES]) or "latin-1"
            channels = parse_columns(path, raw, encoding)
        elif fmt in _PARSERS:
            encoding = text_encoding(raw[:SNIFF_BYTES]) or "latin-1"
            channels = _PARSERS[fmt](path, decode(raw, encoding).splitlines())
        else:
            channels = parse_obspy(path, obspy_format, raw, response)
            fmt = obspy_format
    except RecordError:
        raise
    except (IndexError, KeyError, TypeError, ValueError, AttributeError) as exc:
        # a header that lacks a line or field the format has: say so, with what failed
        raise RecordError(path, f"not a well-formed {fmt} file: its header lacks a field "
                          f"urmx reads ({type(exc).__name__}: {one_line(exc)})") from None
    names = tuple(c.channel for c in channels)
    if channel is not None:
        channels = [_select_channel(path, channels, channel)]
    elif one and len(channels) > 1:
        raise ChannelError(path, f"holds {len(channels)} channels ({', '.join(names)}); "
                           "choose one with channel= (--channel NAME on the command line)")
    samples = [checked(path, fmt, ch, dt, unit, allow_unusual) for ch in channels]
    if encoding in ("utf-16", "utf-16-le", "utf-16-be"):
        for s in samples:
            s.processing.insert(1, f"urmx.records.read: text decoded from {encoding.upper()}")
    described = fmt in FORMATS and fmt != "columns"  # headers name the record
    return FileRead(samples, digest, names, channels[0].note if described else "")


def same_channel(name: str, wanted: str) -> bool:
    """Whether channel `name` is the one asked for: case ignored, ``"90"`` is ``"090"``."""
    a, b = name.strip().upper(), str(wanted).strip().upper()
    return a == b or (a.isdigit() and b.isdigit() and int(a) == int(b))


def _select_channel(path: Path, channels: list[Channel], wanted: str) -> Channel:
    names = [c.channel for c in channels]
    hits = [c for c in channels if same_channel(c.channel, wanted)]
    if len(hits) == 1:
        return hits[0]
    if hits:
        raise ChannelError(path, f"channel {wanted!r} is {len(hits)} channels of the file; "
                           "it cannot be chosen by name")
    held = (f"its {len(names)} channels are {', '.join(names)}" if any(names)
            else "it holds one channel without a name: leave channel unset")
    raise ChannelError(path, f"no channel {wanted!r}: {held}")
