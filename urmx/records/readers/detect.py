"""The first bytes decide a record file's format: urmx's own text formats by their
header lines, ObsPy's formats by ObsPy's detectors (never ``PICKLE``); compressed files,
archives, web pages, pickles, empty and oversized files are named and refused.
"""

from __future__ import annotations

import re
from pathlib import Path

from ..errors import UnknownFormatError, UnsupportedRecordError, UnusualRecordError
from .columns import header_names
from .common import ALLOW, OBSPY_FORMATS, decode, is_numeric_line, text_encoding

#: largest record file read [bytes]: a strong-motion record takes a few MB at most
MAX_RECORD_BYTES = 256 * 2**20
#: bytes read to decide a file's format (never the whole file)
SNIFF_BYTES = 8192
_KNOWN = ("PEER NGA AT2, GeoNet V1A/V2A, COSMOS V1/V2, CDMG/CSMIP and USC Vol 1/2, USGS SMC, "
          "K-NET/KiK-net, plain number columns and ObsPy's " + ", ".join(OBSPY_FORMATS))

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


def sniff(path: Path, allow_unusual: bool = False) -> tuple[str, str | None]:
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
    encoding = text_encoding(head)
    if encoding is None:  # binary: ObsPy's detectors, on files of a record's size only
        check_size(path, size, allow_unusual)
        return _obspy_or_unknown(path, "a binary file starting with bytes "
                                 + head[:8].hex(" "))
    text = decode(head, encoding)
    lines = text.splitlines()
    if not whole and lines:
        lines = lines[:-1]  # the head may end inside a line
    fmt = _text_format(path, lines)
    if fmt is not None:
        return fmt, None
    check_size(path, size, allow_unusual)
    body = [ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
    first = next((ln.strip() for ln in lines if ln.strip()), "")
    if body and is_numeric_line(body[0]):  # numbers, then text: ObsPy's, or a bad line
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
    if body and header_names(body[0]) is not None and len(body) > 1:
        body = body[1:]  # a header row of column names (time, acc_g, ...)
    if body and all(is_numeric_line(ln) for ln in body):
        return "columns"
    return None


def _size(n: int) -> str:
    return f"{n / 2**30:.1f} GiB" if n >= 2**30 else f"{n / 2**20:.1f} MiB" \
        if n >= 2**20 else f"{n} bytes"


def check_size(path: Path, size: int, allow_unusual: bool) -> None:
    if size > MAX_RECORD_BYTES and not allow_unusual:
        raise UnusualRecordError(path, f"file of {_size(size)} is larger than any strong-motion "
                                 f"record (urmx reads up to {_size(MAX_RECORD_BYTES)}; is it "
                                 f"the right file?){ALLOW}")


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
