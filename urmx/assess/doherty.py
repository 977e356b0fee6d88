"""Procedure doherty (being written: see urmx.assess for the interface)."""

from __future__ import annotations

from ..model import Wall
from .result import Assessment

SOURCE = ""


def doherty(wall: Wall, demand, position=None, **options) -> Assessment:
    """Not yet written: not applicable."""
    return Assessment.not_applicable("doherty", SOURCE, "not yet written")
