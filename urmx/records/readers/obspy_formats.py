"""Files that ObsPy reads: K-NET/KiK-net ASCII and the formats of `OBSPY_FORMATS`, each
trace with what its header says it is not (a velocity, a seismometer, counts) and, with a
StationXML file, its instrument response removed.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

from ...errors import MissingFileError
from ..checks import counts_problem, quantity_problems
from ..errors import RecordError, UnknownFormatError
from .common import OBSPY_FORMATS, Channel, one_line


def parse_knet(path: Path, raw: bytes) -> list[Channel]:
    """The channels of a K-NET/KiK-net ASCII file (`raw`: its bytes), read by ObsPy:
    counts times the scale factor, in cm/s2, mean removed."""
    import obspy

    try:
        st = obspy.read(io.BytesIO(raw), format="KNET")
    except Exception as exc:  # noqa: BLE001
        raise RecordError(path, f"K-NET/KiK-net file cannot be read: {one_line(exc)}") from None
    out = []
    for tr in st:
        values = tr.data.astype(float) * tr.stats.calib * 100.0  # counts -> gal (cm/s2)
        values -= values.mean()  # K-NET counts carry an offset; the header peak is demeaned
        out.append(Channel(values, "cm/s2", tr.stats.delta, npts_header=tr.stats.npts,
                           network=tr.stats.network, station=tr.stats.station,
                           channel=tr.stats.channel, starttime=tr.stats.starttime,
                           header_peak=tr.stats.knet.accmax,
                           note="counts x scale factor, mean removed"))
    return out


def parse_obspy(path: Path, format: str | None, raw: bytes,
                response: str | os.PathLike | None = None) -> list[Channel]:
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
                                 f"{one_line(exc)}") from None
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
                                  f"from {tr.id}: {one_line(exc)}") from None
            note, unit = note + f", response of {Path(response).name} removed (ACC)", "m/s2"
        out.append(Channel(tr.data.astype(float), unit, tr.stats.delta,
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
                          f"StationXML: {one_line(exc)}") from None
