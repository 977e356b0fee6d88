"""Assessment procedures for out-of-plane URM walls, and their comparison with urmx's IDA.

One module per procedure, each a pure function of a `urmx.Wall` and a demand:

- `nzsee_c8` (`urmx.assess.nzsee_c8`): NZSEE 2017 C8, displacement-based out-of-plane
  assessment of face-loaded walls, with the parts demand of NZS 1170.5 Section 8 (%NBS);
- `asce41_ht` (`urmx.assess.asce41_ht`): permissible height-to-thickness ratios of URM walls
  loaded out of plane (ASCE 41 / FEMA 356), by wall position and S_X1;
- `ntc_kinematic` (`urmx.assess.ntc_kinematic`): the kinematic analysis of local mechanisms
  of NTC 2018 / Circolare 2019 C8.7.1 (EC8-3 Annex C), linear and nonlinear checks;
- `doherty` (`urmx.assess.doherty`): the displacement-based method of Doherty et al. (2002)
  / Griffith et al. (2003) on urmx's own trilinear curve.

The procedure interface
-----------------------
Every registered procedure is called as ::

    assessment = procedure(wall, demand, position=None, **options)

- ``wall``: a `urmx.Wall`, its supports included (a rigid or flexible top diaphragm, a rigid
  or flexible bottom).
- ``demand``: a `urmx.assess.demand.RecordDemand` (a record at a scale factor, with its
  5 %-damped spectrum computed once: `record_demand`) or a
  `urmx.assess.nzs1170.DesignSpectrum` (NZS 1170.5: Z, site class, R, N). Both give
  ``sa(T)`` [m s-2], ``sd(T)`` [m], ``pga`` [m s-2], ``scale`` and ``scaled(s)``.
- ``position``: a `urmx.assess.demand.Position` or a storey name (``"one-storey"``,
  ``"first"``, ``"top"``, ``"other"``); None: what the wall's supports imply
  (`urmx.assess.demand.position_of`).
- It returns an `urmx.assess.result.Assessment`: verdict (``"pass"``, ``"fail"`` or ``"not
  applicable"`` with a one-line ``reason``), capacity and demand in one unit,
  ``capacity_scale``, every intermediate ``Quantity`` with its unit, and the source.
- Bad arguments (not a Wall, not a demand, a bad option) raise `urmx.errors.InputError`; a
  wall outside the procedure's scope, a demand that lacks what it needs, or a spectrum
  missing at the needed period give ``verdict == "not applicable"``: never a silent number.

Capacity scale: the factor on the demand's intensity at which the check is exactly at its
limit, on the demand's own ``scale`` (for a record: the record scale factor, the currency of
the IDA's ``collapse_scale``). A check whose demand is proportional to the intensity and
whose capacity is not (every spectral check here) gives ``scale * capacity / demand``
(`urmx.assess.result.linear_capacity_scale`); a binary check (ASCE 41's h/t) gives the
scale at which the demand's S_X1 leaves the last bin whose limit the wall meets.

The registry
------------
`PROCEDURES` maps a name to its function; `compare` iterates it in order. Adding a
procedure is one line: ``PROCEDURES["name"] = function`` (or :func:`register`).
"""

from __future__ import annotations

from collections.abc import Callable

from .demand import Position, RecordDemand, position_of, record_demand
from .nzs1170 import DesignSpectrum
from .result import Assessment, NotApplicable, Quantity

#: name -> ``procedure(wall, demand, position=None, **options)`` returning an `Assessment`,
#: in report order
PROCEDURES: dict[str, Callable[..., Assessment]] = {}


def register(name: str, function: Callable[..., Assessment]) -> Callable[..., Assessment]:
    """Add a procedure to `PROCEDURES` (the comparison and ``urmx assess`` run it).

    Parameters
    ----------
    name : str
        The procedure's name in `PROCEDURES`.
    function : callable
        ``procedure(wall, demand, position=None, **options)`` returning an `Assessment`.
    """
    PROCEDURES[name] = function
    return function


from .asce41_ht import asce41_ht  # noqa: E402 (the registry first)
from .doherty import doherty  # noqa: E402
from .ntc_kinematic import ntc_kinematic  # noqa: E402
from .nzsee_c8 import nzsee_c8  # noqa: E402
from .urmx_rule import urmx_rule  # noqa: E402

register("nzsee_c8", nzsee_c8)
register("asce41_ht", asce41_ht)
register("ntc_kinematic", ntc_kinematic)
register("doherty", doherty)
register("urmx_rule", urmx_rule)  # urmx's own rule (issue 37, urmx.assess.urmx_rule)


__all__ = ["PROCEDURES", "Assessment", "DesignSpectrum", "NotApplicable", "Position", "Quantity",
           "RecordDemand", "asce41_ht", "doherty", "ntc_kinematic", "nzsee_c8",
           "position_of", "record_demand", "register", "urmx_rule"]
