"""PEER NGA ``.AT2`` files: a four-line header (event, station and component; the
quantity and its unit; ``NPTS=, DT=``), then the samples.
"""

from __future__ import annotations

import re
from pathlib import Path

from ..errors import (
    PointCountError,
    RecordError,
    RecordUnitError,
    TruncatedRecordError,
    UnsupportedRecordError,
    UnusualRecordError,
)
from .common import (
    Channel,
    component_name,
    not_a_number,
    number_or_none,
    quantity_of,
    separated_numbers,
    unit_name,
)

_PEER_LINE4 = re.compile(r"NPTS\s*=\s*(?P<npts>[^,\s]+)\s*,?\s*DT\s*=\s*(?P<dt>\S+)", re.I)
_PEER_LINE4_WEST2 = re.compile(r"^\s*(?P<npts>\S+)\s+(?P<dt>\S+)\s+NPTS\s*,\s*DT", re.I)


def parse_peer(path: Path, lines: list[str]) -> list[Channel]:
    """The one channel of a PEER AT2 file (`lines`: its text)."""
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
    dt = number_or_none(dt_tok)
    if dt is None:  # a number that is not a positive time step is said by samples.checked
        raise RecordError(path, f"PEER AT2 line 4: time step DT={not_a_number(dt_tok)}: "
                          f"{lines[3].strip()!r}")
    if re.search(r"VELOCITY|DISPLACEMENT", lines[2], re.I):
        raise UnsupportedRecordError(path, "PEER file of velocity or displacement (.VT2/.DT2), "
                                     "not acceleration: read the .AT2 file")
    unit_m = re.search(r"UNITS OF\s+(\S+)", lines[2], re.I)
    unit = unit_name(unit_m.group(1)) if unit_m else None
    if unit is None:
        quantity = quantity_of(unit_m.group(1)) if unit_m else None
        raise (UnusualRecordError if quantity else RecordUnitError)(
            path, "PEER AT2 line 3 states " + (f"a unit of {quantity}, not acceleration: "
                                               if quantity else "an unknown unit: ")
            + repr(lines[2].strip()))
    if len(lines) < 5:
        raise TruncatedRecordError(path, f"PEER AT2 file ends after its 4-line header: no "
                                   f"samples, though line 4 states NPTS= {int(npts_tok)}")
    values = separated_numbers(path, lines[4:], 5, "PEER AT2")
    parts = [p.strip() for p in lines[1].split(",")]
    return [Channel(values, unit, dt, npts_header=int(npts_tok),
                    station=parts[2] if len(parts) > 2 else "",
                    channel=component_name(parts[-1]) if len(parts) > 1 else "",
                    note=lines[1].strip())]
