"""Intensity measures of a record for a wall, numpy only: the measures' names, units and long
names come from the variable registry (``im.<name>`` in ``urmx/variables.toml``).

``"pga"`` [m s-2], ``"pgv"`` [m s-1] (of the record as given), ``"sa_wall"``,
``"sa_diaphragm"`` and ``"sa_avg"`` [m s-2] (5 %-damped pseudo-spectral acceleration, the
exact recursion of `urmx.records.response_spectrum`) and ``"scale"`` [1] (the scale factor
itself). Every measure is proportional to the record's scale factor.

``sa_wall`` is taken at the wall's effective rocking period ``T_r``
(`urmx.fragility.mechanism.rocking_period`), ``sa_diaphragm`` at the period of the top
diaphragm ``T_d``, ``1 / f`` with the Table IV footnote SDOF frequency ``f`` of
`urmx.Wall.diaphragm_frequency` (stiffness over the diaphragm mass plus half the wall
mass). A rigid top support moves with the ground: its period is 0 and Sa is the PGA.

``sa_avg`` is the average spectral acceleration of Eads, Miranda & Lignos (2015, EESD 44):
the geometric mean of Sa at `SA_AVG_PERIODS` (10) log-spaced periods, both ends included,
over a range. The default range (:func:`sa_avg_range`) spans the wall's two periods with
half an octave to spare on either side, ``[min(T_d, T_r) / sqrt 2, sqrt 2 max(T_d, T_r)]``,
with its lower end no shorter than ``T_r / 2``: a stiff diaphragm (``T_d`` below
``T_r / sqrt 2``) moves nearly with the ground, and a rigid top (``T_d = 0``) gives the
rocking period's neighbourhood ``[T_r / 2, sqrt 2 T_r]``. The margin covers the lengthening
of the rocking period as the wall nears instability and the shift of the diaphragm's. A
range given by the user (``period_range``, [s]) replaces it for every wall.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .. import variables
from ..errors import InputError, numbers_argument
from ..model import PAPER_G, Wall
from ..records.measures import (
    SA_AVG_PERIODS,
    average_periods,
    check_period_range,
    geometric_mean_psa,
    pseudo_spectral_acceleration,
    velocity,
)
from ..records.readers import check_finite
from ..records.record import as_record
from .mechanism import diaphragm_period, rocking_period, wall_argument

IMS = variables.intensity_measures()  # pga, pgv, sa_wall, sa_diaphragm, sa_avg, scale
#: units and long name of each intensity measure (from the registry)
IM_ATTRS = {im: (variables.intensity_context(im)["im_units"],
                 variables.intensity_context(im)["im_name"]) for im in IMS}
#: the measures that are a property of the record and the wall (all but the scale factor)
RECORD_IMS = tuple(im for im in IMS if im != "scale")
DAMPING = 0.05  # of the spectral intensity measures [1]
#: default max_intensity per intensity measure, in its units
MAX_INTENSITY = {"pga": 5.0 * PAPER_G, "pgv": 5.0, "sa_wall": 5.0 * PAPER_G,
                 "sa_diaphragm": 5.0 * PAPER_G, "sa_avg": 5.0 * PAPER_G, "scale": 50.0}
SA_AVG_WIDEN = math.sqrt(2.0)  # the default range reaches this factor beyond both periods
SA_AVG_FLOOR = 0.5  # and starts no shorter than this fraction of the rocking period
_WALL_IMS = ("sa_wall", "sa_diaphragm", "sa_avg")

__all__ = ["IMS", "IM_ATTRS", "RECORD_IMS", "DAMPING", "MAX_INTENSITY", "SA_AVG_PERIODS",
           "check_im", "check_period_range", "sa_avg_range", "sa_avg_periods",
           "record_intensity", "record_intensities", "record_measures",
           "spectral_intensities"]


def check_im(im: str) -> None:
    """Refuse a name that is not an intensity measure (an `urmx.errors.InputError`).

    Parameters
    ----------
    im : str
        The name to check against `IMS`.
    """
    if im not in IMS:
        raise InputError(f"im={im!r} is not an intensity measure; use one of "
                         f"{', '.join(map(repr, IMS))}")


def sa_avg_range(wall: Wall) -> tuple[float, float]:
    """The default period range of ``sa_avg`` for a wall (module docstring):
    ``[max(min(T_d, T_r) / sqrt 2, T_r / 2), sqrt 2 max(T_d, T_r)]``. [s]

    Parameters
    ----------
    wall : urmx.Wall
        The wall and its supports.
    """
    wall_argument("sa_avg_range", wall)
    tr, td = rocking_period(wall), diaphragm_period(wall)
    return (max(min(td, tr) / SA_AVG_WIDEN, SA_AVG_FLOOR * tr), SA_AVG_WIDEN * max(td, tr))


def sa_avg_periods(wall: Wall | None = None, period_range=None,
                   n: int = SA_AVG_PERIODS) -> np.ndarray:
    """The periods ``sa_avg`` averages over: `n` log-spaced over `period_range` [s], or over
    the wall's default range (:func:`sa_avg_range`). [s]

    Parameters
    ----------
    wall : urmx.Wall, optional
        The wall whose default range is used when `period_range` is not given.
    period_range : (float, float), optional
        The range of periods. [s]
    n : int
        Number of periods.
    """
    if period_range is None:
        if wall is None:
            raise InputError("im='sa_avg' needs the wall (its periods) or a period_range")
        period_range = sa_avg_range(wall)
    return average_periods(period_range, n)


def record_intensity(record: Any, im: str = "pga", wall: Wall | None = None,
                     period_range=None) -> float:
    """Intensity of a record as analysed at scale 1: its samples times its own scale factor
    (a manifest id at the manifest's scale factor, as studies use it).

    Parameters
    ----------
    record : Record, obspy.Trace, str or (array, dt)
        The record (`urmx.records.as_record`); NaN samples are refused by name.
    im : {"pga", "pgv", "sa_wall", "sa_diaphragm", "sa_avg", "scale"}
        Intensity measure (module docstring).
    wall : urmx.Wall, optional
        Required by ``"sa_wall"``, ``"sa_diaphragm"`` and (without `period_range`)
        ``"sa_avg"``.
    period_range : (float, float), optional
        Periods of ``"sa_avg"`` instead of the wall's default range. [s]

    Returns
    -------
    float
        In the measure's units (`IM_ATTRS`): m s-2, m s-1 or 1.
    """
    check_im(im)
    if im in _WALL_IMS and wall is None and not (im == "sa_avg" and period_range):
        raise InputError(f"im={im!r} needs the wall (its period)")
    rec = as_record(record)
    acc = check_finite(rec.scaled(), f"record {rec.id!r}", rec.dt)
    return float(record_intensities(acc, rec.dt, im, [wall], period_range)[0])


def record_intensities(acceleration, dt: float, im: str, walls,
                       period_range=None) -> np.ndarray:
    """`record_intensity` of one record's samples [m s-2] at time step `dt` [s] for several
    walls at once (one pass of the response spectrum over all their periods), numpy only.
    [units of the measure]

    Parameters
    ----------
    acceleration : array_like of float
        The record's samples as analysed. [m s-2]
    dt : float
        Their time step. [s]
    im : str
        Intensity measure (`IMS`).
    walls : sequence of urmx.Wall
        The walls whose periods the spectral measures use.
    period_range : (float, float), optional
        Periods of ``sa_avg`` instead of each wall's default range. [s]
    """
    acc = numbers_argument("record_intensities", "acceleration", acceleration)
    if im == "scale":
        return np.ones(len(walls))
    if im == "pga":
        return np.full(len(walls), float(np.max(np.abs(acc))))
    if im == "pgv":
        return np.full(len(walls), float(np.max(np.abs(velocity(acc, dt)))))
    if im == "sa_avg":
        periods = np.array([sa_avg_periods(w, period_range) for w in walls])
        return geometric_mean_psa(acc, dt, periods, DAMPING)
    period = rocking_period if im == "sa_wall" else diaphragm_period
    return _spectral(acc, dt, [period(w) for w in walls])


def record_measures(acceleration, dt: float, walls, period_range=None) -> dict[str, np.ndarray]:
    """Every measure of `RECORD_IMS` of one record's samples [m s-2] at step `dt` [s] for
    several walls, in one pass of the response spectrum over all their periods, numpy
    only: measure -> array over `walls`. [units of each measure]

    Parameters
    ----------
    acceleration : array_like of float
        The record's samples as analysed. [m s-2]
    dt : float
        Their time step. [s]
    walls : sequence of urmx.Wall
        The walls whose periods the spectral measures use.
    period_range : (float, float), optional
        Periods of ``sa_avg`` instead of each wall's default range. [s]
    """
    acc = numbers_argument("record_measures", "acceleration", acceleration)
    avg = np.array([sa_avg_periods(w, period_range) for w in walls]).reshape(len(walls), -1)
    own = np.array([[rocking_period(w), diaphragm_period(w)] for w in walls]).reshape(-1, 2)
    uniq, inv = np.unique(np.concatenate([own.ravel(), avg.ravel()]), return_inverse=True)
    psa = pseudo_spectral_acceleration(acc, dt, uniq, DAMPING)[inv]
    k = own.size
    with np.errstate(divide="ignore"):
        mean = np.exp(np.mean(np.log(psa[k:].reshape(avg.shape)), axis=1))
    pga = float(np.max(np.abs(acc)))
    pgv = float(np.max(np.abs(velocity(acc, dt))))
    return {"pga": np.full(len(walls), pga), "pgv": np.full(len(walls), pgv),
            "sa_wall": psa[:k:2], "sa_diaphragm": psa[1:k:2], "sa_avg": mean}


def spectral_intensities(record: Any, periods) -> np.ndarray:
    """5 %-damped pseudo-spectral accelerations of a record as analysed (times its own scale
    factor) at `periods` [s] (0: the PGA), in one pass of the exact recursion. [m s-2]

    Parameters
    ----------
    record : Record, obspy.Trace, str or (array, dt)
        The record (`urmx.records.as_record`), analysed times its own scale factor.
    periods : array_like of float
        Periods of the spectral accelerations (0: the PGA). [s]
    """
    rec = as_record(record)
    return _spectral(rec.scaled(), rec.dt, periods)


def _spectral(acc: np.ndarray, dt: float, periods) -> np.ndarray:
    periods = np.asarray(periods, dtype=float)
    uniq, inv = np.unique(periods, return_inverse=True)
    return pseudo_spectral_acceleration(acc, dt, uniq, DAMPING)[inv]
