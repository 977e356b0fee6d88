"""Processing with ObsPy: baseline, taper, band-pass, resampling, scaling.

Every function returns a new :class:`obspy.Trace` (the input is not modified) and the
step lands in ``stats.processing``: ObsPy's own methods record themselves, and the
urmx steps that ObsPy lacks (scaling to a target PGA) append an entry in the same style.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError, got
from .readers import STANDARD_GRAVITY, check_finite


def _trace(trace):
    """`trace` when it is an obspy Trace, else an `urmx.errors.InputError` naming the
    argument and what it got."""
    if hasattr(trace, "stats") and hasattr(trace, "data") and hasattr(trace, "copy"):
        return trace

    raise InputError(f"trace must be an obspy Trace (urmx.records.read, load), got "
                     f"{got(trace)}")


def baseline(trace, order: int = 0):
    """Remove the mean (``order=0``) or a polynomial baseline of ``order`` (ObsPy ``detrend``).

    Parameters
    ----------
    trace : obspy.Trace
        Acceleration [m s-2].
    order : int
        0 removes the mean, 1 a straight line, higher a polynomial. [1]
    """
    tr = _trace(trace).copy()
    if order == 0:
        tr.detrend("demean")
    elif order == 1:
        tr.detrend("linear")
    else:
        tr.detrend("polynomial", order=order)
    return tr


def taper(trace, fraction: float = 0.05):
    """Cosine (Hann) taper of ``fraction`` of the record at each end. [1]

    Parameters
    ----------
    trace : obspy.Trace
        The record, acceleration [m s-2].
    fraction : float
        Share of the record's length tapered at each end. [1]
    """
    tr = _trace(trace).copy()
    tr.taper(max_percentage=fraction, type="hann")
    return tr


def bandpass(trace, freqmin: float = 0.1, freqmax: float = 25.0, corners: int = 4,
             zerophase: bool = True):
    """Butterworth band-pass (ObsPy ``filter("bandpass")``).

    Parameters
    ----------
    trace : obspy.Trace
        Acceleration [m s-2].
    freqmin, freqmax : float
        Corner frequencies [Hz]; ``freqmax`` is capped just below the Nyquist frequency.
    corners : int
        Filter order. [1]
    zerophase : bool
        Run forwards and backwards (no phase shift).
    """
    tr = _trace(trace).copy()
    nyquist = 0.5 / tr.stats.delta
    tr.filter("bandpass", freqmin=freqmin, freqmax=min(freqmax, 0.95 * nyquist),
              corners=corners, zerophase=zerophase)
    return tr


def resample(trace, dt: float):
    """Resample to time step ``dt`` [s] (anti-aliased, ObsPy ``resample``/``interpolate``).

    Parameters
    ----------
    trace : obspy.Trace
        The record, acceleration [m s-2].
    dt : float
        The new time step. [s]
    """
    tr = _trace(trace).copy()
    if np.isclose(tr.stats.delta, dt, rtol=1e-9):
        return tr
    if dt > tr.stats.delta:
        tr.resample(1.0 / dt, no_filter=False)
    else:
        tr.interpolate(sampling_rate=1.0 / dt, method="lanczos", a=20)
    return tr


def scale(trace, factor: float | None = None, target_pga: float | None = None):
    """Scale by ``factor`` [1] or so that the PGA equals ``target_pga`` [m s-2].

    Parameters
    ----------
    trace : obspy.Trace
        The record, acceleration [m s-2].
    factor : float, optional
        Factor applied to the samples. [1]
    target_pga : float, optional
        The PGA the scaled record has, instead of `factor`. [m s-2]

    Returns
    -------
    obspy.Trace
        The scaled copy; ``stats.scale_factor`` holds the factor applied.
    """
    tr = _trace(trace).copy()
    if (factor is None) == (target_pga is None):
        raise InputError("scale: give exactly one of factor= or target_pga=")
    pga = float(np.max(np.abs(check_finite(tr.data, f"scale: trace {tr.id!r}",
                                           tr.stats.delta))))
    if target_pga is not None:
        if pga == 0:
            raise InputError(f"scale: trace {tr.id} is all zeros, cannot reach a target PGA")
        factor = target_pga / pga
    tr.data = tr.data * factor
    tr.stats.scale_factor = float(factor) * float(trace.stats.get("scale_factor", 1.0))
    target = (f" (target PGA {target_pga:.6g} m/s2 = {target_pga / STANDARD_GRAVITY:.4f} g)"
              if target_pga else "")
    tr.stats.processing.append(f"urmx.records.scale: x {factor:.6g}" + target)
    return tr


def process(trace, demean: bool = True, taper_fraction: float | None = 0.05,
            freqmin: float | None = None, freqmax: float | None = None,
            dt: float | None = None, factor: float | None = None,
            target_pga: float | None = None):
    """The usual chain: baseline, taper, band-pass, resample, scale (each step optional).

    Parameters
    ----------
    trace : obspy.Trace
        The record, acceleration [m s-2].
    demean : bool
        Remove the mean (:func:`baseline` of order 0).
    taper_fraction : float or None
        Share of the length tapered at each end (:func:`taper`); None or 0: no taper. [1]
    freqmin, freqmax : float, optional
        Corners of the band-pass (:func:`bandpass`); either alone filters from 0.05 Hz or
        to 0.95 of the Nyquist frequency. [Hz]
    dt : float, optional
        Resample to this time step (:func:`resample`). [s]
    factor : float, optional
        Scale by this factor (:func:`scale`). [1]
    target_pga : float, optional
        Scale to this PGA instead (:func:`scale`). [m s-2]
    """
    tr = trace
    if demean:
        tr = baseline(tr, 0)
    if taper_fraction:
        tr = taper(tr, taper_fraction)
    if freqmin is not None or freqmax is not None:
        tr = bandpass(tr, freqmin or 0.05, freqmax or 0.95 * 0.5 / tr.stats.delta)
    if dt is not None:
        tr = resample(tr, dt)
    if factor is not None or target_pga is not None:
        tr = scale(tr, factor, target_pga)
    return tr
