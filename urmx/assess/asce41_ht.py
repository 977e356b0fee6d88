"""Permissible height-to-thickness ratios of URM walls loaded out of plane (ASCE/SEI 41-17's
check), by wall position and S_X1: pass when the wall's h/t does not exceed the limit.

Sources, and what could be found. ASCE/SEI 41-17 (its URM out-of-plane h/t table in
Chapter 11), FEMA 356 (2000) Table 7-5 and the IEBC's Appendix A1 table, the documents the
issue names, could not be found in any searchable public copy; urmx does not write their
limits from memory. The one public text of such a table that was found is an earlier,
equivalent provision: **Table No. A1-F, "Allowable value of height-thickness (h/t) ratio of
unreinforced masonry walls with minimum quality mortar"**, of a municipal code that adopts
the UCBC Appendix Chapter 1 provisions for URM bearing-wall buildings (the predecessor of the
IEBC's Appendix A1; published at ecode360.com/44513729):

=========================================  =============================  =================
wall                                       buildings with complying       all other
                                           cross walls                    buildings
=========================================  =============================  =================
one-story building walls                   13 - 16 (footnotes 3, 4, 5)    13
first story of multi-story buildings       16                             15
walls in the top story of multi-story      9 - 14 (footnotes 3, 4, 5)     9
buildings
all other walls                            16                             13
=========================================  =============================  =================

Its footnotes 4 and 5 allow the larger value of a range only where mortar shear tests (at
least 100 psi, or 60 psi with 50 % collar-joint coverage) establish it, interpolating between
30 and 60 psi. That table gives **one set of limits for every intensity** (the code's seismic
zone): it has no S_X1 bins. So `asce41_ht` applies it at every S_X1, and says so; its
capacity scale is therefore inf for a wall within the limit (accepted at every intensity)
and 0 for a wall beyond it. ``cross_walls`` (default False: "all other buildings") and
``tested_mortar`` (default False: the smaller value of a range) choose the column.

The machinery is general: a `HtTable` holds bins ``(s_x1_upper, limits by position)``, each
bin covering ``(previous upper, upper]`` (an S_X1 on a bin edge belongs to the lower bin);
a table with S_X1 bins (ASCE 41's, once its text is at hand) is one more `HtTable`.

Flexible diaphragms: the table has no provision for them (nor for the diaphragm at all);
the check is the same for any support.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import InputError
from ..model import PAPER_G, Wall
from .demand import POSITIONS, check_wall, position_of
from .result import FAIL, PASS, Assessment, NotApplicable, Quantity

NAME = "asce41_ht"
S_X1_PERIOD = 1.0  # s: S_X1 is the spectral response acceleration at a period of 1 s
UCBC_SOURCE = ("Table No. A1-F (h/t of URM walls with minimum quality mortar) of a municipal "
               "code adopting the UCBC Appendix Chapter 1 provisions (ecode360.com/44513729), "
               "used because ASCE/SEI 41-17's table, FEMA 356 Table 7-5 and IEBC Appendix A1's "
               "table could not be found; no S_X1 bins")
SOURCE = UCBC_SOURCE


@dataclass(frozen=True)
class HtTable:
    """Permissible h/t by S_X1 bin and wall position.

    Parameters
    ----------
    bins : tuple of (float, dict)
        ``(upper S_X1 [g] of the bin, {position: limit})``, ascending; the last upper may be
        inf. A bin covers ``(previous upper, upper]``, the first one ``[0, upper]``.
    source : str
        Where the limits come from.
    """

    bins: tuple
    source: str

    def __post_init__(self) -> None:
        uppers = [u for u, _ in self.bins]
        if not uppers or any(b <= a for a, b in zip(uppers, uppers[1:], strict=False)):
            raise InputError("HtTable bins must be given in ascending S_X1 order")
        for _, limits in self.bins:
            if set(limits) != set(POSITIONS):
                raise InputError(f"HtTable: each bin needs a limit for {', '.join(POSITIONS)}")

    def limit(self, s_x1: float, position: str) -> float:
        """The permissible h/t at `s_x1` [g] for `position`; NaN beyond the last bin."""
        for upper, limits in self.bins:
            if s_x1 <= upper:
                return float(limits[position])
        return math.nan

    def capacity_scale(self, h_over_t: float, s_x1: float, position: str,
                       scale: float) -> float:
        """The scale at which the demand's S_X1 (``s_x1`` at `scale`, proportional to it)
        leaves the last bin whose limit the wall meets: inf if it meets the last bin's,
        0 if it meets none from S_X1 = 0. [1]"""
        if s_x1 <= 0:
            return math.inf if h_over_t <= self.limit(0.0, position) else 0.0
        reach = 0.0  # the highest S_X1 up to which every bin is met
        for upper, limits in self.bins:
            if h_over_t > limits[position]:
                break
            reach = upper
        return math.inf if math.isinf(reach) else scale * reach / s_x1


def _ucbc_table(cross_walls: bool, tested_mortar: bool) -> HtTable:
    if cross_walls:
        one, top = (16.0, 14.0) if tested_mortar else (13.0, 9.0)
        limits = {"one-storey": one, "first": 16.0, "top": top, "other": 16.0}
    else:
        limits = {"one-storey": 13.0, "first": 15.0, "top": 9.0, "other": 13.0}
    column = ("buildings with complying cross walls" + (", tested mortar" if tested_mortar
                                                        else "")) if cross_walls else \
        "all other buildings"
    return HtTable(((math.inf, limits),), f"{UCBC_SOURCE}; column: {column}")


def asce41_ht(wall: Wall, s_x1, position=None, cross_walls: bool = False,
              tested_mortar: bool = False, table: HtTable | None = None) -> Assessment:
    """The h/t check of a URM wall loaded out of plane (module docstring).

    Parameters
    ----------
    wall : urmx.Wall
        Its ``height / thickness`` is checked.
    s_x1 : float or demand
        S_X1 [g], or a demand (`urmx.assess.demand`): its 5 %-damped Sa at 1 s over g.
    position : str or Position, optional
        ``"one-storey"``, ``"first"``, ``"top"`` or ``"other"``; default: what the wall's
        supports imply (`urmx.assess.demand.position_of`).
    cross_walls, tested_mortar : bool
        The column of Table A1-F (module docstring).
    table : HtTable, optional
        Another table (its source named in it) instead of Table A1-F.

    Returns
    -------
    Assessment
        Capacity: the permissible h/t; demand: the wall's h/t [1]; capacity scale from the
        bins (`HtTable.capacity_scale`).
    """
    check_wall(wall, NAME)
    pos = position_of(wall, position)
    table = table or _ucbc_table(bool(cross_walls), bool(tested_mortar))
    q = {"h_over_t": Quantity(wall.slenderness, "1", "wall slenderness h/t")}
    try:
        value, scale = _s_x1(s_x1)
    except NotApplicable as exc:
        return Assessment.not_applicable(NAME, table.source, str(exc), q)
    q["S_X1"] = Quantity(value, "g", "S_X1: 5 %-damped Sa at 1 s of the demand")
    limit = table.limit(value, pos.storey)
    if math.isnan(limit):
        return Assessment.not_applicable(NAME, table.source, f"S_X1 = {value:.3g} g lies "
                                         "beyond the table's last bin", q)
    q["limit"] = Quantity(limit, "1", f"permissible h/t, {pos.storey} wall")
    ht = wall.slenderness
    verdict = PASS if ht <= limit else FAIL
    cap = table.capacity_scale(ht, value, pos.storey, scale)
    return Assessment(NAME, table.source, verdict, limit, ht, "1", cap, q,
                      "no provision for flexible diaphragms: the same check for any support")


def _s_x1(s_x1) -> tuple[float, float]:
    """(S_X1 [g], the demand's scale) of a number [g] or a demand."""
    if hasattr(s_x1, "sa") and hasattr(s_x1, "scale"):
        return s_x1.sa(S_X1_PERIOD) / PAPER_G, float(s_x1.scale)
    if isinstance(s_x1, bool) or not isinstance(s_x1, (int, float)) or not math.isfinite(s_x1) \
            or s_x1 < 0:
        raise InputError(f"asce41_ht: s_x1={s_x1!r} must be S_X1 in g (a finite number >= 0) "
                         "or a demand")
    return float(s_x1), 1.0
