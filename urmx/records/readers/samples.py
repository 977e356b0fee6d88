"""The one builder of `urmx.records.readers`: a parsed channel becomes :class:`Samples`
after its checks (point count, NaN, a time step and peak within what strong-motion records
have, units stated twice that agree), its conversion to m s-2, the resampling of uneven time
steps and a processing step for each.
"""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...config import UrmxWarning
from ...errors import numbers_argument
from ..checks import motion_problem, unit_problem
from ..errors import (
    MissingTimeStepError,
    NonFiniteError,
    PointCountError,
    RecordError,
    RecordUnitError,
    TruncatedRecordError,
    UnusualRecordError,
)
from .common import ALLOW, HEADER_UNITS, STANDARD_GRAVITY, UNIT_FACTORS, Channel

#: time steps [s] of strong-motion records (10 kHz to 10 Hz sampling); a record whose
#: time step lies outside is refused unless ``allow_unusual=True``
DT_RANGE = (1e-4, 0.1)
#: peak ground accelerations [g] of strong-motion records: below 0.001 g (1 cm/s2, under
#: the trigger level of strong-motion instruments) the values are most likely g under a
#: cm/s2 or mm/s2 label, above 10 g cm/s2 or mm/s2 under a g or m/s2 label; outside, a
#: record is refused unless ``allow_unusual=True``
PGA_RANGE_G = (1e-3, 10.0)

#: nice time steps [s] that uneven records are resampled to (the largest not above the
#: mean spacing, so the resampled record is never coarser than the original)
_NICE_DT = (0.001, 0.002, 0.0025, 0.004, 0.005, 0.01, 0.02)


@dataclass
class Samples:
    """One channel of a record as checked numbers, before it becomes an ObsPy Trace
    (`urmx.records.readers.read_samples`; reading without ObsPy, for the command line's
    quick path)."""

    data: np.ndarray  # acceleration [m s-2]
    dt: float  # time step [s]
    station: str
    network: str
    channel: str
    starttime: object
    record: dict  # format, file, unit in the file, header peak [m s-2], uneven
    processing: list[str]

    def trace(self):
        """The channel as an :class:`obspy.Trace` (the form `urmx.records.readers.read`
        returns)."""
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


def checked(path: Path, fmt: str, ch: Channel, dt: float | None, unit: str | None,
            allow_unusual: bool = False) -> Samples:
    """A parsed channel of the file `path` (format `fmt`) as :class:`Samples` in m s-2: its
    point count against the header's, no NaN, its unit (:func:`_file_unit`) and time step
    (:func:`_time_step`) from the file or the caller's `unit` and `dt`, then the checks of
    :func:`_plausible` and what ObsPy's header said it is not (refused, or with
    ``allow_unusual`` overridden); every step is written to ``processing``."""
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
    file_unit, unit_source = _file_unit(path, fmt, ch, unit)
    dt_source = ch.extra.get("dt_source", "header")
    values, step, steps = _time_step(path, fmt, label, ch, values, dt, dt_source)
    processing = [f"urmx.records.read: {fmt} file {path.name!r} ({ch.note})", *steps]
    factor = HEADER_UNITS[file_unit]
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


def _file_unit(path: Path, fmt: str, ch: Channel, unit: str | None) -> tuple[str, str]:
    """(the unit of the values, where the file states it): the file's, which a given
    `unit` must agree with, else the given one; neither is a :class:`RecordUnitError`."""
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
    return file_unit, unit_source


def _time_step(path: Path, fmt: str, label: str, ch: Channel, values: np.ndarray,
               dt: float | None, dt_source: str) -> tuple[np.ndarray, float, list[str]]:
    """(values, time step [s], processing steps) of a channel: the step the file states,
    which a given `dt` must agree with, or the given one; a time column's even step, or
    its uneven samples resampled (with a :class:`urmx.UrmxWarning`). A missing, contradicted
    or non-positive step is a :class:`MissingTimeStepError`."""
    steps = []
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
                          stacklevel=5)
            steps.append(f"urmx: header comment said {n_comment} points, "
                         f"used all {values.size}")
    elif np.allclose(np.diff(ch.times), ch.times[1] - ch.times[0], rtol=1e-6, atol=0):
        step = float(ch.times[1] - ch.times[0])  # a time column with an even step
        given = dt if dt is not None else ch.dt
        if given is not None and not math.isclose(given, step, rel_tol=1e-6):
            src = "was given" if dt is not None else f"is stated ({dt_source})"
            raise MissingTimeStepError(path, f"the time column has an even step of {step:g} s "
                                       f"but dt={given:g} {src}")
        steps.append(f"urmx: time column evenly spaced, dt={step:g} s")
    else:
        values, step, msg = _resample_uneven(path, ch.times, values, dt if dt is not None
                                             else ch.dt)
        warnings.warn(f"{path}: {label} {msg}", UrmxWarning, stacklevel=5)
        steps.append(f"urmx: {msg}")
    if not (math.isfinite(step) and step > 0):
        raise MissingTimeStepError(path, f"{label} has time step dt={step!r} s; a time step "
                                   "must be a positive number of seconds")
    return values, step, steps


def _unusual(path: Path, problem: str, allow_unusual: bool) -> str:
    """Refuse a record for `problem` (`UnusualRecordError`), or with ``allow_unusual`` the
    processing step that says it was overridden (kept in a study archive's
    ``record_processing``)."""
    if not allow_unusual:
        raise UnusualRecordError(path, problem + ALLOW)
    return f"urmx: allow_unusual overrode: {problem}"


def _plausible(path: Path, label: str, ch: Channel, values: np.ndarray, data: np.ndarray,
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
    factor = HEADER_UNITS[file_unit]
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
