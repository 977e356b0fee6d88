"""GeoNet (New Zealand) ``.V1A``/``.V2A`` files: one block a component, each a text
header, 40 integer and 60 real header values, then accelerations, velocities and
displacements in fixed 8-character fields.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

from ..errors import RecordError, TruncatedRecordError
from .common import Channel, component_name, find_groups, fixed_numbers, utc


def parse_geonet(path: Path, lines: list[str]) -> list[Channel]:
    """The channels of a GeoNet V1A/V2A file (`lines`: its text), one a component."""
    channels, i = [], 0
    while i < len(lines) and lines[i].strip():
        if i + 26 > len(lines):
            raise TruncatedRecordError(path, f"GeoNet file ends inside a header (line {i + 1})")
        text = "\n".join(lines[i:i + 16])
        ints = fixed_numbers(path, lines[i + 16:i + 20], 8, first=i + 17).astype(int)
        reals = fixed_numbers(path, lines[i + 20:i + 26], 8, first=i + 21)
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
        values = fixed_numbers(path, block, 8, first=start + 1)
        unit_m = find_groups(r"(?:units of [\d.]+ |peak\s+-?[\d.]+ )(mm/s/s|mm/s2)", text)
        peak = find_groups(r"Acceleration:\s+peak\s+(-?[\d.]+)", text)
        yr, mo, dy, hh, mi, ds = ints[:6]
        channels.append(Channel(
            values, "mm/s2" if unit_m else None, float(reals[25]), npts_header=int(n_acc),
            station=find_groups(r"^Site\s+(\S+)", text, re.M)[0],
            network="NZ",
            channel=component_name(find_groups(r"Component\s+(\S+)", text)[0]),
            starttime=utc(yr, mo, dy, hh, mi, ds / 10.0) - float(reals[21]),
            header_peak=abs(float(peak[0])) if peak else None,
            note=lines[i].strip()))
        i = start + sum(n_lines)
    if not channels:
        raise TruncatedRecordError(path, "GeoNet file holds no channel")
    return channels
