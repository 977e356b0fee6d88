"""Intensity measures of a record for a wall, numpy only: the measures' names, units and long
names come from the variable registry (``im.<name>`` in ``urmx/variables.toml``).

``"pga"`` [m s-2], ``"pgv"`` [m s-1] (of the record as given), ``"sa_wall"`` and
``"sa_diaphragm"`` [m s-2] (5 %-damped pseudo-spectral acceleration, the exact recursion of
`urmx.records.response_spectrum`) and ``"scale"`` [1] (the scale factor itself). Every
measure is proportional to the record's scale factor.

``sa_wall`` is taken at the wall's effective rocking period
(`urmx.fragility.mechanism.rocking_period`), ``sa_diaphragm`` at the period of the top
diaphragm, ``1 / f`` with the Table IV footnote SDOF frequency ``f`` of
`urmx.Wall.diaphragm_frequency` (stiffness over the diaphragm mass plus half the wall
mass). A rigid top support moves with the ground: its period is 0 and Sa is the PGA.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import variables
from ..errors import InputError
from ..model import PAPER_G, Wall
from ..records.measures import pseudo_spectral_acceleration, velocity
from ..records.record import as_record
from .mechanism import diaphragm_period, rocking_period

IMS = variables.intensity_measures()  # pga, pgv, sa_wall, sa_diaphragm, scale
#: units and long name of each intensity measure (from the registry)
IM_ATTRS = {im: (variables.intensity_context(im)["im_units"],
                 variables.intensity_context(im)["im_name"]) for im in IMS}
DAMPING = 0.05  # of the spectral intensity measures [1]
#: default max_intensity per intensity measure, in its units
MAX_INTENSITY = {"pga": 5.0 * PAPER_G, "pgv": 5.0, "sa_wall": 5.0 * PAPER_G,
                 "sa_diaphragm": 5.0 * PAPER_G, "scale": 50.0}


def check_im(im: str) -> None:
    """Refuse a name that is not an intensity measure (an `urmx.errors.InputError`)."""
    if im not in IMS:
        raise InputError(f"im={im!r} is not an intensity measure; use one of "
                         f"{', '.join(map(repr, IMS))}")


def record_intensity(record: Any, im: str = "pga", wall: Wall | None = None) -> float:
    """Intensity of a record as analysed at scale 1: its samples times its own scale factor
    (a manifest id at the manifest's scale factor, as studies use it).

    Parameters
    ----------
    record : Record, obspy.Trace, str or (array, dt)
        The record (`urmx.records.as_record`).
    im : {"pga", "pgv", "sa_wall", "sa_diaphragm", "scale"}
        Intensity measure (module docstring).
    wall : urmx.Wall, optional
        Required by ``"sa_wall"`` and ``"sa_diaphragm"``.

    Returns
    -------
    float
        In the measure's units (`IM_ATTRS`): m s-2, m s-1 or 1.
    """
    check_im(im)
    if im in ("sa_wall", "sa_diaphragm") and wall is None:
        raise InputError(f"im={im!r} needs the wall (its period)")
    rec = as_record(record)
    return float(record_intensities(rec.scaled(), rec.dt, im, [wall])[0])


def record_intensities(acceleration, dt: float, im: str, walls) -> np.ndarray:
    """`record_intensity` of one record's samples [m s-2] at time step `dt` [s] for several
    walls at once (one pass of the response spectrum over all their periods), numpy only.
    [units of the measure]"""
    acc = np.asarray(acceleration, dtype=float)
    if im == "scale":
        return np.ones(len(walls))
    if im == "pga":
        return np.full(len(walls), float(np.max(np.abs(acc))))
    if im == "pgv":
        return np.full(len(walls), float(np.max(np.abs(velocity(acc, dt)))))
    period = rocking_period if im == "sa_wall" else diaphragm_period
    return _spectral(acc, dt, [period(w) for w in walls])


def spectral_intensities(record: Any, periods) -> np.ndarray:
    """5 %-damped pseudo-spectral accelerations of a record as analysed (times its own scale
    factor) at `periods` [s] (0: the PGA), in one pass of the exact recursion. [m s-2]"""
    rec = as_record(record)
    return _spectral(rec.scaled(), rec.dt, periods)


def _spectral(acc: np.ndarray, dt: float, periods) -> np.ndarray:
    periods = np.asarray(periods, dtype=float)
    uniq, inv = np.unique(periods, return_inverse=True)
    return pseudo_spectral_acceleration(acc, dt, uniq, DAMPING)[inv]
