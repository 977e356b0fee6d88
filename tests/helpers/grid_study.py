"""The small grid study's stand-ins (`tests/test_study.py`, and the tests that run the same
records: cells, study files' t_rest): two synthetic records, "quake" (a sine, PGA 2.0 m s-2,
200 samples) and "shake" (a pulse, PGA 3.0, 150 samples), and `fake_kernel`, a kernel with
hand-computable outputs that logs its calls in `CALLS` and raises `Interrupt` at analysis
number ``FAIL_AT[0]``; the study files `STUDY` (2 x 2 x 2 x 2 cells, two histories kept)
and `DIMS_STUDY` (every grid dimension). Fixture: ``grid_records`` (conftest.py)."""

from __future__ import annotations

import math

import numpy as np

from urmx import variables

from .runs import Interrupt

DT = 0.01
# two synthetic records: "quake" (PGA 2.0 m s-2, 200 samples), "shake" (PGA 3.0, 150 samples)
ACC = {"quake": 2.0 * np.sin(np.linspace(0.0, 4.0 * np.pi, 200)) / np.sin(np.pi / 2),
       "shake": np.r_[np.zeros(10), 3.0, -1.0, np.zeros(138)]}
ACC["quake"][50] = 2.0  # exact PGA
SCALE = {"quake": 0.5, "shake": 2.0}
CALLS: list[tuple] = []
FAIL_AT: list[int] = []  # raise Interrupt instead of running the analysis number FAIL_AT[0]


def fake_kernel(wall, ground_acceleration, dt, *, scale=1.0, cor=0.8, impact="scale", tail=0.0,
                history=False):
    """A stand-in with the interface of urmx.kernel.run and hand-computable outputs."""
    pga = scale * float(np.max(np.abs(ground_acceleration)))
    if FAIL_AT and len(CALLS) == FAIL_AT[0]:
        raise Interrupt
    CALLS.append((wall.height, wall.top_stiffness, round(pga, 9), cor, impact))
    out = {name: 0.0 for name in variables.SCALARS}
    out["peak_crack_displacement"] = pga * wall.height * cor / 100.0
    out["peak_top_displacement"] = (len(ground_acceleration) - 1) * dt + tail
    out["peak_top_acceleration"] = 1.0 if impact == "contact" else 0.0
    out["instability_ratio"] = min(1.0, pga * cor / wall.slenderness)
    out["collapsed"] = int(out["instability_ratio"] >= 1.0)
    out["collapse_time"] = 1.5 if out["collapsed"] else math.nan
    out["base_impacts"] = 7
    out["status"] = "collapsed" if out["collapsed"] else "ok"
    if history:
        n = len(ground_acceleration)
        out["history"] = {name: np.full(n, cor) for name in variables.HISTORIES}
        out["history"]["time"] = np.arange(n) * dt
    return out


STUDY = """\
[study]
name = "small"
title = "a small test grid"
walls = ["s08", "s18"]
diaphragms = ["D1", "D5-pinned"]
supports = "top"
records = ["quake", "shake"]
cor = [0.7, 0.8]

[[study.history]]
wall = "s18"
diaphragm = "D1"
record = ["quake", "shake"]
cor = 0.8
"""


DIMS_STUDY = """
[study]
walls = ["s18", "c9"]
diaphragms = ["specimen"]
supports = "specimen"
records = ["quake", "shake"]
cor = {start = 0.70, stop = 0.72, step = 0.01}
scale = [1.0, 2.0]
impact = ["scale", "contact"]
damping = [0.05]
pairs = {s18 = ["shake"], c9 = ["quake", "shake"]}
"""
