"""USGS SMC files: a text header, integer and real headers in fixed fields, comments, then
the samples in cm/s2 (film records: unevenly spaced (time, accel) pairs); the raw type 0 is
refused.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import TruncatedRecordError, UnsupportedRecordError
from .common import Channel, component_name, find_groups, fixed_numbers, split_pairs


def parse_smc(path: Path, lines: list[str]) -> list[Channel]:
    """The one channel of a USGS SMC file (`lines`: its text)."""
    kind = lines[0].strip()
    if kind.startswith("0"):
        raise UnsupportedRecordError(path, "SMC raw (type 0) file holds counts, not acceleration")
    if len(lines) < 28:
        raise TruncatedRecordError(path, "SMC file ends inside its header")
    ints = fixed_numbers(path, lines[11:17], 10, first=12).astype(int)
    reals = fixed_numbers(path, lines[17:27], 15, first=18)
    n_comment = int(ints[15])
    data = lines[27 + n_comment:]
    values = fixed_numbers(path, data, 10, first=28 + n_comment)
    npts = int(ints[16])
    note = kind
    if values.size > npts:  # SMC readers take the announced count; report what is dropped
        note += f"; {values.size - npts} values after the announced {npts} ignored"
        values = values[:npts]
    text = "\n".join(lines[:11])
    station = lines[2].strip()
    comp = find_groups(r"component\s*=\s*(\S+)", text)
    peak = find_groups(r"pk(?: acc)?\s*=\s*(-?[\d.]+)", text)
    year, jday, hour, minute = ints[1:5]
    from obspy import UTCDateTime

    start = UTCDateTime(year=int(year), julday=int(jday), hour=int(hour), minute=int(minute))
    ch = Channel(values, "cm/s2", None, npts_header=npts, station=station,
                 channel=component_name(comp[0] + " deg") if comp else "", starttime=start,
                 header_peak=abs(float(peak[0])) if peak else None, note=note)
    rate = reals[1]
    if rate < 1e30:
        ch.dt = 1.0 / rate
    else:  # uncorrected film record: (time, accel) pairs
        split_pairs(path, ch)
    return [ch]
