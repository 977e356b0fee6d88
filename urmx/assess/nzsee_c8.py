"""Procedure nzsee_c8 (being written: see urmx.assess for the interface)."""

from __future__ import annotations

from ..model import Wall
from .result import Assessment

SOURCE = ""


def nzsee_c8(wall: Wall, demand, position=None, **options) -> Assessment:
    """Not yet written: not applicable."""
    return Assessment.not_applicable("nzsee_c8", SOURCE, "not yet written")
