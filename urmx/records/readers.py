"""Readers: accelerogram files of many formats -> :class:`obspy.Stream` in m s-2.

The format is found from the file's content (:func:`detect_format`), not its name. Each
format parser returns plain :class:`_Channel` objects; one builder (:func:`_to_trace`)
checks them (point count, NaN, unit plausibility), converts to m s-2, resamples uneven
time steps (with a :class:`urmx.UrmxWarning`) and writes every step to
``stats.processing``.

Supported: PEER NGA ``.AT2``; GeoNet ``.V1A``/``.V2A``; COSMOS V1/V2 (``.V1c``/``.V2c``;
the raw-count ``V0c`` is refused); CDMG/CSMIP and USC Vol 1/Vol 2 text (including the
film records' unevenly spaced (time, accel) pairs); USGS SMC; K-NET/KiK-net ASCII (via
ObsPy); plain number columns (SLAMMER single column, several values per line, ``#``
header lines, two-column time/accel); and the ObsPy formats of `OBSPY_FORMATS`.

Only formats whose readers parse data are ever tried: ObsPy's ``PICKLE`` format unpickles
the file (which can run any code), so it is neither detected nor accepted by name, and a
file that looks like a Python pickle is refused before ObsPy sees it.
"""

from __future__ import annotations

import math
import os
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..config import UrmxWarning
from ..errors import MissingFileError
from .errors import (
    MissingTimeStepError,
    NonFiniteError,
    PointCountError,
    RecordError,
    RecordUnitError,
    TruncatedRecordError,
    UnknownFormatError,
    UnsupportedRecordError,
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

#: largest believable peak ground acceleration [g]; above it the unit is surely wrong
MAX_PLAUSIBLE_PGA_G = 10.0

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
_ALIASES = {"at2": "peer", "nga": "peer", "v1a": "geonet", "v2a": "geonet", "csmip": "dmg",
            "cdmg": "dmg", "usc": "dmg", "kiknet": "knet", "slammer": "columns",
            "plain": "columns", "text": "columns"}
_FLOAT = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


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


# -- public entry point ----------------------------------------------------------------


def read(path: str | os.PathLike, format: str | None = None, dt: float | None = None,
         unit: str | None = None):
    """Read an accelerogram file into an :class:`obspy.Stream` in m s-2.

    Parameters
    ----------
    path : str or path-like
        The record file.
    format : str, optional
        One of ``FORMATS`` (aliases ``at2``, ``v2a``, ``csmip``, ``usc``, ``slammer``, ...)
        or an ObsPy format name of ``OBSPY_FORMATS`` (``MSEED``, ``SAC``, ...). Found from
        the content if omitted. Python pickles are never read.
    dt : float, optional
        Time step [s] for files that do not carry it (plain columns). For files that
        do, it must agree with the header; for uneven records it is the resampling step.
    unit : {"g", "m/s2", "cm/s2", "mm/s2"}, optional
        Unit of the values, for files that do not state it; must agree with the header
        where the file states one.

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
        A :class:`ValueError` subclass naming the file and the problem: unknown format,
        truncated file, wrong point count, NaN, missing or non-positive dt, unit mistakes,
        raw counts, a Python pickle.
    urmx.errors.MissingFileError
        The file does not exist (a :class:`FileNotFoundError`).
    """
    from obspy import Stream

    return Stream([c.trace() for c in read_samples(path, format, dt, unit)])


def read_samples(path: str | os.PathLike, format: str | None = None, dt: float | None = None,
                 unit: str | None = None) -> list[Samples]:
    """:func:`read` without ObsPy: the checked channels as :class:`Samples` (data in m s-2,
    dt, header fields, provenance). Same arguments, checks and errors as :func:`read`;
    only ObsPy's own formats import ObsPy."""
    path = Path(path)
    if not path.is_file():
        raise MissingFileError(f"record file {str(path)!r} does not exist")
    if unit is not None and unit not in UNIT_FACTORS:
        raise RecordUnitError(path, f"unit {unit!r} is not one of {sorted(UNIT_FACTORS)}")
    if dt is not None and not (np.isfinite(dt) and dt > 0):
        raise MissingTimeStepError(path, f"dt must be a positive number of seconds, got {dt!r}")
    if format is None:
        fmt = detect_format(path)
        obspy_format = _detect_obspy(path) if fmt == "obspy" else None
    else:
        fmt = _ALIASES.get(format.lower(), format.lower())
        obspy_format = None if fmt in _PARSERS else format.upper()
        if obspy_format is not None and obspy_format not in OBSPY_FORMATS:
            why = (" (ObsPy's PICKLE reader unpickles the file, which can run any code)"
                   if obspy_format == "PICKLE" else "")
            raise UnsupportedRecordError(
                path, f"format {format!r} is not read by urmx{why}; formats: "
                f"{', '.join(FORMATS)} or ObsPy's {', '.join(OBSPY_FORMATS)}")
    if fmt in _PARSERS:
        text = _read_text(path)
        channels = _PARSERS[fmt](path, text.splitlines())
    else:
        channels = _parse_obspy(path, obspy_format)
    return [_checked(path, fmt, ch, dt, unit) for ch in channels]


def detect_format(path: str | os.PathLike) -> str:
    """Find a record file's format from its content.

    Parameters
    ----------
    path : str or path-like
        The record file.

    Returns
    -------
    str
        One of ``FORMATS`` or ``"obspy"`` (a file :func:`obspy.read` recognises).

    Raises
    ------
    UnknownFormatError
        The content matches no supported format.
    UnsupportedRecordError
        A recognised file that holds no acceleration history (e.g. CSMIP Vol 3 spectra),
        or a Python pickle.
    """
    path = Path(path)
    with open(path, "rb") as fh:
        head = fh.read(6000)
    if not head.strip():
        raise UnknownFormatError(path, "file is empty")
    if _looks_like_pickle(head):
        raise UnsupportedRecordError(
            path, "file is a Python pickle: urmx never reads pickles, since unpickling can "
            "run any code; convert the record to MiniSEED, SAC or text")
    if b"\x00" in head:
        return _obspy_or_unknown(path)
    text = head.decode("latin-1")
    lines = text.splitlines()
    first = lines[0] if lines else ""
    top = "\n".join(lines[:6])
    if "PEER NGA" in first.upper() or re.search(r"NPTS\s*=\s*\d+\s*,\s*DT\s*=", top, re.I):
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
    body = [ln for ln in lines[:-1] if ln.strip() and not ln.lstrip().startswith("#")]
    if body and all(_is_numeric_line(ln) for ln in body[:200]):
        return "columns"
    return _obspy_or_unknown(path)


# -- helpers ---------------------------------------------------------------------------


def _read_text(path: Path) -> str:
    return path.read_bytes().decode("latin-1")


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


def _obspy_or_unknown(path: Path) -> str:
    if _detect_obspy(path) is None:
        raise UnknownFormatError(
            path, "unknown record format: not PEER AT2, GeoNet V1A/V2A, COSMOS, CDMG/CSMIP, "
            "USC, SMC, K-NET, plain numbers or an ObsPy format urmx reads "
            f"({', '.join(OBSPY_FORMATS)})")
    return "obspy"


def _fixed(path: Path, lines: list[str], width: int, offset: int = 0) -> np.ndarray:
    """Numbers in fixed-width fields (values may touch, so never split on spaces)."""
    out = []
    for ln in lines:
        ln = ln.rstrip()
        for i in range(offset, len(ln), width):
            tok = ln[i:i + width].strip()
            if tok:
                out.append(tok)
    try:
        return np.array(out, dtype=float)
    except ValueError:
        bad = next(t for t in out if not _safe_float(t))
        raise RecordError(path, f"cannot read {bad!r} as a number") from None


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


def _parse_peer(path: Path, lines: list[str]) -> list[_Channel]:
    if len(lines) < 5:
        raise TruncatedRecordError(path, "PEER AT2 file ends inside its 4-line header")
    m = re.search(r"NPTS\s*=\s*(\d+)\s*,\s*DT\s*=\s*([\d.Ee+-]+)", lines[3], re.I)
    if not m:
        raise RecordError(path, f"PEER AT2 line 4 has no 'NPTS=..., DT=...': {lines[3]!r}")
    unit_m = re.search(r"UNITS OF\s+(\S+)", lines[2], re.I)
    unit = unit_m.group(1).lower() if unit_m else None
    if unit not in _HEADER_UNITS:
        raise RecordUnitError(path, f"PEER AT2 header states an unknown unit: {lines[2]!r}")
    try:
        values = np.array(" ".join(lines[4:]).split(), dtype=float)
    except ValueError:
        raise RecordError(path, "PEER AT2 data contain a value that is not a number") from None
    parts = [p.strip() for p in lines[1].split(",")]
    return [_Channel(values, unit, float(m.group(2)), npts_header=int(m.group(1)),
                     station=parts[2] if len(parts) > 2 else "",
                     channel=_component(parts[-1]) if len(parts) > 1 else "",
                     note=lines[1].strip())]


def _parse_geonet(path: Path, lines: list[str]) -> list[_Channel]:
    channels, i = [], 0
    while i < len(lines) and lines[i].strip():
        if i + 26 > len(lines):
            raise TruncatedRecordError(path, f"GeoNet file ends inside a header (line {i + 1})")
        text = "\n".join(lines[i:i + 16])
        ints = _fixed(path, lines[i + 16:i + 20], 8).astype(int)
        reals = _fixed(path, lines[i + 20:i + 26], 8)
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
        values = _fixed(path, block, 8)
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
    reals = _fixed(path, lines[i + 1:i + 1 + real_lines], width)
    i += 1 + real_lines
    n_comment = int(_find(r"(\d+)\s+Comment line", lines[i])[0])
    comments = "\n".join(lines[i + 1:i + 1 + n_comment])
    i += 1 + n_comment
    head = lines[i]
    npts = int(_find(r"^\s*(\d+)", head)[0])
    unit_text = _find(r"units\s*=\s*([^(,]+)", head)[0].strip().lower()
    unit = {"cm/sec2": "cm/s2", "cm/s/s": "cm/s2", "g": "g", "mm/sec2": "mm/s2",
            "m/sec2": "m/s2"}.get(unit_text)
    per_line, width = map(int, _find(r"Format\s*=\s*\((\d+)[EF](\d+)", head))
    data = lines[i + 1:i + 1 + math.ceil(npts / per_line)]
    values = _fixed(path, data, width)
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
    ints = _fixed(path, lines[11:17], 10).astype(int)
    reals = _fixed(path, lines[17:27], 15)
    n_comment = int(ints[15])
    data = lines[27 + n_comment:]
    values = _fixed(path, data, 10)
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


def _parse_knet(path: Path, lines: list[str]) -> list[_Channel]:
    import obspy

    try:
        st = obspy.read(str(path), format="KNET")
    except Exception as exc:  # noqa: BLE001
        raise RecordError(path, f"K-NET/KiK-net file cannot be read: {exc}") from None
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


def _parse_columns(path: Path, lines: list[str]) -> list[_Channel]:
    comments = "\n".join(ln for ln in lines if ln.lstrip().startswith("#"))
    body = [ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
    rows = [ln.replace(",", " ").split() for ln in body]
    try:
        values = np.array([v for r in rows for v in r], dtype=float)
    except ValueError:
        bad = next(ln for ln in body if not _is_numeric_line(ln))
        raise RecordError(path, f"line {bad.strip()!r} is not numbers") from None
    ch = _Channel(values, None, None, unit_from_file=False, note="plain numbers")
    n_head = _find(r"(\d+)\s+points", comments)
    dt_head = _find(r"spacing of\s+([\d.]+)\s*sec", comments) or _find(r"dt\s*=\s*([\d.]+)",
                                                                         comments)
    unit_head = _find(r"units? (?:are|is|:)\s*\(?\s*(g|m/s2|cm/s2|mm/s2|gal)\b", comments)
    if dt_head:
        ch.dt = float(dt_head[0])
    if unit_head:
        ch.unit = {"gal": "cm/s2"}.get(unit_head[0].lower(), unit_head[0].lower())
        ch.unit_from_file = True
    if n_head:
        ch.extra["npts_comment"] = int(n_head[0])
    if rows and all(len(r) == 2 for r in rows) and not comments:
        t = values[0::2]
        if len(t) > 2 and np.all(np.diff(t) > 0):  # two columns: time [s], accel
            ch.times, ch.values = t, values[1::2]
    return [ch]


def _parse_obspy(path: Path, format: str | None) -> list[_Channel]:
    import obspy

    if format is None or format.upper() not in OBSPY_FORMATS:  # never auto-detect
        raise UnknownFormatError(path, f"ObsPy format {format!r} is not one urmx reads")
    try:
        st = obspy.read(str(path), format=format.upper())
    except Exception as exc:  # noqa: BLE001
        raise UnknownFormatError(path, f"ObsPy cannot read it as {format or 'any format'}: "
                                 f"{exc}") from None
    return [_Channel(tr.data.astype(float), None, tr.stats.delta, network=tr.stats.network,
                     station=tr.stats.station, channel=tr.stats.channel,
                     starttime=tr.stats.starttime, unit_from_file=False,
                     note=f"read by ObsPy ({tr.stats._format})") for tr in st]


_PARSERS = {"peer": _parse_peer, "geonet": _parse_geonet, "cosmos": _parse_cosmos,
            "smc": _parse_smc, "dmg": _parse_dmg, "knet": _parse_knet,
            "columns": _parse_columns}


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


def _checked(path: Path, fmt: str, ch: _Channel, dt: float | None, unit: str | None
             ) -> Samples:
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
    bad = ~np.isfinite(values)
    if bad.any():
        raise NonFiniteError(path, f"{label} has {int(bad.sum())} NaN/infinite values "
                             f"(first at sample {int(np.argmax(bad))})")
    # units: the file's statement wins; a contradicting argument is a mistake
    if ch.unit is not None and ch.unit_from_file:
        if unit is not None and unit != ch.unit:
            raise RecordUnitError(path, f"file states unit {ch.unit!r} but unit={unit!r} was "
                                  "given; leave unit unset for files that state it")
        file_unit = ch.unit
    else:
        file_unit = unit or ch.unit
    if file_unit is None:
        raise RecordUnitError(path, f"{fmt} file does not state its unit; pass unit= one of "
                              f"{sorted(UNIT_FACTORS)} (--unit on the command line)")
    processing = [f"urmx.records.read: {fmt} file {name!r} ({ch.note})"]
    if ch.times is None:
        if ch.dt is not None and dt is not None and not math.isclose(ch.dt, dt, rel_tol=1e-6):
            raise MissingTimeStepError(path, f"file states dt={ch.dt} s but dt={dt} was given")
        step = ch.dt if ch.dt is not None else dt
        if step is None:
            raise MissingTimeStepError(path, f"{fmt} file does not carry its time step; "
                                       "pass dt= in seconds (--dt on the command line; "
                                       "SLAMMER files: see EQdata.txt)")
        n_comment = ch.extra.get("npts_comment")
        if n_comment is not None and n_comment != values.size:
            warnings.warn(f"{path}: header comment says {n_comment} points but the file holds "
                          f"{values.size}; all {values.size} values are used", UrmxWarning,
                          stacklevel=3)
            processing.append(f"urmx: header comment said {n_comment} points, "
                              f"used all {values.size}")
    elif np.allclose(np.diff(ch.times), ch.times[1] - ch.times[0], rtol=1e-6, atol=0):
        step = float(ch.times[1] - ch.times[0])  # a time column with an even step
        processing.append(f"urmx: time column evenly spaced, dt={step:g} s")
    else:
        values, step, msg = _resample_uneven(path, ch.times, values, dt)
        warnings.warn(f"{path}: {label} {msg}", UrmxWarning, stacklevel=3)
        processing.append(f"urmx: {msg}")
    if not (math.isfinite(step) and step > 0):
        raise MissingTimeStepError(path, f"{label} has time step dt={step!r} s; a time step "
                                   "must be a positive number of seconds")
    factor = _HEADER_UNITS[file_unit]
    data = values * factor
    if file_unit != "m/s2":
        processing.append(f"urmx: unit {file_unit} -> m/s2 (x {factor:g})")
    pga_g = float(np.max(np.abs(data))) / STANDARD_GRAVITY
    if pga_g > MAX_PLAUSIBLE_PGA_G:
        hint = " (values look like cm/s2 or mm/s2)" if file_unit in ("g", "m/s2") else ""
        raise RecordUnitError(path, f"{label} would have PGA {pga_g:.1f} g with unit "
                              f"{file_unit!r}: the unit is wrong{hint}")
    record = dict(format=fmt, file=str(path), unit_in_file=file_unit,
                  header_pga=None if ch.header_peak is None else ch.header_peak * factor,
                  uneven=ch.times is not None)
    return Samples(data, float(step), ch.station or path.stem, (ch.network or "")[:8],
                   ch.channel or "", ch.starttime, record, processing)


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
