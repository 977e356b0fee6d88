"""COSMOS V1/V2 files (``.V1c``/``.V2c``): text, integer and real headers and comments
whose line counts the file states, then the samples in the format it states; the raw-count
V0 is refused.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from ..errors import UnsupportedRecordError, UnusualRecordError
from .common import Channel, find_groups, fixed_numbers, quantity_of, unit_name, utc


def parse_cosmos(path: Path, lines: list[str]) -> list[Channel]:
    """The one channel of a COSMOS V1/V2 file (`lines`: its text)."""
    text = "\n".join(lines[:60])
    if re.search(r"raw acceleration counts|units=\s*counts", text, re.I):
        raise UnsupportedRecordError(
            path, "COSMOS V0 file holds raw digitiser counts without the sensor sensitivity "
            "applied; read the corrected V2 (or V1) file instead")
    n_text = int(find_groups(r"with\s+(\d+)\s+text lines", lines[0])[0])
    i = n_text
    n_int, int_lines = map(int, find_groups(r"(\d+)\s+Integer-header values follow on\s+(\d+)",
                                            lines[i]))
    i += 1 + int_lines
    n_real, real_lines = map(int, find_groups(r"(\d+)\s+Real-header values follow on\s+(\d+)",
                                              lines[i]))
    width = int(find_groups(r"\(\d+F(\d+)\.", lines[i])[0])
    reals = fixed_numbers(path, lines[i + 1:i + 1 + real_lines], width, first=i + 2)
    i += 1 + real_lines
    n_comment = int(find_groups(r"(\d+)\s+Comment line", lines[i])[0])
    comments = "\n".join(lines[i + 1:i + 1 + n_comment])
    i += 1 + n_comment
    head = lines[i]
    npts = int(find_groups(r"^\s*(\d+)", head)[0])
    stated = find_groups(r"units\s*=\s*([^(,]+)", head)[0]
    unit = unit_name(stated)
    if unit is None and quantity_of(stated):
        raise UnusualRecordError(path, f"COSMOS data header states units={stated.strip()} "
                                 f"({quantity_of(stated)}), not an acceleration: read the "
                                 ".acc file of the record")
    per_line, width = map(int, find_groups(r"Format\s*=\s*\((\d+)[EF](\d+)", head))
    data = lines[i + 1:i + 1 + math.ceil(npts / per_line)]
    values = fixed_numbers(path, data, width, first=i + 2)
    code = find_groups(r"Code:\s*(\w+)-(\w+)", text) or ("", "")
    scnl = find_groups(r"<SCNL>\s*(\w+)\.(\w+)\.", comments)
    start = find_groups(r"Rcrd start time:\s*(\d+)/(\d+)/(\d+)\s+(\d+):(\d+):([\d.]+)", text)
    peak = find_groups(r"Max\s*=\s*(-?[\d.]+)\s*cm/sec2", text)
    return [Channel(values, unit, float(reals[61]) / 1000.0, npts_header=npts,
                    network=code[0], station=code[1], channel=scnl[1] if scnl else "",
                    starttime=utc(*start) if start else None,
                    header_peak=abs(float(peak[0])) if peak and unit == "cm/s2" else None,
                    note=lines[0].strip())]
