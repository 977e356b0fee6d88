"""The result of one assessment procedure: `Assessment`, a frozen record of the verdict, the
capacity and demand, the capacity scale, every intermediate quantity with its unit, and the
source; or the same object marked not applicable, with the reason.

A procedure never returns a number it could not compute from its source: where the wall is
outside the procedure's scope, the demand lacks what it needs, or a part of the source could
not be found, the result has ``verdict == "not applicable"``, NaN capacity, demand and
capacity scale, and ``reason`` says why in one line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

PASS = "pass"
FAIL = "fail"
NOT_APPLICABLE = "not applicable"
VERDICTS = (PASS, FAIL, NOT_APPLICABLE)


class NotApplicable(Exception):  # noqa: N818 (a state, not an error a user sees)
    """Raised inside a procedure when the wall, the demand or the source leaves the check
    undefined; the procedure turns it into ``Assessment.not_applicable(reason)``."""


@dataclass(frozen=True)
class Quantity:
    """One intermediate value of a procedure.

    Parameters
    ----------
    value : float
        In `unit`.
    unit : str
        UDUNITS-style unit (``"m"``, ``"s"``, ``"m s-2"``, ``"1"``, ``"%"``, ``"g"``).
    description : str
        What it is, with the source's symbol.
    ref : str
        Where the source defines it (equation, clause or table).
    """

    value: float
    unit: str
    description: str
    ref: str = ""

    def to_dict(self) -> dict[str, Any]:
        """Plain data for JSON (NaN as null, inf as the string ``"inf"``)."""
        return {"value": _json_number(self.value), "unit": self.unit,
                "description": self.description, "ref": self.ref}


def _json_number(v: float) -> float | None | str:
    v = float(v)
    if math.isnan(v):
        return None
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return v


@dataclass(frozen=True)
class Assessment:
    """The outcome of one procedure for one wall and one demand.

    Parameters
    ----------
    procedure : str
        The procedure's registry name (``"nzsee_c8"``, ``"asce41_ht"``, ...).
    source : str
        Document, edition, section and equations the check follows.
    verdict : {"pass", "fail", "not applicable"}
        ``"pass"`` when the capacity reaches the demand (the check holds at the demand).
    capacity, demand : float
        The check's two sides, in `unit` (NaN when not applicable).
    unit : str
        Unit of `capacity` and `demand`.
    capacity_scale : float
        The factor on the demand's intensity at which the check is exactly at its limit,
        expressed as a record scale factor (for a record demand) or a factor on the design
        spectrum (for a design spectrum); inf when no intensity fails the wall, 0 when every
        intensity does. [1]
    quantities : dict of str to Quantity
        Every intermediate value, in the order computed.
    reason : str
        Why the procedure is not applicable (empty otherwise), or a note on a choice made.
    """

    procedure: str
    source: str
    verdict: str
    capacity: float = math.nan
    demand: float = math.nan
    unit: str = ""
    capacity_scale: float = math.nan
    quantities: dict[str, Quantity] = field(default_factory=dict, compare=False)
    reason: str = ""

    def __post_init__(self) -> None:
        if self.verdict not in VERDICTS:
            raise ValueError(f"verdict {self.verdict!r} is not one of {VERDICTS}")

    @classmethod
    def not_applicable(cls, procedure: str, source: str, reason: str,
                       quantities: dict[str, Quantity] | None = None) -> Assessment:
        """The result of a check that cannot be made, with the one-line reason.

        Parameters
        ----------
        procedure : str
            The procedure's name.
        source : str
            The document it comes from (document, section, equation).
        reason : str
            Why it cannot be applied, in one line.
        quantities : dict of str to Quantity, optional
            The quantities computed before it stopped.
        """
        return cls(procedure=procedure, source=source, verdict=NOT_APPLICABLE,
                   quantities=dict(quantities or {}), reason=reason)

    @property
    def applicable(self) -> bool:
        return self.verdict != NOT_APPLICABLE

    @property
    def passed(self) -> bool:
        return self.verdict == PASS

    def __getitem__(self, name: str) -> float:
        """The value of an intermediate quantity (its unit in ``quantities[name].unit``)."""
        return self.quantities[name].value

    def to_dict(self) -> dict[str, Any]:
        """Plain data for JSON (NaN as null, inf as the string ``"inf"``)."""
        return {"procedure": self.procedure, "verdict": self.verdict,
                "capacity": _json_number(self.capacity), "demand": _json_number(self.demand),
                "unit": self.unit, "capacity_scale": _json_number(self.capacity_scale),
                "reason": self.reason, "source": self.source,
                "quantities": {k: q.to_dict() for k, q in self.quantities.items()}}

    def summary(self) -> str:
        """One line: procedure, verdict, capacity against demand, capacity scale."""
        if not self.applicable:
            return f"{self.procedure}: not applicable: {self.reason}"
        return (f"{self.procedure}: {self.verdict}: capacity {self.capacity:.4g} "
                f"{self.unit} against demand {self.demand:.4g} {self.unit}; "
                f"capacity scale {self.capacity_scale:.4g}")


def verdict(capacity: float, demand: float) -> str:
    """``"pass"`` when ``capacity >= demand``, else ``"fail"``."""
    return PASS if capacity >= demand else FAIL


def linear_capacity_scale(scale: float, capacity: float, demand: float) -> float:
    """The capacity scale of a check whose demand is proportional to the intensity and whose
    capacity does not depend on it: ``scale * capacity / demand`` (inf for zero demand). [1]"""
    if demand <= 0.0:
        return math.inf
    return scale * capacity / demand
