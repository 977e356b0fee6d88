"""Procedure ntc_kinematic (being written: see urmx.assess for the interface)."""

from __future__ import annotations

from ..model import Wall
from .result import Assessment

SOURCE = ""


def ntc_kinematic(wall: Wall, demand, position=None, **options) -> Assessment:
    """Not yet written: not applicable."""
    return Assessment.not_applicable("ntc_kinematic", SOURCE, "not yet written")
