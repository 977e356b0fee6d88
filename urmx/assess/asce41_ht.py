"""Procedure asce41_ht (being written: see urmx.assess for the interface)."""

from __future__ import annotations

from ..model import Wall
from .result import Assessment

SOURCE = ""


def asce41_ht(wall: Wall, s_x1, position=None) -> Assessment:
    """Not yet written: not applicable. `s_x1`: S_X1 [g] as a number, or a demand (its
    5 %-damped Sa at 1 s over g)."""
    return Assessment.not_applicable("asce41_ht", SOURCE, "not yet written")
