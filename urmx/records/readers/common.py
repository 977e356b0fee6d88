"""What every format parser of `urmx.records.readers` shares: the channel as parsed
(:class:`Channel`), the units and the ObsPy formats urmx reads, the decoding of text and the
reading of numbers and header fields (fixed-width fields, units, components, times).
"""

from __future__ import annotations

import codecs
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import RecordError, TruncatedRecordError

STANDARD_GRAVITY = 9.80665  # standard gravity [m s-2], for records in units of g

#: factors from the units accepted by :func:`read` (and found in headers) to m s-2
UNIT_FACTORS = {
    "g": STANDARD_GRAVITY,
    "m/s2": 1.0,
    "cm/s2": 0.01,
    "mm/s2": 0.001,
}
HEADER_UNITS = {**UNIT_FACTORS, "g/10": STANDARD_GRAVITY / 10.0, "um/s2": 1e-6}

ALLOW = "; if it is really meant, pass allow_unusual=True (--allow-unusual on the command line)"

#: ObsPy waveform formats urmx detects and reads (parsers only, in ObsPy's order of
#: preference); never ``PICKLE``, whose reader unpickles, i.e. can run code
OBSPY_FORMATS = ("MSEED", "SAC", "GSE2", "SEISAN", "SACXY", "GSE1", "Q", "SH_ASC", "SLIST",
                 "TSPAIR", "Y", "PDAS", "SEGY", "SU", "SEG2", "WAV", "WIN", "CSS",
                 "NNSA_KB_CORE", "AH", "GCF", "REFTEK130", "RG16", "DMX",
                 "KINEMETRICS_EVT")
FLOAT = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
DECIMAL_COMMA = re.compile(r"[-+]?\d*,\d+")


@dataclass
class Channel:
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


# -- text -------------------------------------------------------------------------------


def text_encoding(head: bytes) -> str | None:
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


def decode(raw: bytes, encoding: str) -> str:
    """`raw` as text in `encoding` (from :func:`text_encoding`)."""
    if encoding == "utf-8-sig":  # numbers and headers are ASCII: latin-1 never fails
        return raw[len(codecs.BOM_UTF8):].decode("latin-1")
    if encoding.startswith("utf-16"):
        return raw[: len(raw) - len(raw) % 2].decode(encoding, errors="replace")
    return raw.decode(encoding)


def is_numeric_line(line: str) -> bool:
    """Whether `line` holds only numbers (separated by spaces or commas)."""
    return all(FLOAT.fullmatch(tok) for tok in line.replace(",", " ").split())


# -- numbers and header fields -----------------------------------------------------------


def number_or_none(tok: str) -> float | None:
    """A number token (``FLOAT``), or None."""
    return float(tok) if FLOAT.fullmatch(tok) else None


def not_a_number(tok: str) -> str:
    """What is wrong with `tok`, for a message: not a number (a decimal comma?)."""
    hint = " (a decimal comma? write numbers with a decimal point)" \
        if DECIMAL_COMMA.fullmatch(tok) else ""
    return f"{tok!r} is not a number{hint}"


def unit_name(text: str) -> str | None:
    """A unit as urmx names it (a key of ``HEADER_UNITS``), from a file's spelling, or
    None: ``CM/SEC/SEC``, ``cm/s^2``, ``gal`` -> ``cm/s2``; ``G`` -> ``g``."""
    t = text.strip().strip("()[],.;:").lower().replace(" ", "").replace("²", "2")
    t = t.replace("**", "").replace("^", "").replace("sec", "s")
    t = re.sub(r"/s/s$", "/s2", t)
    t = {"gal": "cm/s2", "gals": "cm/s2", "µm/s2": "um/s2"}.get(t, t)
    return t if t in HEADER_UNITS else None


def separated_numbers(path: Path, lines: list[str], first: int, what: str) -> np.ndarray:
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
                    raise RecordError(path, f"{what} line {i}: {not_a_number(tok)}") from None
        raise


def fixed_numbers(path: Path, lines: list[str], width: int, offset: int = 0,
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
        j = next(j for j, t in enumerate(out) if not is_float(t))
        k = where[j]
        line = f"line {first + k}" if first is not None else f"data line {lines[k].strip()!r}"
        raise RecordError(path, f"{line}: {not_a_number(out[j])}") from None


def is_float(tok: str) -> bool:
    """Whether `tok` reads as a float."""
    try:
        float(tok)
    except ValueError:
        return False
    return True


def field_width(path: Path, line: str) -> tuple[int, int]:
    """(offset, width) of the fixed fields on a data line (from its separated values)."""
    n = len(FLOAT.findall(line))
    length = len(line.rstrip())
    if n == 0 or length // n == 0 or length - (length // n) * n > 3:
        raise RecordError(path, f"cannot tell the field width of data line {line.strip()!r}")
    return length - (length // n) * n, length // n


def component_name(text: str) -> str:
    """A component as a header names it, as a channel name: ``90`` and ``90 deg`` ->
    ``090``, ``S62W deg`` -> ``S62W``, else its first word in capitals."""
    text = text.strip()
    if text.isdigit():
        return f"{int(text):03d}"
    m = re.match(r"([NS]?\d+[EW]?|\d+)\s*deg", text, re.I)
    if m:
        return f"{int(m.group(1)):03d}" if m.group(1).isdigit() else m.group(1).upper()
    return text.split()[0].upper() if text else ""


def utc(year, month, day, hour=0, minute=0, second=0.0):
    """An :class:`obspy.UTCDateTime` from header fields (two-digit years: 1931-2030)."""
    from obspy import UTCDateTime

    year = int(year)
    if year < 100:
        year += 1900 if year > 30 else 2000
    return UTCDateTime(year, int(month), int(day), int(hour), int(minute)) + float(second)


def find_groups(pattern: str, text: str, flags=re.I):
    """The groups of the first match of `pattern` in `text` (case ignored), or None."""
    m = re.search(pattern, text, flags)
    return m.groups() if m else None


def quantity_of(unit_text: str) -> str | None:
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


def split_pairs(path: Path, ch: Channel) -> None:
    """Make a channel read as (time, accel) pairs its sample times and values."""
    if ch.npts_header is not None and len(ch.values) == ch.npts_header:
        ch.npts_header //= 2  # header counted numbers, not pairs
    if len(ch.values) % 2:
        raise TruncatedRecordError(path, "(time, accel) pairs end with a lone value")
    ch.times, ch.values = ch.values[0::2], ch.values[1::2]


def one_line(exc: Exception) -> str:
    """An exception's message on one line (its type when it has none)."""
    return " ".join(str(exc).split()) or type(exc).__name__
