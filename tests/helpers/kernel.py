"""Walls, records and small helpers for the kernel's physics tests (`tests/test_kernel.py`, and
`tests/test_simulate.py` for t_rest).

The Table II walls of the paper are taken literally (nominal masses, MODEL.md section 2).
Records come from the records folder as every test finds it (`tests.fixtures.records`:
``$URMX_RECORDS``); a test that needs a missing record fails under CI and skips elsewhere.
"""

from __future__ import annotations

from functools import cache

import numpy as np

import urmx
from urmx.variables import SCALARS

from ..fixtures.records import record_file, records_folder

G = urmx.model.PAPER_G

SCALAR_PEAKS = (
    "peak_crack_displacement", "peak_top_displacement", "peak_base_displacement",
    "peak_lower_drift", "peak_upper_drift", "peak_top_acceleration",
    "peak_crack_acceleration", "peak_base_acceleration", "instability_ratio_lower",
    "instability_ratio_upper", "instability_ratio",
)

# Table II, Wall 12 (b 0.110 m, h 1.5 m, eta 0.5, m 297 kg, PMR 72)
WALL12 = dict(thickness=0.110, height=1.5, crack_ratio=0.5, mass=297.0, pmr=72.0)
WALL12_RIGID = urmx.Wall(**WALL12)
# the same wall with its supports taken literally: 1e9 N/m springs, no diaphragm mass
WALL12_SPRING = urmx.Wall(**WALL12, bottom_stiffness=1e9, top_stiffness=1e9)
# Table II, West wall: rigid base, top 5.5e5 N/m, m_dt 780 kg, 12 % damping
WEST = urmx.Wall(thickness=0.092, height=1.934, crack_ratio=0.67, mass=429.0,
                 top_stiffness=5.5e5, top_mass=780.0, top_damping=0.12, pmr=75.0)
# Table II, C9: both supports flexible
C9 = urmx.Wall(thickness=0.191, height=2.79, crack_ratio=0.48, mass=1739.0,
               bottom_stiffness=39.4e3, top_stiffness=37e3, bottom_mass=655.0,
               top_mass=663.0, bottom_damping=0.12, top_damping=0.12, pmr=75.0)
# the four support cases on one wall (C9's geometry and diaphragms)
SUPPORTS = {
    "rigid/rigid": C9.replace(bottom_stiffness="rigid", top_stiffness="rigid"),
    "rigid/flex": C9.replace(bottom_stiffness="rigid"),
    "flex/rigid": C9.replace(top_stiffness="rigid"),
    "flex/flex": C9,
}


@cache
def elcentro() -> tuple[np.ndarray, float]:
    """El Centro 1940 S00E, m/s2 (file: cm/s2, 6 values a line), dt 0.02 s."""
    path = record_file("elcentro1940/elcentro_S00E_1940.dat")
    return np.loadtxt(path).ravel() / 100.0, 0.02


@cache
def nahanni() -> tuple[np.ndarray, float]:
    """Nahanni 1985 Site 1, 010 deg, m/s2 (file: g, one column), dt 0.005 s."""
    path = record_file("nahanni1985/NS1-010")
    return np.loadtxt(path) * G, 0.005


@cache
def bigbear() -> tuple[np.ndarray, float]:
    """Big Bear 1992, Hesperia (CDMG), the manifest's channel, m/s2."""
    record_file("bigbear1992/ce23583r_HESPERIA.RAW")
    import urmx.records

    tr = urmx.records.load("bigbear", records_folder())
    return np.asarray(tr.data, dtype=float), float(tr.stats.delta)


def rel(a: float, b: float) -> float:
    """Relative difference |a - b| / |b| (0 when both are 0)."""
    if a == b:
        return 0.0
    return abs(a - b) / abs(b)


def worst_peak_difference(a: dict, b: dict) -> tuple[float, str]:
    """Largest relative difference over the peak outputs, and its name."""
    return max((rel(a[k], b[k]), k) for k in SCALAR_PEAKS)


#: every output of an analysis two solvers must agree on (the archive's scalars, and how
#: the analysis ended, its events and its holds)
OUTPUTS = (*SCALARS, "duration", "events", "holds")


def differences(a: dict, b: dict) -> dict[str, float]:
    """Relative difference of every output of `OUTPUTS` between two results (NaN against
    NaN, as a collapse time without a collapse, is no difference); inf when the statuses
    differ."""
    out = {"status": 0.0 if a["status"] == b["status"] else np.inf}
    for k in OUTPUTS:
        x, y = float(a[k]), float(b[k])
        out[k] = 0.0 if x == y or (np.isnan(x) and np.isnan(y)) else \
            abs(x - y) / max(abs(x), abs(y))
    return out


def c9_chatter() -> dict:
    """C9 on a rigid base under El Centro x 0.6, contact law (a chatter that ends in a
    hold): 132 crack impacts at t_rest = 0.01 s, 130 at 0.02 s (the held joints of
    tests/test_kernel.py)."""
    ag, dt = elcentro()
    return dict(wall=SUPPORTS["rigid/flex"], ground_acceleration=ag[:301], dt=dt, scale=0.6,
                impact="contact")
