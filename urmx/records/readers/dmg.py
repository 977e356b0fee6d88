"""CDMG/CSMIP and USC Vol 1/Vol 2 text files (one family of layouts): channels closed by
``/&`` lines, each evenly spaced (``<n> points of accel data ... at <dt> sec``) or, in the
film records, unevenly spaced (time, accel) pairs.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import RecordError, TruncatedRecordError, UnknownFormatError
from .common import (
    Channel,
    component_name,
    field_width,
    find_groups,
    fixed_numbers,
    split_pairs,
    utc,
)


def parse_dmg(path: Path, lines: list[str]) -> list[Channel]:
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


def _parse_dmg_block(path: Path, lines: list[str]) -> Channel:
    """One channel (the lines between two ``/&`` lines) of a CDMG/USC file."""
    text = "\n".join(lines[:40])
    comp = find_groups(r"(?:CHAN\s+\d+:|COMP)\s+([^\n]+)", text)
    station = find_groups(r"STATION(?: NO\.| USC#)\s*(\w+)", text)
    start = find_groups(r"(?:TRIGGER TIME|Start time|ORIGIN\(USGS\)):\s*"
                        r"(\d+)/(\d+)/(\d+),\s*(\d+):(\d+):([\d.]+)", text)
    ch = Channel(np.empty(0), None, None, station=station[0] if station else "",
                 channel=component_name(comp[0]) if comp else "",
                 note=lines[0].strip())
    if start:
        mo, dy, yr, hh, mi, ss = start
        ch.starttime = utc(yr, mo, dy, hh, mi, ss)
    head_i = next((k for k, ln in enumerate(lines) if _DATA_HEAD.match(ln)), None)
    if head_i is not None:  # evenly spaced: "<n> points of accel data ... at <dt> sec"
        head = lines[head_i]
        ch.npts_header = int(_DATA_HEAD.match(head).group(1))
        spacing = find_groups(r"spaced at\s+([\d.]+)\s*sec", head)
        rate = find_groups(r"at\s+(\d+)\s*pts/sec", head)
        ch.dt = float(spacing[0]) if spacing else 1.0 / float(rate[0]) if rate else None
        unit = find_groups(r"(?:units:?|units of|in)\s+(g|cm/sec2|cm/sec/sec)\b", head)
        ch.unit = {"g": "g", "cm/sec2": "cm/s2", "cm/sec/sec": "cm/s2"}.get(
            unit[0].lower() if unit else "")
        data = []
        for ln in lines[head_i + 1:]:
            if re.search(r"[a-df-zA-DF-Z]", ln):  # next section header (velocity, ...)
                break
            data.append(ln)
        fmt = find_groups(r"\((\d+)f(\d+)\.\d+\)", head)
        offset, width = (0, int(fmt[1])) if fmt else field_width(path, data[0] if data else "")
        ch.values = fixed_numbers(path, data, width, offset)
        peak = find_groups(r"Peak acceleration\s*=\s*(-?[\d.]+)\s*cm", "\n".join(lines))
        max_g = find_groups(r"MAX\s*=\s*(-?[\d.]+)\s*G", text)
        if peak and ch.unit == "cm/s2":
            ch.header_peak = abs(float(peak[0]))
        elif max_g and ch.unit == "g":
            ch.header_peak = abs(float(max_g[0]))
        return ch
    # uneven (time, accel) pairs after the integer and real headers
    units = find_groups(r"UNITS (?:OF UNCOR ACCEL )?ARE SEC AND\s+(G/10|G)\b", text)
    if not units:
        raise UnknownFormatError(path, "CDMG/USC-style file without a data header or units line")
    ch.unit = units[0].lower()
    npts = find_groups(r"NO\. OF POINTS\s*=\s*(\d+)", text)
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
    ch.values = fixed_numbers(path, data, *field_width(path, data[0])[::-1]) if data \
        else np.empty(0)
    ch.npts_header = None if ch.npts_header is None else 2 * ch.npts_header
    max_g = find_groups(r"MAX\s*=\s*(-?[\d.]+)\s*G", text)
    split_pairs(path, ch)
    ch.header_peak = abs(float(max_g[0])) * (10.0 if ch.unit == "g/10" else 1.0) \
        if max_g else None
    return ch
