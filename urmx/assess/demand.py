"""Demands of the assessment procedures, and where a wall stands in its building.

A demand is one of:

- `RecordDemand`: a ground-motion record at a scale factor. Its 5 %-damped pseudo-spectral
  acceleration is computed once, with urmx's exact recursion
  (`urmx.records.measures.pseudo_spectral_acceleration`, the one behind the ``sa_*``
  intensity measures of `urmx.fragility.intensity`), on `RECORD_PERIODS` (log-spaced) and
  interpolated linearly in log-period and log-acceleration between them; period 0 is the
  record's peak ground acceleration. A period outside the computed range has no spectrum:
  :meth:`sa` raises `NotApplicable` (the procedure reports it, never extrapolates).
- `DesignSpectrum`: the NZS 1170.5:2004 elastic site hazard spectrum (Section 3.1), given by
  the hazard factor ``Z``, the site subsoil class, the return period factor ``R`` and the
  near-fault factor ``N`` (`urmx.assess.nzs1170` for the spectral shape factor).

Every demand has ``sa(T)`` [m s-2], ``sd(T)`` [m] (``sa (T / 2 pi)^2``), ``pga`` [m s-2]
(``sa(0)``), ``scale`` (the factor its spectrum carries: the record scale factor, or the
factor on the design spectrum) and ``scaled(s)`` (the same demand with its spectrum times
``s``). A procedure's capacity scale is expressed on this same ``scale``.

`Position` is where the wall stands: the storey (ASCE 41's wall positions) and the heights
of the wall's base and of the building, which the parts demand of NZS 1170.5 Section 8 and
the kinematic checks at height of NTC 2018 need. `position_of` gives the default a wall's
supports imply (module docstring of :func:`position_of`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..model import Wall
from ..records.measures import pseudo_spectral_acceleration
from ..records.record import as_record
from .result import NotApplicable

G = 9.81  # m s-2: urmx.model.PAPER_G, the g of every procedure here (coefficients in g)
DAMPING = 0.05  # of every response spectrum here [1]
#: periods of a record's spectrum (0 is added: the PGA) [s]
RECORD_PERIODS = np.geomspace(0.01, 10.0, 361)
POSITIONS = ("one-storey", "first", "top", "other")


@dataclass(frozen=True)
class RecordDemand:
    """A record at a scale factor, with its 5 %-damped spectrum (module docstring).

    Build it with :func:`record_demand`. ``periods`` [s] and ``psa`` [m s-2] are the
    spectrum of the record at scale 1 (its samples times the record's own scale factor, as a
    study analyses it); ``scale`` multiplies them.
    """

    label: str
    periods: np.ndarray = field(repr=False, compare=False)
    psa: np.ndarray = field(repr=False, compare=False)
    pga_unscaled: float = field(repr=False)
    scale: float = 1.0
    kind: str = "record"

    def scaled(self, s: float) -> RecordDemand:
        """The same record demand with its scale multiplied by `s`.

        Parameters
        ----------
        s : float
            Factor on the scale. [1]
        """
        return RecordDemand(self.label, self.periods, self.psa, self.pga_unscaled,
                            self.scale * s)

    @property
    def pga(self) -> float:
        """Peak ground acceleration at this scale. [m s-2]"""
        return self.scale * self.pga_unscaled

    def sa(self, period: float) -> float:
        """5 %-damped pseudo-spectral acceleration at `period` [s]; 0 gives the PGA; a
        period outside the computed range raises `NotApplicable`. [m s-2]

        Parameters
        ----------
        period : float
            Period; 0 gives the PGA. [s]
        """
        t = float(period)
        if not math.isfinite(t) or t < 0.0:
            raise NotApplicable(f"record {self.label}: no spectrum at period {t!r} s")
        if t == 0.0:
            return self.pga
        lo, hi = float(self.periods[0]), float(self.periods[-1])
        if t < lo * (1 - 1e-12) or t > hi * (1 + 1e-12):
            raise NotApplicable(f"record {self.label} has no spectrum at T = {t:.4g} s "
                                f"(computed over {lo:g}-{hi:g} s)")
        y = np.interp(math.log(t), np.log(self.periods), np.log(self.psa))
        return self.scale * float(np.exp(y))

    def sd(self, period: float) -> float:
        """Spectral displacement ``sa (T / 2 pi)^2`` at `period` [s]. [m]

        Parameters
        ----------
        period : float
            Period; 0 gives the PGA. [s]
        """
        return self.sa(period) * (period / (2.0 * math.pi)) ** 2

    def describe(self) -> str:
        """The record's label and scale, for reports (``record elcentro x 1.5``)."""
        return f"record {self.label} x {self.scale:g}"


def record_demand(record, scale: float = 1.0, periods=None, records_dir=None,
                  label: str | None = None) -> RecordDemand:
    """The demand of a record (a `urmx.records.Record`, a manifest id, a file, or samples
    [m s-2] with their step [s]) at `scale`, its spectrum computed once on `periods` [s]
    (default `RECORD_PERIODS`); `label` names it (default: the record's id).

    Parameters
    ----------
    record : Record, str, path or (array, dt)
        A `urmx.records.Record`, a manifest id, a record file, or samples [m s-2] with their
        step [s].
    scale : float
        Factor on the record, > 0. [1]
    periods : array_like of float, optional
        Periods of its spectrum, positive and increasing (default `RECORD_PERIODS`). [s]
    records_dir : str or path-like, optional
        Records folder of a manifest id.
    label : str, optional
        Its name (default: the record's id).

    Raises
    ------
    urmx.errors.InputError
        A scale that is not a finite positive number, a record that cannot be read, or
        periods that are not positive and increasing.
    """
    scale = _positive("scale", scale)
    rec = as_record(record, records_dir) if isinstance(record, (str, os.PathLike)) \
        else as_record(record)
    periods = RECORD_PERIODS if periods is None else np.asarray(periods, dtype=float)
    if periods.ndim != 1 or periods.size < 2 or not np.all(periods > 0) \
            or not np.all(np.diff(periods) > 0):
        raise InputError("record_demand periods must be at least two positive, increasing "
                         "periods [s]")
    acc = np.asarray(rec.scaled(), dtype=float)
    if not np.all(np.isfinite(acc)):
        raise InputError(f"record {rec.id!r} has samples that are not finite numbers")
    psa = pseudo_spectral_acceleration(acc, rec.dt, periods, DAMPING)
    return RecordDemand(str(label or rec.id), periods, np.asarray(psa, dtype=float),
                        float(np.max(np.abs(acc))), scale)


def _positive(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer,
                                                         np.floating)) \
            or not math.isfinite(value) or value <= 0:
        raise InputError(f"{name}={value!r} must be a finite number greater than zero")
    return float(value)


@dataclass(frozen=True)
class Position:
    """Where a wall stands in its building.

    Parameters
    ----------
    storey : {"one-storey", "first", "top", "other"}
        ASCE 41's wall positions: a wall of a one-storey building, of the first storey of a
        multistorey building, of its top storey, or any other.
    base_height : float
        Height of the wall's base above the ground (the lower support). [m]
    building_height : float
        Height of the building's top level above the ground, h_n. [m]
    """

    storey: str
    base_height: float
    building_height: float

    def __post_init__(self) -> None:
        if self.storey not in POSITIONS:
            raise InputError(f"position storey={self.storey!r} must be one of "
                             f"{', '.join(POSITIONS)}")
        for name in ("base_height", "building_height"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                    or v < 0:
                raise InputError(f"position {name}={v!r} must be a finite height >= 0 [m]")
        if self.building_height <= 0 or self.base_height >= self.building_height:
            raise InputError("position base_height must lie below building_height "
                             f"({self.base_height:g} m, {self.building_height:g} m)")


def position_of(wall: Wall, position: Position | str | None = None) -> Position:
    """The wall's position: `position` when given (a `Position`, or a storey name with the
    heights below), else what its supports imply.

    Default heights: a wall with a rigid bottom stands on the ground (base height 0) of a
    one-storey building as high as the wall; a wall with a flexible bottom support (between
    two diaphragms, the catalog's ``"D1/both"``) is the top storey of a two-storey building
    of equal storeys (base height h, building height 2h). These are urmx's choices, not a
    source's: give a `Position` for another building.

    Parameters
    ----------
    wall : urmx.Wall
        The wall and its supports.
    position : Position, str or None
        A `Position`, a storey name (``"one-storey"``, ``"first"``, ``"top"``, ``"other"``)
        with the default heights, or None: what the supports imply.
    """
    if isinstance(position, Position):
        return position
    h = wall.height
    if position is None:
        position = "one-storey" if wall.bottom_rigid else "top"
    if not isinstance(position, str) or position not in POSITIONS:
        raise InputError(f"position={position!r} must be a Position or one of "
                         f"{', '.join(POSITIONS)}")
    if position == "one-storey":
        return Position(position, 0.0, h)
    if position == "first":
        return Position(position, 0.0, 2.0 * h)
    if position == "top":
        return Position(position, h, 2.0 * h)
    return Position(position, h, 3.0 * h)


def check_demand(demand, procedure: str) -> None:
    """Refuse an argument that is not a demand (an `urmx.errors.InputError`, one line)."""
    if not all(hasattr(demand, a) for a in ("sa", "sd", "scale", "pga")):
        raise InputError(f"{procedure}: demand must be a RecordDemand (urmx.assess."
                         f"record_demand) or a DesignSpectrum (urmx.assess.DesignSpectrum), "
                         f"not {type(demand).__name__}")


def check_wall(wall, procedure: str) -> None:
    """Refuse an argument that is not a `urmx.Wall` (an `urmx.errors.InputError`)."""
    if not isinstance(wall, Wall):
        raise InputError(f"{procedure}: wall must be a urmx.Wall, not {type(wall).__name__}")
