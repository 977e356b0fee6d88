"""Readers: accelerogram files of many formats -> :class:`obspy.Stream` in m s-2.

The format is found from the file's first bytes (:func:`detect_format`), not its name or
its whole content. Each format parser returns plain :class:`_Channel` objects; one builder
(:func:`_checked`) checks them (point count, NaN, a time step and peak within what
strong-motion records have, units stated twice that agree), converts to m s-2, resamples
uneven time steps (with a :class:`urmx.UrmxWarning`) and writes every step to
``stats.processing``. :func:`describe` gives one channel of one file with its provenance
(SHA-256, format, unit, time step) for manifests and studies.

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

import codecs
import hashlib
import io
import math
import os
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ...config import UrmxWarning
from ...errors import MissingFileError, numbers_argument, path_argument
from ..checks import counts_problem, motion_problem, quantity_problems, unit_problem
from ..errors import (
    ChannelError,
    MissingTimeStepError,
    NonFiniteError,
    PointCountError,
    RecordError,
    RecordUnitError,
    TruncatedRecordError,
    UnknownFormatError,
    UnsupportedRecordError,
    UnusualRecordError,
)

STANDARD_GRAVITY = 9.80665  # standard gravity [m s-2], for records in units of g

#: factors from the units accepted by :func:`read` (and found in headers) to m s-2
UNIT_FACTORS = {
    "g": STANDARD_GRAVITY,
    "m/s2": 1.0,
    "cm/s2": 0.01,
    "mm/s2": 0.001,
}
_HEADER_UNITS = {**UNIT_FACTORS, "g/10": STANDARD_GRAVITY / 10.0, "um/s2": 1e-6}

#: time steps [s] of strong-motion records (10 kHz to 10 Hz sampling); a record whose
#: time step lies outside is refused unless ``allow_unusual=True``
DT_RANGE = (1e-4, 0.1)
#: peak ground accelerations [g] of strong-motion records: below 0.001 g (1 cm/s2, under
#: the trigger level of strong-motion instruments) the values are most likely g under a
#: cm/s2 or mm/s2 label, above 10 g cm/s2 or mm/s2 under a g or m/s2 label; outside, a
#: record is refused unless ``allow_unusual=True``
PGA_RANGE_G = (1e-3, 10.0)
#: largest record file read [bytes]: a strong-motion record takes a few MB at most
MAX_RECORD_BYTES = 256 * 2**20
#: bytes read to decide a file's format (never the whole file)
SNIFF_BYTES = 8192
_ALLOW = "; if it is really meant, pass allow_unusual=True (--allow-unusual on the command line)"

#: nice time steps [s] that uneven records are resampled to (the largest not above the
#: mean spacing, so the resampled record is never coarser than the original)
_NICE_DT = (0.001, 0.002, 0.0025, 0.004, 0.005, 0.01, 0.02)

FORMATS = ("peer", "geonet", "cosmos", "dmg", "smc", "knet", "columns")
#: ObsPy waveform formats urmx detects and reads (parsers only, in ObsPy's order of
#: preference); never ``PICKLE``, whose reader unpickles, i.e. can run code
OBSPY_FORMATS = ("MSEED", "SAC", "GSE2", "SEISAN", "SACXY", "GSE1", "Q", "SH_ASC", "SLIST",
                 "TSPAIR", "Y", "PDAS", "SEGY", "SU", "SEG2", "WAV", "WIN", "CSS",
                 "NNSA_KB_CORE", "AH", "GCF", "REFTEK130", "RG16", "DMX",
                 "KINEMETRICS_EVT")
_KNOWN = ("PEER NGA AT2, GeoNet V1A/V2A, COSMOS V1/V2, CDMG/CSMIP and USC Vol 1/2, USGS SMC, "
          "K-NET/KiK-net, plain number columns and ObsPy's " + ", ".join(OBSPY_FORMATS))
_ALIASES = {"at2": "peer", "nga": "peer", "v1a": "geonet", "v2a": "geonet", "csmip": "dmg",
            "cdmg": "dmg", "usc": "dmg", "kiknet": "knet", "slammer": "columns",
            "plain": "columns", "text": "columns"}
_FLOAT = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_DECIMAL_COMMA = re.compile(r"[-+]?\d*,\d+")

#: what a file is, from its first bytes, and what to do: (signature, offset, what, advice)
_CONTAINERS = (
    (b"\x1f\x8b", 0, "gzip-compressed", "decompress it first (gunzip FILE)"),
    (b"PK\x03\x04", 0, "a zip archive", "unpack it first (unzip FILE) and read the record "
     "file inside"),
    (b"PK\x05\x06", 0, "an empty zip archive", "it holds no file"),
    (b"BZh", 0, "bzip2-compressed", "decompress it first (bunzip2 FILE)"),
    (b"\xfd7zXZ\x00", 0, "xz-compressed", "decompress it first (unxz FILE)"),
    (b"\x28\xb5\x2f\xfd", 0, "zstd-compressed", "decompress it first (unzstd FILE)"),
    (b"7z\xbc\xaf\x27\x1c", 0, "a 7-Zip archive", "unpack it first (7z x FILE)"),
    (b"ustar", 257, "a tar archive", "unpack it first (tar xf FILE)"),
    (b"%PDF", 0, "a PDF document", "a record is the data file itself"),
    (b"\x89HDF\r\n\x1a\n", 0, "an HDF5 or netCDF-4 file (a urmx archive?)",
     "a record is a strong-motion data file"),
    (b"CDF\x01", 0, "a netCDF-3 file", "a record is a strong-motion data file"),
    (b"CDF\x02", 0, "a netCDF-3 file", "a record is a strong-motion data file"),
)


@dataclass
class _Channel:
    """One channel as parsed, before checks and unit conversion."""

    values: np.ndarray
    unit: str | None
    dt: float | None
    times: np.ndarray | None = None  # uneven records: sample times [s]
    npts_header: int | None = None
    station: str = ""
    network: str = ""
    channel: str = ""
    starttime: object = None
    header_peak: float | None = None  # |peak| stated in the header, in ``unit``
    unit_from_file: bool = True
    note: str = ""
    extra: dict = field(default_factory=dict)


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
    return _sniff(Path(path), allow_unusual)[0]


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
        fmt, obspy_format = _sniff(path, allow_unusual)
    else:
        fmt = _ALIASES.get(format.lower(), format.lower())
        obspy_format = None if fmt in _PARSERS else format.upper()
        if obspy_format is not None and obspy_format not in OBSPY_FORMATS:
            why = (" (ObsPy's PICKLE reader unpickles the file, which can run any code)"
                   if obspy_format == "PICKLE" else "")
            raise UnsupportedRecordError(
                path, f"format {format!r} is not read by urmx{why}; formats: "
                f"{', '.join(FORMATS)} or ObsPy's {', '.join(OBSPY_FORMATS)}")
        _check_size(path, path.stat().st_size, allow_unusual)
    raw = path.read_bytes()
    digest = hashlib.sha256(raw).hexdigest()
    encoding = None
    try:
        if fmt == "knet":
            channels = _parse_knet(path, raw)
        elif fmt == "columns":
            encoding = _text_encoding(raw[:SNIFF_BYTES]) or "latin-1"
            channels = _parse_columns(path, raw, encoding)
        elif fmt in _PARSERS:
            encoding = _text_encoding(raw[:SNIFF_BYTES]) or "latin-1"
            channels = _PARSERS[fmt](path, _decode(raw, encoding).splitlines())
        else:
            channels = _parse_obspy(path, obspy_format, raw, response)
            fmt = obspy_format
    except RecordError:
        raise
    except (IndexError, KeyError, TypeError, ValueError, AttributeError) as exc:
        # a header that lacks a line or field the format has: say so, with what failed
        raise RecordError(path, f"not a well-formed {fmt} file: its header lacks a field "
                          f"urmx reads ({type(exc).__name__}: {_one_line(exc)})") from None
    names = tuple(c.channel for c in channels)
    if channel is not None:
        channels = [_select_channel(path, channels, channel)]
    elif one and len(channels) > 1:
        raise ChannelError(path, f"holds {len(channels)} channels ({', '.join(names)}); "
                           "choose one with channel= (--channel NAME on the command line)")
    samples = [_checked(path, fmt, ch, dt, unit, allow_unusual) for ch in channels]
    if encoding in ("utf-16", "utf-16-le", "utf-16-be"):
        for s in samples:
            s.processing.insert(1, f"urmx.records.read: text decoded from {encoding.upper()}")
    described = fmt in FORMATS and fmt != "columns"  # headers name the record
    return FileRead(samples, digest, names, channels[0].note if described else "")


def same_channel(name: str, wanted: str) -> bool:
    """Whether channel `name` is the one asked for: case ignored, ``"90"`` is ``"090"``."""
    a, b = name.strip().upper(), str(wanted).strip().upper()
    return a == b or (a.isdigit() and b.isdigit() and int(a) == int(b))


def _select_channel(path: Path, channels: list[_Channel], wanted: str) -> _Channel:
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


# -- sniffing: the first bytes decide --------------------------------------------------


def _sniff(path: Path, allow_unusual: bool = False) -> tuple[str, str | None]:
    """(format, ObsPy format or None) from the file's first `SNIFF_BYTES` bytes."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(SNIFF_BYTES)
    whole = len(head) >= size
    if not head.strip():
        raise UnknownFormatError(path, "file is empty" if not head else
                                 "file holds only blank space")
    if not head.strip(b"\x00"):
        what = ("the file holds only zero bytes" if whole else
                f"its first {len(head)} bytes are all zero bytes")
        raise UnknownFormatError(path, f"{what} ({_size(size)}): a blank, sparse or damaged "
                                 "file, not a record")
    for magic, offset, what, advice in _CONTAINERS:
        if head[offset:offset + len(magic)] == magic:
            raise UnknownFormatError(path, f"file is {what}, not a record file: {advice}")
    if head.lstrip()[:15].lower().startswith((b"<!doctype html", b"<html")):
        raise UnknownFormatError(path, "file is an HTML page (a download that returned a web "
                                 "page?), not a record file")
    if _looks_like_pickle(head):
        raise UnsupportedRecordError(
            path, "file is a Python pickle: urmx never reads pickles, since unpickling can "
            "run any code; convert the record to MiniSEED, SAC or text")
    encoding = _text_encoding(head)
    if encoding is None:  # binary: ObsPy's detectors, on files of a record's size only
        _check_size(path, size, allow_unusual)
        return _obspy_or_unknown(path, "a binary file starting with bytes "
                                 + head[:8].hex(" "))
    text = _decode(head, encoding)
    lines = text.splitlines()
    if not whole and lines:
        lines = lines[:-1]  # the head may end inside a line
    fmt = _text_format(path, lines)
    if fmt is not None:
        return fmt, None
    _check_size(path, size, allow_unusual)
    body = [ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
    first = next((ln.strip() for ln in lines if ln.strip()), "")
    if body and _is_numeric_line(body[0]):  # numbers, then text: ObsPy's, or a bad line
        found = _detect_obspy(path)
        return ("obspy", found) if found else ("columns", None)
    if not body:
        return _obspy_or_unknown(path, "a text file of comment lines only, first "
                                 f"{first[:60]!r}")
    return _obspy_or_unknown(path, f"a text file whose first line is {first[:60]!r}")


def _text_format(path: Path, lines: list[str]) -> str | None:
    """One of urmx's own text formats, from the first lines, or None."""
    first = lines[0] if lines else ""
    top = "\n".join(lines[:6])
    text = "\n".join(lines)
    if "PEER NGA" in first.upper() or re.search(r"NPTS\s*=\s*\S+\s*,\s*DT\s*=", top, re.I):
        return "peer"
    if re.match(r"\s*(Un)?corrected accelerogram\s+\S+\s+GNS", first, re.I):
        return "geonet"
    if re.search(r"Format v\d", first) and "Integer-header values" in text:
        return "cosmos"
    if re.match(r"\s*Response (and Fourier amplitude )?spectra", first, re.I):
        raise UnsupportedRecordError(
            path, "CSMIP Vol 3 file: response and Fourier spectra, no acceleration history; "
            "read the Vol 2 (.V2) file instead")
    if re.match(r"\s*[0-2] (RAW|UNCORRECTED|CORRECTED) ACCELEROGRAM", first):
        return "smc"
    if top.startswith("Origin Time") and "Scale Factor" in text:
        return "knet"
    if re.search(r"(UN)?CORRECTED ACCELEROGRAM", "\n".join(lines[:2]), re.I):
        return "dmg"
    body = [ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
    if body and _header_names(body[0]) is not None and len(body) > 1:
        body = body[1:]  # a header row of column names (time, acc_g, ...)
    if body and all(_is_numeric_line(ln) for ln in body):
        return "columns"
    return None


def _size(n: int) -> str:
    return f"{n / 2**30:.1f} GiB" if n >= 2**30 else f"{n / 2**20:.1f} MiB" \
        if n >= 2**20 else f"{n} bytes"


def _check_size(path: Path, size: int, allow_unusual: bool) -> None:
    if size > MAX_RECORD_BYTES and not allow_unusual:
        raise UnusualRecordError(path, f"file of {_size(size)} is larger than any strong-motion "
                                 f"record (urmx reads up to {_size(MAX_RECORD_BYTES)}; is it "
                                 f"the right file?){_ALLOW}")


def _text_encoding(head: bytes) -> str | None:
    """How to decode a file that starts with `head`: a text encoding, or None (binary)."""
    if head.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        return "utf-16"
    n = len(head) - len(head) % 2
    if n >= 8:
        even, odd = head[0:n:2], head[1:n:2]
        if odd.count(0) >= 0.95 * len(odd) and even.count(0) <= 0.01 * len(even):
            return "utf-16-le"
        if even.count(0) >= 0.95 * len(even) and odd.count(0) <= 0.01 * len(odd):
            return "utf-16-be"
    if head.startswith(codecs.BOM_UTF8):
        return "utf-8-sig"
    controls = sum(head.count(bytes([c])) for c in range(32) if c not in b"\t\n\v\f\r\x1a")
    return None if controls > 0.05 * len(head) else "latin-1"


def _decode(raw: bytes, encoding: str) -> str:
    if encoding == "utf-8-sig":  # numbers and headers are ASCII: latin-1 never fails
        return raw[len(codecs.BOM_UTF8):].decode("latin-1")
    if encoding.startswith("utf-16"):
        return raw[: len(raw) - len(raw) % 2].decode(encoding, errors="replace")
    return raw.decode(encoding)


def _is_numeric_line(line: str) -> bool:
    return all(_FLOAT.fullmatch(tok) for tok in line.replace(",", " ").split())


def _looks_like_pickle(head: bytes) -> bool:
    """A Python pickle: protocol 2+ header, or ObsPy's own pickle marker near the start
    (what ObsPy's PICKLE detector looks for before it unpickles)."""
    if len(head) > 1 and head[0] == 0x80 and 2 <= head[1] <= 5:
        return True
    return b"obspy.core.stream" in head[:200]


def _detect_obspy(path: Path) -> str | None:
    """The first of `OBSPY_FORMATS` whose ObsPy detector accepts the file, or None."""
    from obspy.core.util.base import ENTRY_POINTS, buffered_load_entry_point

    entries = ENTRY_POINTS["waveform"]
    for fmt in OBSPY_FORMATS:
        ep = entries.get(fmt)
        if ep is None:
            continue
        try:
            is_format = buffered_load_entry_point(
                ep.dist.name, f"obspy.plugin.waveform.{ep.name}", "isFormat")
            if is_format(str(path)):
                return fmt
        except Exception:  # noqa: BLE001 - a detector that fails means "not mine"
            continue
    return None


def _obspy_or_unknown(path: Path, seen: str) -> tuple[str, str]:
    found = _detect_obspy(path)
    if found is None:
        raise UnknownFormatError(path, f"unknown record format: {seen}; urmx reads {_KNOWN}")
    return "obspy", found


def _number(tok: str) -> float | None:
    """A number token (``_FLOAT``), or None."""
    return float(tok) if _FLOAT.fullmatch(tok) else None


def _not_a_number(tok: str) -> str:
    hint = " (a decimal comma? write numbers with a decimal point)" \
        if _DECIMAL_COMMA.fullmatch(tok) else ""
    return f"{tok!r} is not a number{hint}"


def _unit_name(text: str) -> str | None:
    """A unit as urmx names it (a key of ``_HEADER_UNITS``), from a file's spelling, or
    None: ``CM/SEC/SEC``, ``cm/s^2``, ``gal`` -> ``cm/s2``; ``G`` -> ``g``."""
    t = text.strip().strip("()[],.;:").lower().replace(" ", "").replace("²", "2")
    t = t.replace("**", "").replace("^", "").replace("sec", "s")
    t = re.sub(r"/s/s$", "/s2", t)
    t = {"gal": "cm/s2", "gals": "cm/s2", "µm/s2": "um/s2"}.get(t, t)
    return t if t in _HEADER_UNITS else None


def _values(path: Path, lines: list[str], first: int, what: str) -> np.ndarray:
    """The whitespace-separated numbers of `lines` (`first`: the file line of lines[0]);
    a bad token is named with its line."""
    try:
        return np.array(" ".join(lines).split(), dtype=float)
    except ValueError:
        for i, ln in enumerate(lines, first):
            for tok in ln.split():
                try:
                    float(tok)
                except ValueError:
                    raise RecordError(path, f"{what} line {i}: {_not_a_number(tok)}") from None
        raise
def _fixed(path: Path, lines: list[str], width: int, offset: int = 0,
           first: int | None = None) -> np.ndarray:
    """Numbers in fixed-width fields (values may touch, so never split on spaces);
    `first` is the file line of ``lines[0]``, for the message naming a bad value."""
    out, where = [], []
    for k, ln in enumerate(lines):
        ln = ln.rstrip()
        for i in range(offset, len(ln), width):
            tok = ln[i:i + width].strip()
            if tok:
                out.append(tok)
                where.append(k)
    try:
        return np.array(out, dtype=float)
    except ValueError:
        j = next(j for j, t in enumerate(out) if not _safe_float(t))
        k = where[j]
        line = f"line {first + k}" if first is not None else f"data line {lines[k].strip()!r}"
        raise RecordError(path, f"{line}: {_not_a_number(out[j])}") from None


def _safe_float(tok: str) -> bool:
    try:
        float(tok)
    except ValueError:
        return False
    return True


def _field_width(path: Path, line: str) -> tuple[int, int]:
    """(offset, width) of the fixed fields on a data line (from its separated values)."""
    n = len(_FLOAT.findall(line))
    length = len(line.rstrip())
    if n == 0 or length // n == 0 or length - (length // n) * n > 3:
        raise RecordError(path, f"cannot tell the field width of data line {line.strip()!r}")
    return length - (length // n) * n, length // n


def _component(text: str) -> str:
    text = text.strip()
    if text.isdigit():
        return f"{int(text):03d}"
    m = re.match(r"([NS]?\d+[EW]?|\d+)\s*deg", text, re.I)
    if m:
        return f"{int(m.group(1)):03d}" if m.group(1).isdigit() else m.group(1).upper()
    return text.split()[0].upper() if text else ""


def _utc(year, month, day, hour=0, minute=0, second=0.0):
    from obspy import UTCDateTime

    year = int(year)
    if year < 100:
        year += 1900 if year > 30 else 2000
    return UTCDateTime(year, int(month), int(day), int(hour), int(minute)) + float(second)


def _find(pattern: str, text: str, flags=re.I):
    m = re.search(pattern, text, flags)
    return m.groups() if m else None


# -- format parsers --------------------------------------------------------------------


_PEER_LINE4 = re.compile(r"NPTS\s*=\s*(?P<npts>[^,\s]+)\s*,?\s*DT\s*=\s*(?P<dt>\S+)", re.I)
_PEER_LINE4_WEST2 = re.compile(r"^\s*(?P<npts>\S+)\s+(?P<dt>\S+)\s+NPTS\s*,\s*DT", re.I)


def _parse_peer(path: Path, lines: list[str]) -> list[_Channel]:
    if len(lines) < 4:
        raise TruncatedRecordError(path, "PEER AT2 file ends inside its 4-line header")
    m = _PEER_LINE4.search(lines[3]) or _PEER_LINE4_WEST2.search(lines[3])
    if not m:
        raise RecordError(path, f"PEER AT2 line 4 has no 'NPTS=..., DT=...': {lines[3]!r}")
    npts_tok = m.group("npts")
    dt_tok = re.sub(r"(?i),?(sec|s)?,?$", "", m.group("dt"))
    if not npts_tok.isdigit():
        raise RecordError(path, f"PEER AT2 line 4: NPTS={npts_tok!r} is not a whole number: "
                          f"{lines[3].strip()!r}")
    if int(npts_tok) < 2:
        raise PointCountError(path, f"PEER AT2 line 4 states NPTS= {int(npts_tok)}: a record "
                              f"has at least 2 samples ({lines[3].strip()!r})")
    dt = _number(dt_tok)
    if dt is None:  # a number that is not a positive time step is said by _checked
        raise RecordError(path, f"PEER AT2 line 4: time step DT={_not_a_number(dt_tok)}: "
                          f"{lines[3].strip()!r}")
    if re.search(r"VELOCITY|DISPLACEMENT", lines[2], re.I):
        raise UnsupportedRecordError(path, "PEER file of velocity or displacement (.VT2/.DT2), "
                                     "not acceleration: read the .AT2 file")
    unit_m = re.search(r"UNITS OF\s+(\S+)", lines[2], re.I)
    unit = _unit_name(unit_m.group(1)) if unit_m else None
    if unit is None:
        quantity = _quantity_of(unit_m.group(1)) if unit_m else None
        raise (UnusualRecordError if quantity else RecordUnitError)(
            path, "PEER AT2 line 3 states " + (f"a unit of {quantity}, not acceleration: "
                                               if quantity else "an unknown unit: ")
            + repr(lines[2].strip()))
    if len(lines) < 5:
        raise TruncatedRecordError(path, f"PEER AT2 file ends after its 4-line header: no "
                                   f"samples, though line 4 states NPTS= {int(npts_tok)}")
    values = _values(path, lines[4:], 5, "PEER AT2")
    parts = [p.strip() for p in lines[1].split(",")]
    return [_Channel(values, unit, dt, npts_header=int(npts_tok),
                     station=parts[2] if len(parts) > 2 else "",
                     channel=_component(parts[-1]) if len(parts) > 1 else "",
                     note=lines[1].strip())]


def _quantity_of(unit_text: str) -> str | None:
    """The quantity a unit that is not an acceleration names (``CM/S``: velocity, ``CM``:
    displacement, ``COUNTS``), or None."""
    t = unit_text.strip().strip("()[],.;:").lower().replace(" ", "").replace("sec", "s")
    if re.fullmatch(r"(m|cm|mm|um|nm|in|ft)/s", t):
        return "velocity"
    if re.fullmatch(r"(m|cm|mm|um|nm|in|ft)", t):
        return "displacement"
    if t in ("counts", "count", "digits"):
        return "counts"
    return None


def _parse_geonet(path: Path, lines: list[str]) -> list[_Channel]:
    channels, i = [], 0
    while i < len(lines) and lines[i].strip():
        if i + 26 > len(lines):
            raise TruncatedRecordError(path, f"GeoNet file ends inside a header (line {i + 1})")
        text = "\n".join(lines[i:i + 16])
        ints = _fixed(path, lines[i + 16:i + 20], 8, first=i + 17).astype(int)
        reals = _fixed(path, lines[i + 20:i + 26], 8, first=i + 21)
        if len(ints) != 40 or len(reals) != 60:
            raise RecordError(path, f"GeoNet header at line {i + 1} is malformed")
        n_acc, n_vel, n_dis = ints[33], ints[34], ints[35]
        n_lines = [math.ceil(n / 10) for n in (n_acc, n_vel, n_dis)]
        start = i + 26
        if start + sum(n_lines) > len(lines):
            raise TruncatedRecordError(
                path, f"component {len(channels) + 1} announces {n_acc} accelerations (+ "
                f"{n_vel} velocities, {n_dis} displacements) but the file ends first")
        block = lines[start:start + n_lines[0]]
        values = _fixed(path, block, 8, first=start + 1)
        unit_m = _find(r"(?:units of [\d.]+ |peak\s+-?[\d.]+ )(mm/s/s|mm/s2)", text)
        peak = _find(r"Acceleration:\s+peak\s+(-?[\d.]+)", text)
        yr, mo, dy, hh, mi, ds = ints[:6]
        channels.append(_Channel(
            values, "mm/s2" if unit_m else None, float(reals[25]), npts_header=int(n_acc),
            station=_find(r"^Site\s+(\S+)", text, re.M)[0],
            network="NZ",
            channel=_component(_find(r"Component\s+(\S+)", text)[0]),
            starttime=_utc(yr, mo, dy, hh, mi, ds / 10.0) - float(reals[21]),
            header_peak=abs(float(peak[0])) if peak else None,
            note=lines[i].strip()))
        i = start + sum(n_lines)
    if not channels:
        raise TruncatedRecordError(path, "GeoNet file holds no channel")
    return channels


def _parse_cosmos(path: Path, lines: list[str]) -> list[_Channel]:
    text = "\n".join(lines[:60])
    if re.search(r"raw acceleration counts|units=\s*counts", text, re.I):
        raise UnsupportedRecordError(
            path, "COSMOS V0 file holds raw digitiser counts without the sensor sensitivity "
            "applied; read the corrected V2 (or V1) file instead")
    n_text = int(_find(r"with\s+(\d+)\s+text lines", lines[0])[0])
    i = n_text
    n_int, int_lines = map(int, _find(r"(\d+)\s+Integer-header values follow on\s+(\d+)",
                                      lines[i]))
    i += 1 + int_lines
    n_real, real_lines = map(int, _find(r"(\d+)\s+Real-header values follow on\s+(\d+)",
                                        lines[i]))
    width = int(_find(r"\(\d+F(\d+)\.", lines[i])[0])
    reals = _fixed(path, lines[i + 1:i + 1 + real_lines], width, first=i + 2)
    i += 1 + real_lines
    n_comment = int(_find(r"(\d+)\s+Comment line", lines[i])[0])
    comments = "\n".join(lines[i + 1:i + 1 + n_comment])
    i += 1 + n_comment
    head = lines[i]
    npts = int(_find(r"^\s*(\d+)", head)[0])
    stated = _find(r"units\s*=\s*([^(,]+)", head)[0]
    unit = _unit_name(stated)
    if unit is None and _quantity_of(stated):
        raise UnusualRecordError(path, f"COSMOS data header states units={stated.strip()} "
                                 f"({_quantity_of(stated)}), not an acceleration: read the "
                                 ".acc file of the record")
    per_line, width = map(int, _find(r"Format\s*=\s*\((\d+)[EF](\d+)", head))
    data = lines[i + 1:i + 1 + math.ceil(npts / per_line)]
    values = _fixed(path, data, width, first=i + 2)
    code = _find(r"Code:\s*(\w+)-(\w+)", text) or ("", "")
    scnl = _find(r"<SCNL>\s*(\w+)\.(\w+)\.", comments)
    start = _find(r"Rcrd start time:\s*(\d+)/(\d+)/(\d+)\s+(\d+):(\d+):([\d.]+)", text)
    peak = _find(r"Max\s*=\s*(-?[\d.]+)\s*cm/sec2", text)
    return [_Channel(values, unit, float(reals[61]) / 1000.0, npts_header=npts,
                     network=code[0], station=code[1], channel=scnl[1] if scnl else "",
                     starttime=_utc(*start) if start else None,
                     header_peak=abs(float(peak[0])) if peak and unit == "cm/s2" else None,
                     note=lines[0].strip())]


def _parse_smc(path: Path, lines: list[str]) -> list[_Channel]:
    kind = lines[0].strip()
    if kind.startswith("0"):
        raise UnsupportedRecordError(path, "SMC raw (type 0) file holds counts, not acceleration")
    if len(lines) < 28:
        raise TruncatedRecordError(path, "SMC file ends inside its header")
    ints = _fixed(path, lines[11:17], 10, first=12).astype(int)
    reals = _fixed(path, lines[17:27], 15, first=18)
    n_comment = int(ints[15])
    data = lines[27 + n_comment:]
    values = _fixed(path, data, 10, first=28 + n_comment)
    npts = int(ints[16])
    note = kind
    if values.size > npts:  # SMC readers take the announced count; report what is dropped
        note += f"; {values.size - npts} values after the announced {npts} ignored"
        values = values[:npts]
    text = "\n".join(lines[:11])
    station = lines[2].strip()
    comp = _find(r"component\s*=\s*(\S+)", text)
    peak = _find(r"pk(?: acc)?\s*=\s*(-?[\d.]+)", text)
    year, jday, hour, minute = ints[1:5]
    from obspy import UTCDateTime

    start = UTCDateTime(year=int(year), julday=int(jday), hour=int(hour), minute=int(minute))
    ch = _Channel(values, "cm/s2", None, npts_header=npts, station=station,
                  channel=_component(comp[0] + " deg") if comp else "", starttime=start,
                  header_peak=abs(float(peak[0])) if peak else None, note=note)
    rate = reals[1]
    if rate < 1e30:
        ch.dt = 1.0 / rate
    else:  # uncorrected film record: (time, accel) pairs
        _split_pairs(path, ch)
    return [ch]


def _split_pairs(path: Path, ch: _Channel) -> None:
    if ch.npts_header is not None and len(ch.values) == ch.npts_header:
        ch.npts_header //= 2  # header counted numbers, not pairs
    if len(ch.values) % 2:
        raise TruncatedRecordError(path, "(time, accel) pairs end with a lone value")
    ch.times, ch.values = ch.values[0::2], ch.values[1::2]


def _parse_dmg(path: Path, lines: list[str]) -> list[_Channel]:
    """CDMG/CSMIP Vol 1/Vol 2 and USC Vol 1/Vol 2 text (the same family of layouts)."""
    blocks, cur = [], []
    for ln in lines:
        if ln.startswith("/&"):
            blocks.append(cur)
            cur = []
        else:
            cur.append(ln)
    if any(ln.strip() for ln in cur):
        if blocks:  # CDMG/CSMIP files close every channel with a "/&" line
            raise TruncatedRecordError(
                path, f"channel {len(blocks) + 1} has no end-of-data '/&' line: file truncated")
        blocks.append(cur)
    return [_parse_dmg_block(path, b) for b in blocks if any(ln.strip() for ln in b)]


_DATA_HEAD = re.compile(
    r"^\s*(\d+)\s+(points of acc\w*|accelerogram points)(.*)$", re.I)


def _parse_dmg_block(path: Path, lines: list[str]) -> _Channel:
    text = "\n".join(lines[:40])
    comp = _find(r"(?:CHAN\s+\d+:|COMP)\s+([^\n]+)", text)
    station = _find(r"STATION(?: NO\.| USC#)\s*(\w+)", text)
    start = _find(r"(?:TRIGGER TIME|Start time|ORIGIN\(USGS\)):\s*"
                  r"(\d+)/(\d+)/(\d+),\s*(\d+):(\d+):([\d.]+)", text)
    ch = _Channel(np.empty(0), None, None, station=station[0] if station else "",
                  channel=_component(comp[0]) if comp else "",
                  note=lines[0].strip())
    if start:
        mo, dy, yr, hh, mi, ss = start
        ch.starttime = _utc(yr, mo, dy, hh, mi, ss)
    head_i = next((k for k, ln in enumerate(lines) if _DATA_HEAD.match(ln)), None)
    if head_i is not None:  # evenly spaced: "<n> points of accel data ... at <dt> sec"
        head = lines[head_i]
        ch.npts_header = int(_DATA_HEAD.match(head).group(1))
        spacing = _find(r"spaced at\s+([\d.]+)\s*sec", head)
        rate = _find(r"at\s+(\d+)\s*pts/sec", head)
        ch.dt = float(spacing[0]) if spacing else 1.0 / float(rate[0]) if rate else None
        unit = _find(r"(?:units:?|units of|in)\s+(g|cm/sec2|cm/sec/sec)\b", head)
        ch.unit = {"g": "g", "cm/sec2": "cm/s2", "cm/sec/sec": "cm/s2"}.get(
            unit[0].lower() if unit else "")
        data = []
        for ln in lines[head_i + 1:]:
            if re.search(r"[a-df-zA-DF-Z]", ln):  # next section header (velocity, ...)
                break
            data.append(ln)
        fmt = _find(r"\((\d+)f(\d+)\.\d+\)", head)
        offset, width = (0, int(fmt[1])) if fmt else _field_width(path, data[0] if data else "")
        ch.values = _fixed(path, data, width, offset)
        peak = _find(r"Peak acceleration\s*=\s*(-?[\d.]+)\s*cm", "\n".join(lines))
        max_g = _find(r"MAX\s*=\s*(-?[\d.]+)\s*G", text)
        if peak and ch.unit == "cm/s2":
            ch.header_peak = abs(float(peak[0]))
        elif max_g and ch.unit == "g":
            ch.header_peak = abs(float(max_g[0]))
        return ch
    # uneven (time, accel) pairs after the integer and real headers
    units = _find(r"UNITS (?:OF UNCOR ACCEL )?ARE SEC AND\s+(G/10|G)\b", text)
    if not units:
        raise UnknownFormatError(path, "CDMG/USC-style file without a data header or units line")
    ch.unit = units[0].lower()
    npts = _find(r"NO\. OF POINTS\s*=\s*(\d+)", text)
    ch.npts_header = int(npts[0]) if npts else None
    int_line = re.compile(r"^(\s*-?\d+){16}\s*$")
    k = next((k for k, ln in enumerate(lines) if int_line.match(ln)), None)
    if k is None:
        raise RecordError(path, "no integer header found in the CDMG/USC file")
    while k < len(lines) and re.fullmatch(r"[\s\d-]+", lines[k]):
        k += 1
    full = len(lines[k].rstrip())
    while k < len(lines) and len(lines[k].rstrip()) >= full:
        k += 1
    data = lines[k + 1:]
    ch.values = _fixed(path, data, *_field_width(path, data[0])[::-1]) if data else np.empty(0)
    ch.npts_header = None if ch.npts_header is None else 2 * ch.npts_header
    max_g = _find(r"MAX\s*=\s*(-?[\d.]+)\s*G", text)
    _split_pairs(path, ch)
    ch.header_peak = abs(float(max_g[0])) * (10.0 if ch.unit == "g/10" else 1.0) \
        if max_g else None
    return ch


def _one_line(exc: Exception) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def _parse_knet(path: Path, raw: bytes) -> list[_Channel]:
    import obspy

    try:
        st = obspy.read(io.BytesIO(raw), format="KNET")
    except Exception as exc:  # noqa: BLE001
        raise RecordError(path, f"K-NET/KiK-net file cannot be read: {_one_line(exc)}") from None
    out = []
    for tr in st:
        values = tr.data.astype(float) * tr.stats.calib * 100.0  # counts -> gal (cm/s2)
        values -= values.mean()  # K-NET counts carry an offset; the header peak is demeaned
        out.append(_Channel(values, "cm/s2", tr.stats.delta, npts_header=tr.stats.npts,
                            network=tr.stats.network, station=tr.stats.station,
                            channel=tr.stats.channel, starttime=tr.stats.starttime,
                            header_peak=tr.stats.knet.accmax,
                            note="counts x scale factor, mean removed"))
    return out


# statements of a time step in a comment line: the keyword, then an optional "=", ":",
# "is" or "of", then the value (which must then be a number)
_DT_STATEMENT = re.compile(
    r"\b(?:dt|delta|time[ -]?step|timestep|sampling interval|sample interval|spacing of)\b"
    r"\s*(?P<sep>=|:|\bis\b|\bof\b)?\s*(?P<value>[^\s;]*)\s*(?P<unit>\w*)", re.I)
_UNIT_STATEMENT = re.compile(r"\bunits?\b\s*(?P<sep>=|:|\bare\b|\bis\b|\bin\b|\bof\b)?"
                             r"(?P<rest>.*)", re.I)
_TIME_UNITS = {"": 1.0, "s": 1.0, "sec": 1.0, "secs": 1.0, "second": 1.0, "seconds": 1.0,
               "ms": 1e-3, "msec": 1e-3, "millisecond": 1e-3, "milliseconds": 1e-3}


def _comment_dt(path: Path, lineno: int, comment: str) -> tuple[float, str] | None:
    """The time step [s] a comment line states, with where it was said, or None; a
    statement whose value is not a number is refused (never read as part of one)."""
    found = []
    for m in _DT_STATEMENT.finditer(comment):
        value, unit = m.group("value").rstrip(",;)"), m.group("unit").lower()
        if not value and not m.group("sep"):
            continue
        glued = re.fullmatch(rf"({_FLOAT.pattern})([a-zA-Z]+)", value)
        if glued and glued.group(2).lower() in _TIME_UNITS:
            value, unit = glued.group(1), glued.group(2).lower()
        if not value[:1].isdigit() and value[:1] not in "+-." and not m.group("sep"):
            continue  # "time step computed later": not a statement of its value
        number = _number(value)
        if number is None:
            raise MissingTimeStepError(
                path, f"comment line {lineno} {comment!r} states a time step that cannot be "
                f"read: {_not_a_number(value)}; correct the comment, or remove it and pass "
                "dt= (--dt)")
        factor = _TIME_UNITS.get(unit, 1.0)
        found.append((number * factor, f"comment line {lineno}: {comment!r}"))
    if len({f[0] for f in found}) > 1:
        raise MissingTimeStepError(path, f"comment line {lineno} {comment!r} states two time "
                                   "steps")
    return found[0] if found else None


def _comment_unit(path: Path, lineno: int, comment: str) -> tuple[str, str] | None:
    """The unit a comment line states (``# units: g``, ``The units are (g)``), or None;
    a statement naming no known unit is refused."""
    m = _UNIT_STATEMENT.search(comment)
    if not m:
        return None
    for tok in m.group("rest").replace("(", " ").replace(")", " ").split():
        name = _unit_name(tok)
        if name is not None and name in UNIT_FACTORS:
            return name, f"comment line {lineno}: {comment!r}"
    if m.group("sep") or m.group("rest").strip(" :=") == "":
        raise RecordUnitError(path, f"comment line {lineno} {comment!r} states no unit urmx "
                              f"knows ({', '.join(UNIT_FACTORS)}, gal = cm/s2); correct the "
                              "comment or remove it and pass unit= (--unit)")
    return None


# -- plain number columns ---------------------------------------------------------------
# One acceleration per line (SLAMMER), several values per line, a (time, acceleration) pair
# per line, or an ordinary CSV file with one header row of names. The file is parsed in
# blocks of about a megabyte of text, so reading N samples holds the file's bytes, the
# samples (8N bytes) and, per line, its count of values and its number (6 bytes), never a
# Python object per value (README "Errors", rule 7). A header row names the columns: a
# time column (time, t; [s], (s), _s or _ms) and acceleration columns (acc, accel,
# acceleration, a; a unit in brackets or after an underscore: acc_g, acc [m/s2]); a
# column of another name is asked about, never guessed; several acceleration columns are
# one channel each (named by the header). Comments may state dt, a sampling rate (read as
# its step), the unit and the point count.

#: bytes of text parsed at a time
_BLOCK = 1 << 18

_TIME_NAME = re.compile(r"^(?:time|t)(?:[ _]*[\[(]?\s*(?P<u>s|sec|ms)\s*[\])]?)?$", re.I)
_ACC_NAME = re.compile(r"^(?:ground[ _]?acc(?:eleration)?|acceleration|accel|acc|ag|a)"
                       r"(?P<rest>.*)$", re.I)
_RATE_STATEMENT = re.compile(
    r"\b(?:sampling rate|sample rate|sampling frequency|samples per second|sps)\b"
    r"\s*(?P<sep>=|:|\bis\b|\bof\b)?\s*(?P<value>[^\s;]*)\s*(?P<unit>\w*)", re.I)


def _blocks(raw: bytes, encoding: str):
    """(number of the first line, lines) of the decoded text, a block at a time; blocks
    end at a line break, so line numbers are those of the whole text."""
    if encoding.startswith("utf-16"):  # rare: decode at once
        yield 1, _decode(raw, encoding).splitlines()
        return
    start, lineno = 0, 1
    if encoding == "utf-8-sig":
        start = 3
        encoding = "latin-1"
    n = len(raw)
    while start < n:
        end = raw.find(b"\n", min(start + _BLOCK, n))
        end = n if end < 0 else end + 1
        lines = raw[start:end].decode(encoding).splitlines()
        yield lineno, lines
        lineno += len(lines)
        start = end


def _header_names(line: str) -> list[str] | None:
    """The column names of a header row (comma-, semicolon- or tab-separated, or separated
    by spaces when no name holds one), or None when `line` is not a row of names."""
    s = line.strip()
    if not s or _is_numeric_line(s) or not re.match(r"[A-Za-z\"']", s):
        return None
    sep = "," if "," in s else ";" if ";" in s else "\t" if "\t" in s else None
    names = [n.strip().strip("\"'").strip() for n in (s.split(sep) if sep else s.split())]
    if not names or any(not n or not re.match(r"[A-Za-z]", n) for n in names):
        return None
    return names


def _column_kind(name: str) -> tuple[str, str | None] | None:
    """("time", unit) or ("acc", unit) of a column name, or None when the name says
    neither; a unit the name holds is returned as urmx names it (None: none)."""
    m = _TIME_NAME.match(name.strip())
    if m:
        return "time", (m.group("u") or "s").lower().replace("sec", "s")
    m = _ACC_NAME.match(name.strip())
    if not m:
        return None
    rest = m.group("rest").strip()
    if not rest:
        return "acc", None
    inner = re.fullmatch(r"[\[(]\s*(.+?)\s*[\])]", rest) or re.fullmatch(r"[_ ]+(.+)", rest)
    if inner:
        unit = _unit_name(inner.group(1))
        if unit is not None:
            return "acc", unit
        # acc_x, acc_ns_g: a component label, perhaps followed by a unit
        tail = re.fullmatch(r"(?:[A-Za-z0-9]+[_ ]+)?[\[(]?\s*(.+?)\s*[\])]?", inner.group(1))
        unit = _unit_name(tail.group(1)) if tail else None
        if unit is not None or re.fullmatch(r"[A-Za-z0-9]+", inner.group(1)):
            return "acc", unit
    return None


def _comment_rate(path: Path, lineno: int, comment: str) -> tuple[float, str] | None:
    """The time step [s] a comment stating a sampling rate gives (``# sampling rate = 100
    Hz`` -> 0.01 s), with where it was said, or None; a rate that is not a positive number
    is refused with the file, the line and the comment."""
    m = _RATE_STATEMENT.search(comment)
    if not m or (not m.group("value") and not m.group("sep")):
        return None
    value = m.group("value").rstrip(",;)")
    glued = re.fullmatch(r"([-+.\d][\d.eE+-]*)(hz|sps)", value, re.I)
    if glued:
        value = glued.group(1)
    rate = _number(value)
    if rate is None or not np.isfinite(rate) or rate <= 0:
        raise MissingTimeStepError(path, f"comment line {lineno} {comment!r} states a sampling "
                                   f"rate that is not a positive number ({value!r}); correct "
                                   "the comment, or remove it and pass dt= (--dt)")
    return 1.0 / rate, f"comment line {lineno}: {comment!r}"


def _parse_columns(path: Path, raw: bytes, encoding: str) -> list[_Channel]:
    """Plain number columns, a block of text at a time (section comment above)."""
    comments, names, head_line = [], None, None
    vals, widths, linenos, first = [], [], [], True
    for lineno, lines in _blocks(raw, encoding):
        if first:
            _decimal_commas(path, lines, lineno)
            first = False
        toks, w, nos = [], [], []
        for i, ln in enumerate(lines, lineno):
            s = ln.strip()
            if not s:
                continue
            if s[0] == "#":
                comments.append((i, s))
                continue
            if names is None and not w and not widths:
                names = _header_names(s)
                if names is not None:
                    head_line = i
                    continue
            r = s.replace(",", " ").replace(";", " ").split()
            toks += r
            w.append(len(r))
            nos.append(i)
        if toks:
            vals.append(_block_values(path, toks, w, nos))
            widths.append(np.array(w, dtype=np.int16))
            linenos.append(np.array(nos, dtype=np.int32))
    values = np.concatenate(vals) if len(vals) != 1 else vals[0]
    del vals
    w = np.concatenate(widths) if widths else np.empty(0, dtype=np.int16)
    nos = np.concatenate(linenos) if linenos else np.empty(0, dtype=np.int32)
    if values.size == 1:
        raise TruncatedRecordError(path, f"the file holds a single number ({values[0]:g}), not "
                                   "an acceleration history: is it the right file?")
    ch = _Channel(values, None, None, unit_from_file=False, note="plain numbers")
    _column_comments(path, ch, comments)
    if names is not None:
        return _headed(path, ch, names, head_line, w, nos)
    if w.size > 2 and bool((w == 2).all()) and _time_like(np.diff(values[0::2])):
        _time_column(path, ch, values[0::2], values[1::2], nos)
        ch.note = "plain numbers, (time, acceleration) columns"
    elif w.size > 2 and w.min() == w.max() >= 3 and \
            bool(np.all(np.diff(values[0::int(w[0])]) > 0)):
        k = int(w[0])
        raise RecordError(path, f"every line holds {k} numbers and the first column increases "
                          f"like a time: the columns are ambiguous (a time and {k - 1} "
                          "accelerations?), and urmx never guesses between acceleration "
                          "columns; give the file a header row naming them (e.g. time,acc_x_g,"
                          "acc_y_g) and choose one with channel= (--channel), or keep one "
                          "acceleration column")
    return [ch]


def _decimal_commas(path: Path, lines: list[str], lineno: int) -> None:
    """Refuse numbers written with a decimal comma (``0,005``), which a comma-separated
    reading would split in two: all of the first 50 data lines look like one."""
    body = [(i, s.strip()) for i, s in enumerate(lines, lineno)
            if s.strip() and not s.strip().startswith("#")][:50]
    if body and _header_names(body[0][1]) is not None:
        body = body[1:]
    if body and all(_DECIMAL_COMMA.fullmatch(s) for _, s in body):
        raise RecordError(path, f"line {body[0][0]}: {_not_a_number(body[0][1])}")


def _block_values(path: Path, toks: list[str], w: list[int], nos: list[int]) -> np.ndarray:
    """The numbers of a block's tokens; a token that is not one is named with its line."""
    try:
        return np.array(toks, dtype=float)
    except ValueError:
        k = 0
        for n, i in zip(w, nos, strict=True):
            bad = next((tk for tk in toks[k:k + n] if not _safe_float(tk)), None)
            if bad is not None:
                raise RecordError(path, f"line {i} is not numbers: {' '.join(toks[k:k + n])[:80]!r}"
                                  f" ({_not_a_number(bad)})") from None
            k += n
        raise


def _column_comments(path: Path, ch: _Channel, comments: list[tuple[int, str]]) -> None:
    """The time step (or sampling rate), unit and point count the comment lines state."""
    dts = [d for i, c in comments for d in (_comment_dt(path, i, c), _comment_rate(path, i, c))
           if d]
    units = [u for u in (_comment_unit(path, i, c) for i, c in comments) if u]
    for found, what in ((dts, "time steps"), (units, "units")):
        if len({f[0] for f in found}) > 1:
            raise (MissingTimeStepError if what == "time steps" else RecordUnitError)(
                path, f"comments state two {what}: {found[0][1]} and {found[1][1]}")
    if dts:
        ch.dt, ch.extra["dt_source"] = dts[0]
    if units:
        ch.unit, ch.extra["unit_source"] = units[0]
        ch.unit_from_file = True
    n_head = _find(r"(\d+)\s+points", "\n".join(c for _, c in comments))
    if n_head:
        ch.extra["npts_comment"] = int(n_head[0])


def _time_column(path: Path, ch: _Channel, t: np.ndarray, a: np.ndarray,
                 nos: np.ndarray) -> None:
    """Make `t` [s] the channel's sample times and `a` its values; the times must be
    finite and increase strictly (the first bad one is named with its line)."""
    if not np.isfinite(t).all():
        k = int(np.argmax(~np.isfinite(t)))
        raise NonFiniteError(path, f"line {nos[k]}: time {t[k]} is not finite")
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0))
        raise RecordError(
            path, f"line {nos[k + 1]}: time {t[k + 1]:g} s does not increase "
            f"(line {nos[k]} has {t[k]:g} s); the first column of a (time, "
            "acceleration) file must increase strictly")
    ch.times, ch.values = t, a


def _headed(path: Path, ch: _Channel, names: list[str], head_line: int, w: np.ndarray,
            nos: np.ndarray) -> list[_Channel]:
    """The channels of a file with a header row: one per acceleration column, with the
    unit its name states, the time column's times (section comment above)."""
    k = len(names)
    off = np.flatnonzero(w != k)
    if off.size:
        raise RecordError(path, f"line {nos[off[0]]} holds {w[off[0]]} values but the header "
                          f"row (line {head_line}) names {k} columns: {', '.join(names)}")
    kinds = [_column_kind(n) for n in names]
    unknown = [n for n, kd in zip(names, kinds, strict=True) if kd is None]
    if unknown:
        raise RecordError(path, f"the header row (line {head_line}) names a column "
                          f"{unknown[0]!r} that is neither time nor acceleration: name it time "
                          "or t (time [s], t_ms) or acc, acceleration (with its unit: acc_g, "
                          "acc [m/s2], acceleration (cm/s2)), or remove the column")
    times = [i for i, kd in enumerate(kinds) if kd[0] == "time"]
    accs = [i for i, kd in enumerate(kinds) if kd[0] == "acc"]
    if len(times) > 1 or not accs:
        what = "two time columns" if len(times) > 1 else "no acceleration column"
        raise RecordError(path, f"the header row (line {head_line}) names {what}: "
                          f"{', '.join(names)}")
    table = ch.values.reshape(-1, k)
    out = []
    for i in accs:
        c = _Channel(np.ascontiguousarray(table[:, i]), ch.unit, ch.dt,
                     channel=names[i] if len(accs) > 1 else "",
                     unit_from_file=ch.unit_from_file, extra=dict(ch.extra),
                     note=f"columns named in a header row: {', '.join(names)}")
        unit = kinds[i][1]
        if unit is not None:
            if ch.unit is not None and ch.unit != unit:
                raise RecordUnitError(path, f"column {names[i]!r} states unit {unit!r} but "
                                      f"{ch.extra['unit_source']} states {ch.unit!r}")
            c.unit, c.unit_from_file = unit, True
            c.extra["unit_source"] = f"column name {names[i]!r}, line {head_line}"
        if times:
            j = times[0]
            scale = 1e-3 if kinds[j][1] == "ms" else 1.0
            _time_column(path, c, table[:, j] * scale, c.values, nos)
        out.append(c)
    return out


def _time_like(steps: np.ndarray) -> bool:
    """Whether a first column with these differences is a time column: it increases
    throughout (however unevenly), or nearly all its steps (a duplicate or reversal aside)
    lie within half of the median step, which is not zero; acceleration values in pairs
    go up and down instead."""
    with np.errstate(invalid="ignore"):
        if np.all(steps > 0):
            return True
        med = float(np.median(steps))
        return med != 0.0 and bool(np.mean(np.abs(steps - med) <= 0.5 * abs(med)) >= 0.9)


def _parse_obspy(path: Path, format: str | None, raw: bytes,
                 response: str | os.PathLike | None = None) -> list[_Channel]:
    """The traces of a file in one of ObsPy's formats, each with what its header says it
    is not (`urmx.records.checks.quantity_problems`: a velocity, a seismometer, counts);
    with `response` (a StationXML file) the instrument response is removed to
    acceleration [m s-2]."""
    import obspy


    if format is None or format.upper() not in OBSPY_FORMATS:  # never auto-detect
        raise UnknownFormatError(path, f"ObsPy format {format!r} is not one urmx reads")
    try:
        st = obspy.read(io.BytesIO(raw), format=format.upper())
    except Exception as exc:  # noqa: BLE001
        raise UnknownFormatError(path, f"ObsPy cannot read it as {format}: "
                                 f"{_one_line(exc)}") from None
    inventory = None if response is None else _inventory(path, response)
    out = []
    for tr in st:
        problems = quantity_problems(tr.stats, inventory is not None)
        note, unit = f"read by ObsPy ({format.upper()})", None
        counts = counts_problem(tr.data.dtype, inventory is not None)
        if counts:
            problems.append(counts)
        if inventory is not None:
            try:
                tr.remove_response(inventory=inventory, output="ACC")
            except Exception as exc:  # noqa: BLE001
                raise RecordError(path, f"the response in {str(response)!r} cannot be removed "
                                  f"from {tr.id}: {_one_line(exc)}") from None
            note, unit = note + f", response of {Path(response).name} removed (ACC)", "m/s2"
        out.append(_Channel(tr.data.astype(float), unit, tr.stats.delta,
                            network=tr.stats.network, station=tr.stats.station,
                            channel=tr.stats.channel, starttime=tr.stats.starttime,
                            unit_from_file=unit is not None, note=note,
                            extra={"dt_source": f"{format.upper()} header",
                                   "unit_source": f"response {Path(str(response)).name}",
                                   "unit_confirmed": inventory is not None,
                                   "problems": problems}))
    return out


def _inventory(path: Path, response: str | os.PathLike):
    """The StationXML (or other ObsPy inventory) file `response`, read, or a one-line
    error naming it."""
    import obspy

    if not Path(response).is_file():
        raise MissingFileError(f"response file {str(response)!r} (for {path}) does not exist")
    try:
        return obspy.read_inventory(str(response))
    except Exception as exc:  # noqa: BLE001
        raise RecordError(path, f"the response file {str(response)!r} cannot be read as "
                          f"StationXML: {_one_line(exc)}") from None


_PARSERS = {"peer": _parse_peer, "geonet": _parse_geonet, "cosmos": _parse_cosmos,
            "smc": _parse_smc, "dmg": _parse_dmg, "knet": _parse_knet,
            "columns": None}  # read in blocks: _parse_columns


# -- the one builder: checks, units, resampling, provenance ----------------------------


@dataclass
class Samples:
    """One channel of a record as checked numbers, before it becomes an ObsPy Trace
    (:func:`read_samples`; reading without ObsPy, for the command line's quick path)."""

    data: np.ndarray  # acceleration [m s-2]
    dt: float  # time step [s]
    station: str
    network: str
    channel: str
    starttime: object
    record: dict  # format, file, unit in the file, header peak [m s-2], uneven
    processing: list[str]

    def trace(self):
        """The channel as an :class:`obspy.Trace` (the form :func:`read` returns)."""
        from obspy import Trace, UTCDateTime
        from obspy.core.util import AttribDict

        tr = Trace(data=self.data)
        tr.stats.delta = self.dt
        tr.stats.network = self.network
        tr.stats.station = self.station
        tr.stats.channel = self.channel
        tr.stats.starttime = self.starttime if self.starttime is not None else UTCDateTime(0)
        tr.stats.units = "m/s2"
        tr.stats.record = AttribDict(self.record)
        tr.stats.processing = list(self.processing)
        return tr


def _checked(path: Path, fmt: str, ch: _Channel, dt: float | None, unit: str | None,
             allow_unusual: bool = False) -> Samples:
    name = path.name
    label = f"channel {ch.channel!r}" if ch.channel else "the record"
    values = np.asarray(ch.values, dtype=float)
    if values.size == 0:
        raise TruncatedRecordError(path, f"{label} holds no samples")
    n_expected = ch.npts_header
    if n_expected is not None and values.size != n_expected:
        cls = TruncatedRecordError if values.size < n_expected else PointCountError
        what = "pairs" if ch.times is not None else "points"
        raise cls(path, f"header of {label} announces {n_expected} {what} but the file holds "
                  f"{values.size}" + (" (file truncated?)" if cls is TruncatedRecordError
                                      else " (wrong point count in the header)"))
    if values.size < 2:
        raise TruncatedRecordError(path, f"{label} holds a single sample ({values[0]:g}), not "
                                   "an acceleration history")
    check_finite(values, label, path=path)
    overrides = [_unusual(path, f"{label}: {problem}", allow_unusual)
                 for problem in ch.extra.get("problems", ())]
    # units: a unit stated by the file and given by the caller must agree
    unit_source = ch.extra.get("unit_source", "header")
    if ch.unit is not None and ch.unit_from_file:
        if unit is not None and unit != ch.unit:
            raise RecordUnitError(path, f"file states unit {ch.unit!r} ({unit_source}) but "
                                  f"unit={unit!r} was given; leave unit unset for files that "
                                  "state it")
        file_unit = ch.unit
    else:
        file_unit = unit or ch.unit
    if file_unit is None:
        raise RecordUnitError(path, f"{fmt} file does not state its unit; pass unit= one of "
                              f"{sorted(UNIT_FACTORS)} (--unit on the command line)")
    processing = [f"urmx.records.read: {fmt} file {name!r} ({ch.note})"]
    dt_source = ch.extra.get("dt_source", "header")
    if ch.dt is not None and dt is not None and not math.isclose(ch.dt, dt, rel_tol=1e-6):
        raise MissingTimeStepError(path, f"file states dt={ch.dt:g} s ({dt_source}) but "
                                   f"dt={dt} was given")
    if ch.times is None:
        step = ch.dt if ch.dt is not None else dt
        if step is None:
            raise MissingTimeStepError(path, f"{fmt} file does not carry its time step; "
                                       "pass dt= in seconds (--dt on the command line; "
                                       "SLAMMER files: see EQdata.txt)")
        n_comment = ch.extra.get("npts_comment")
        if n_comment is not None and n_comment != values.size:
            warnings.warn(f"{path}: header comment says {n_comment} points but the file holds "
                          f"{values.size}; all {values.size} values are used", UrmxWarning,
                          stacklevel=4)
            processing.append(f"urmx: header comment said {n_comment} points, "
                              f"used all {values.size}")
    elif np.allclose(np.diff(ch.times), ch.times[1] - ch.times[0], rtol=1e-6, atol=0):
        step = float(ch.times[1] - ch.times[0])  # a time column with an even step
        given = dt if dt is not None else ch.dt
        if given is not None and not math.isclose(given, step, rel_tol=1e-6):
            src = "was given" if dt is not None else f"is stated ({dt_source})"
            raise MissingTimeStepError(path, f"the time column has an even step of {step:g} s "
                                       f"but dt={given:g} {src}")
        processing.append(f"urmx: time column evenly spaced, dt={step:g} s")
    else:
        values, step, msg = _resample_uneven(path, ch.times, values, dt if dt is not None
                                             else ch.dt)
        warnings.warn(f"{path}: {label} {msg}", UrmxWarning, stacklevel=4)
        processing.append(f"urmx: {msg}")
    if not (math.isfinite(step) and step > 0):
        raise MissingTimeStepError(path, f"{label} has time step dt={step!r} s; a time step "
                                   "must be a positive number of seconds")
    factor = _HEADER_UNITS[file_unit]
    data = values * factor
    if file_unit != "m/s2":
        processing.append(f"urmx: unit {file_unit} -> m/s2 (x {factor:g})")
    src = unit_source if ch.unit_from_file and ch.unit else "given"
    processing += overrides + _plausible(path, label, ch, values, data, float(step),
                                         (file_unit, src, dt_source), allow_unusual)
    record = dict(format=fmt, file=str(path), unit_in_file=file_unit,
                  header_pga=None if ch.header_peak is None else ch.header_peak * factor,
                  uneven=ch.times is not None)
    return Samples(data, float(step), ch.station or path.stem, (ch.network or "")[:8],
                   ch.channel or "", ch.starttime, record, processing)


def _unusual(path: Path, problem: str, allow_unusual: bool) -> str:
    """Refuse a record for `problem` (`UnusualRecordError`), or with ``allow_unusual`` the
    processing step that says it was overridden (kept in a study archive's
    ``record_processing``)."""
    if not allow_unusual:
        raise UnusualRecordError(path, problem + _ALLOW)
    return f"urmx: allow_unusual overrode: {problem}"


def _plausible(path: Path, label: str, ch: _Channel, values: np.ndarray, data: np.ndarray,
               step: float, how: tuple[str, str, str], allow_unusual: bool) -> list[str]:
    """The checks of a record's time step, PGA, velocity and displacement and of its
    stated unit against its values (`urmx.records.checks`); each problem refuses the
    record, or with ``allow_unusual`` becomes an ``overrode`` processing step (returned).
    `how`: (unit of the values, where it comes from, where the time step comes from)."""
    file_unit, src, dt_source = how
    out = []
    lo, hi = DT_RANGE
    if not lo <= step <= hi:
        where = "given" if ch.dt is None and ch.times is None else \
            "of the time column" if ch.times is not None else f"from the {dt_source}"
        hint = (" (milliseconds given as seconds?)" if lo <= step / 1000 <= hi and step > hi
                else " (implausibly small)" if step < lo else "")
        out.append(_unusual(path, f"{label} has time step dt={step:g} s ({where}), outside "
                            f"the {lo:g}-{hi:g} s of strong-motion records{hint}",
                            allow_unusual))
    peak = float(np.max(np.abs(values)))
    factor = _HEADER_UNITS[file_unit]
    pga_g = peak * factor / STANDARD_GRAVITY
    lo, hi = PGA_RANGE_G
    if not lo <= pga_g <= hi:
        if peak == 0.0:
            return out + [_unusual(path, f"every sample of {label} is zero", allow_unusual)]
        fits = [f"as {u}: {peak * f / STANDARD_GRAVITY:.3g} g"
                for u, f in UNIT_FACTORS.items()
                if u != file_unit and lo <= peak * f / STANDARD_GRAVITY <= hi]
        hint = f" ({'; '.join(fits)})" if fits else ""
        verdict = ("the unit is wrong" if pga_g > hi else
                   "the unit is likely wrong, or the channel holds no strong motion")
        out.append(_unusual(path, f"{label} would have PGA {pga_g:.3g} g with unit "
                            f"{file_unit!r} ({src}), outside the {lo:g}-{hi:g} g of "
                            f"strong-motion records: {verdict}{hint}", allow_unusual))
    elif src != "given":
        confirmed = ch.header_peak is not None or bool(ch.extra.get("unit_confirmed"))
        problem = unit_problem(peak, file_unit, src, confirmed)
        if problem:
            out.append(_unusual(path, f"{label}: {problem}", allow_unusual))
    problem = motion_problem(data, step, f"with unit {file_unit!r} ({src})")
    if problem:
        out.append(_unusual(path, f"{label}: {problem}", allow_unusual))
    return out


def check_finite(data, label: str = "record", dt: float | None = None,
                 path: str | os.PathLike | None = None) -> np.ndarray:
    """`data` as a float64 array, or a :class:`NonFiniteError` naming the first NaN or
    infinite sample (its index, and time [s] when `dt` is given) and how many there are.

    Use it wherever samples arrive from outside (a Trace, an array): a NaN must be named as
    such, never taken for a zero.

    Parameters
    ----------
    data : array_like of float
        The samples. [any unit: they are only checked]
    label : str
        What the samples are, for the message (``"record"``).
    dt : float, optional
        Their time step, to name the time of the first bad sample. [s]
    path : str or path-like, optional
        The file they came from, for the message.
    """
    values = numbers_argument(label, "samples", data)
    bad = ~np.isfinite(values)
    if bad.any():
        k = int(np.argmax(bad))
        at = f", t = {k * dt:g} s" if dt else ""
        raise NonFiniteError(path, f"{label} has {int(bad.sum())} NaN or infinite samples of "
                             f"{values.size}, the first at index {k} ({float(values.flat[k])}"
                             f"{at})")
    return values


def _resample_uneven(path: Path, times: np.ndarray, values: np.ndarray, dt: float | None):
    times = np.asarray(times, dtype=float)
    steps = np.diff(times)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0))
        raise RecordError(path, f"time column does not increase at sample {k + 1} "
                          f"(t={times[k]} then {times[k + 1]})")
    mean = float(steps.mean())
    step = dt if dt is not None else max(d for d in _NICE_DT if d <= mean * 1.05) \
        if mean >= _NICE_DT[0] else mean
    t_new = times[0] + np.arange(int(np.floor((times[-1] - times[0]) / step + 1e-9)) + 1) * step
    out = np.interp(t_new, times, values)
    msg = (f"unevenly sampled (steps {steps.min():.5f}-{steps.max():.5f} s, mean {mean:.5f} s); "
           f"resampled by linear interpolation to dt={step:g} s ({t_new.size} points)")
    return out, step, msg
