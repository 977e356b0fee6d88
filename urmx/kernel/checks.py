"""What a wall and a record must satisfy before the kernel runs them: the arguments shared
by every solver (:func:`check_inputs`), each refused with a one-line InputError."""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from ..model import T_REST, Wall
from .loop import DT_RANGE, LAWS, WINDOW


def _float(name: str, value, what: str) -> float:
    """`value` as a float, or an InputError saying that argument `name` must be `what`."""
    try:
        return float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name}={value!r} must be {what}") from None


def check_t_rest(t_rest) -> float:
    """`t_rest` as a float, or an InputError naming it (a positive, finite time)."""
    value = _float("t_rest", t_rest, "a number of seconds")
    if not (math.isfinite(value) and value > 0.0):
        raise InputError(f"t_rest={t_rest!r} must be a positive, finite time in seconds "
                         f"(v_rest = g_open/t_rest, MODEL.md section 4)")
    return value


#: what `urmx.kernel.run` can track: every output, or what a collapse capacity search reads
TRACKS = ("all", "capacity")


def check_track(track) -> str:
    """`track` if it is one of `TRACKS`, else an InputError naming them."""
    if track not in TRACKS:
        raise InputError(f"track={track!r} is not a tracking mode; use one of "
                         f"{', '.join(map(repr, TRACKS))}")
    return track


def check_inputs(wall, ground_acceleration, dt, scale, cor, impact, tail, window=WINDOW,
                 t_rest=T_REST):
    """Validate the arguments shared by every solver; returns (ag, dt, ntail, law)."""
    check_t_rest(t_rest)
    if not isinstance(wall, Wall):
        raise InputError(f"wall must be a urmx.Wall, not {type(wall).__name__}")
    dt = _float("dt", dt, "a number of seconds")
    if not (math.isfinite(dt) and dt > 0.0):
        raise InputError(f"dt={dt!r} must be a positive, finite time step in seconds")
    if not DT_RANGE[0] <= dt <= DT_RANGE[1]:
        raise InputError(f"dt={dt!r} s is not a record step the kernel accepts: it must lie "
                         f"in [{DT_RANGE[0]:g}, {DT_RANGE[1]:g}] s")
    ag = np.asarray(ground_acceleration, dtype=float)
    if ag.ndim != 1 or ag.size < 2:
        raise InputError(f"ground_acceleration must be a 1-D array of at least 2 samples "
                         f"(got shape {ag.shape})")
    if not np.isfinite(ag).all():
        bad = ~np.isfinite(ag)
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"ground_acceleration has {int(bad.sum())} NaN/inf sample(s), the "
                         f"first at index {i} (t = {i * dt:g} s)")
    scale = _float("scale", scale, "a number")
    if not math.isfinite(scale):
        raise InputError(f"scale={scale!r} must be finite")
    cor = _float("cor", cor, "a number in (0, 1]")
    if not (0.0 < cor <= 1.0):
        raise InputError(f"cor={cor!r} must lie in (0, 1] (coefficient of restitution)")
    if impact not in LAWS:
        raise InputError(f"impact={impact!r} is not an impact law; use one of "
                         f"{', '.join(map(repr, LAWS))}")
    tail = _float("tail", tail, "a duration in seconds")
    if not (math.isfinite(tail) and tail >= 0.0):
        raise InputError(f"tail={tail!r} must be a non-negative duration in seconds")
    window = float(window)
    if not (math.isfinite(window) and 0.0 < window < dt):
        raise InputError(f"window={window!r} must lie in (0, dt)")
    ntail = int(round(tail / dt))
    return ag * scale, dt, ntail, LAWS[impact]

