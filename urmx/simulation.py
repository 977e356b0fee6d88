"""One analysis as a labelled ``xarray.Dataset``: the public wrapper over the solvers.

:func:`simulate` validates the arguments, runs the exact kernel (:func:`urmx.kernel.run`)
or the scipy yardstick (:func:`urmx.reference.run`), and labels the result: the scalars
of ``urmx.variables.SCALARS`` as 0-d variables, the histories (on request) over a
``time`` dimension on the record grid, every variable stamped with ``units`` and
``long_name`` from the registry, and the run's settings as global attributes.

Studies call :func:`urmx.kernel.run` directly and label per batch: building a Dataset
costs about 0.2 ms, a large share of one analysis.
"""

from __future__ import annotations

import functools
import math
import os
from typing import Any

import numpy as np
import xarray as xr

from . import provenance, reference, variables
from .errors import InputError, numbers_argument
from .kernel import check_inputs, run
from .model import T_REST, Wall
from .records.record import load_named

METHODS = ("exact", "reference")
DEFAULT_RTOL = 1e-10  # relative tolerance of the reference method
# spellings of m/s2 accepted in an ObsPy trace's stats.units
_SI_UNITS = {"m/s2", "m/s**2", "m/s^2", "m s-2", "m.s-2", "m/(s*s)"}


def load_record(record: str | os.PathLike, records_dir: str | os.PathLike | None = None):
    """A record named by a string: a record file (one channel) or a manifest record id.

    Returns an ObsPy Trace in m s-2 (unscaled; `urmx.records.record.load_named`, the one
    reading of a record's name). Raises :class:`urmx.errors.MissingFileError` naming
    `record` when it is neither an existing file nor a manifest id.
    """
    return load_named(record, records_dir)


def _record(ground_acceleration: Any, dt: float | None) -> tuple[Any, float | None, str]:
    """Samples, time step and a label of the input; an ObsPy Trace gives its own dt."""
    if isinstance(ground_acceleration, (str, os.PathLike)):
        ground_acceleration = load_record(ground_acceleration)
    stats = getattr(ground_acceleration, "stats", None)
    if stats is None or not hasattr(ground_acceleration, "data"):
        ground_acceleration = numbers_argument("simulate", "ground_acceleration",
                                               ground_acceleration)
        if dt is None:
            raise InputError("dt is required when ground_acceleration is an array "
                             "(give the record time step in seconds), or pass an ObsPy "
                             "Trace, a record file or a manifest record id")
        return ground_acceleration, dt, "array"
    units = stats.get("units")
    if units is not None and str(units).strip().lower() not in _SI_UNITS:
        raise InputError(f"trace {stats.get('id', '')!s} has units {units!r}; "
                         f"ground acceleration must be in m/s2")
    delta = float(stats.delta)
    if dt is not None and not math.isclose(float(dt), delta, rel_tol=1e-9):
        raise InputError(f"dt={dt!r} differs from the trace's stats.delta={delta!r}")
    return np.asarray(ground_acceleration.data, dtype=float), delta, str(stats.get("id", ""))


def simulate(wall: Wall, ground_acceleration: Any, dt: float | None = None, *,
             scale: float = 1.0, cor: float = 0.8, impact: str = "scale", tail: float = 0.0,
             t_rest: float = T_REST, history: bool = False, method: str = "exact",
             rtol: float | None = None) -> xr.Dataset:
    """Rocking response of one wall to one ground motion, as a labelled Dataset.

    Parameters
    ----------
    wall : urmx.Wall
        The wall and its two supports.
    ground_acceleration : array_like, obspy.Trace, str or path
        Ground acceleration samples, linearly interpolated between samples. [m s-2]
        A Trace gives its own time step (``stats.delta``) and, if ``stats.units`` is
        set, it must be m/s2. A string or path is a record file (read with
        `urmx.records.read`) or a manifest record id (`urmx.records.load`), unscaled.
    dt : float, optional
        Record time step; required for arrays, optional for a Trace (must agree). [s]
    scale : float
        Factor applied to the record. [1]
    cor : float
        Coefficient of restitution, in (0, 1]. [1]
    impact : {"scale", "contact"}
        Impact law (MODEL.md section 8).
    tail : float
        Free-vibration tail after the record, rounded to whole record steps. [s]
    t_rest : float
        A joint that an impact leaves with a rate below ``v_rest = g_open/t_rest`` is held
        closed (MODEL.md section 4): a constant of the model, recorded as the attribute
        ``t_rest``, not the record step. [s]
    history : bool
        Add the time histories over a ``time`` dimension on the record grid.
    method : {"exact", "reference"}
        ``"exact"``: the event-driven kernel (round-off accuracy); ``"reference"``: the
        scipy ``solve_ivp`` yardstick.
    rtol : float, optional
        Relative tolerance of the reference method (default 1e-10); not accepted with
        ``method="exact"``, which has no tolerance. [1]

    Returns
    -------
    xarray.Dataset
        0-d variables ``urmx.variables.SCALARS``; with ``history=True`` also
        ``theta_lower``, ``theta_upper``, ``base_displacement``, ``crack_displacement``,
        ``top_displacement``, ``base_acceleration``, ``crack_acceleration``,
        ``top_acceleration``, ``pattern`` (11, 12, 21, 22; 0 after a stop) and the
        analysed ``ground_acceleration`` (scaled, zero in the tail) over ``time``.
        Global attributes: ``status`` ("ok", "collapsed", "event-limit"), ``duration``
        [s], ``events``, ``method``, ``cor``, ``scale``, ``impact``, ``tail``, ``t_rest``,
        ``dt``,
        the provenance attributes of `urmx.provenance.attrs` (``urmx_version`` with the
        git commit, ``kernel_source_hash``, library versions) and the wall's fields as
        ``wall_<field>``.

    Raises
    ------
    urmx.errors.InputError
        A :class:`ValueError`: unknown method, ``rtol`` with the exact method or outside
        (0, 1), a Trace not in m/s2, or a bad input caught by
        :func:`urmx.kernel.check_inputs` (NaN/inf samples, ``dt <= 0``, ``cor`` outside
        (0, 1], unknown impact law, ...).
    urmx.records.RecordError, urmx.errors.MissingFileError
        A record named by a string cannot be read or found.
    """
    _check_options(method, rtol, scale=scale, cor=cor, tail=tail, dt=dt)
    samples, dt, source = _record(ground_acceleration, dt)
    try:
        check_inputs(wall, samples, dt, scale, cor, impact, tail, t_rest=t_rest)
    except ValueError as exc:  # the solvers' own argument checks
        raise InputError(str(exc)) from None
    t_rest = float(t_rest)
    rtol = DEFAULT_RTOL if method == "reference" and rtol is None else rtol
    solve = run if method == "exact" else functools.partial(reference.run, rtol=rtol)
    res = solve(wall, samples, dt, scale=scale, cor=cor, impact=impact, tail=tail,
                t_rest=t_rest, history=history)
    ds = _dataset(res, samples, scale, history)
    ds.attrs = _attrs(wall, res, method=method, rtol=rtol, dt=float(dt), scale=scale,
                      cor=cor, impact=impact, tail=tail, t_rest=t_rest, source=source)
    return variables.stamp(ds)


def _check_options(method: str, rtol: float | None, **numbers: Any) -> None:
    """Refuse an unknown method, a tolerance the method does not take or outside (0, 1),
    and any of `numbers` (scale, cor, tail, dt) given but not a number."""
    if method not in METHODS:
        raise InputError(f"method={method!r} is not a method; use 'exact' or 'reference'")
    if method == "exact" and rtol is not None:
        raise InputError("rtol applies to method='reference' only; the exact method has no "
                         "tolerance")
    if rtol is not None and not (isinstance(rtol, (int, float)) and 0.0 < rtol < 1.0):
        raise InputError(f"rtol={rtol!r} must lie in (0, 1)")
    for name, value in numbers.items():
        if value is not None and (isinstance(value, bool) or not isinstance(
                value, (int, float, np.integer, np.floating))):
            raise InputError(f"simulate: {name}={value!r} must be a number, not "
                             f"{type(value).__name__}")


def _dataset(res: dict, samples: Any, scale: float, history: bool) -> xr.Dataset:
    """The run's scalars as 0-d variables and, with `history`, its time histories and the
    analysed (scaled, zero in the tail) ground acceleration over ``time``."""
    data: dict[str, Any] = {}
    for name in variables.SCALARS:
        dtype = np.int32 if name in variables.INTEGER_SCALARS else np.float64
        data[name] = ((), np.asarray(res[name], dtype=dtype))
    coords = {}
    if history:
        hist = res["history"]
        coords["time"] = ("time", hist["time"])
        for name in variables.HISTORIES:
            data[name] = ("time", hist[name])
        ag = np.zeros(hist["time"].size)
        record = np.asarray(samples, dtype=float) * float(scale)
        ag[:record.size] = record
        data["ground_acceleration"] = ("time", ag)
    return xr.Dataset(data, coords=coords)


def _attrs(wall: Wall, res: dict, *, method: str, rtol: float | None, dt: float,
           scale: float, cor: float, impact: str, tail: float, t_rest: float,
           source: str) -> dict:
    """netCDF-safe global attributes (strings and numbers only)."""
    attrs: dict[str, Any] = {
        "Conventions": "CF-1.8",
        "title": "urmx rocking analysis of one wall",
        "status": res["status"],
        "duration": float(res["duration"]),
        "events": int(res["events"]),
        "method": method,
    }
    if rtol is not None:
        attrs["rtol"] = float(rtol)
    attrs.update(dt=dt, scale=float(scale), cor=float(cor), impact=impact, tail=float(tail),
                 t_rest=t_rest, record=source)
    attrs.update(provenance.attrs())  # urmx_version (with the git commit), versions
    for key, value in wall.to_dict().items():
        attrs[f"wall_{key}"] = value if isinstance(value, str) else float(value)
    attrs["history"] = (f"urmx {provenance.VERSION} simulate(method={method!r}, scale={scale:g}, "
                        f"cor={cor:g}, impact={impact!r}, tail={tail:g}, t_rest={t_rest:g})")
    return attrs
