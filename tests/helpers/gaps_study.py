"""The "gaps" study's stand-ins (`tests/test_reliability.py`, and the cluster and cells tests
that run the same study): two synthetic pulse records, "quake" (PGA 1.0 m s-2) and "shake"
(PGA 3.0), scaled 1 and 2; `fake_kernel` (hand-computable outputs, an event-limit cell full of
`JUNK`), `slow_kernel` and `ida_kernel` (collapse at `ida_threshold`); the study files
`STUDY` (a grid with gaps), `IDA_STUDY` (the same as an IDA study) and `WIDE` (the
parametric walls under the 40 `MANY` records, `many_acceleration`). Fixture:
``gaps_records`` (conftest.py)."""

from __future__ import annotations

import math
import os
import time

import numpy as np

from urmx import variables

DT = 0.01
ACC = {"quake": np.r_[np.zeros(5), 1.0, -0.5, np.zeros(93)],  # PGA 1.0 m s-2
       "shake": np.r_[np.zeros(10), 3.0, -1.0, np.zeros(88)]}  # PGA 3.0 m s-2
SCALE = {"quake": 1.0, "shake": 2.0}  # scaled PGA: quake 1.0, shake 6.0
JUNK = 1e9  # what an event-limit cell's outputs hold in the stand-in kernel
SLEEP = "URMX_TEST_KERNEL_SLEEP"  # seconds slow_kernel takes per analysis (worker processes
# import this module afresh, so the setting travels in the environment)


def fake_kernel(wall, ground_acceleration, dt, *, scale=1.0, cor=0.8, impact="scale", tail=0.0,
                history=False):
    """Stand-in with the interface of urmx.kernel.run.

    - base_impacts = 10 * scaled PGA + 100 * cor (rounded); crack_impacts = 3;
    - collapsed = 1 for the slender wall (height > 3 m) under the strong record (PGA > 5);
    - the stocky wall under the strong record at COR 0.7 stops at the event limit, with
      outputs that would spoil any reduction (JUNK).
    """
    pga = scale * float(np.max(np.abs(ground_acceleration)))
    out = {name: 0.0 for name in variables.SCALARS}
    out["peak_crack_displacement"] = pga * wall.height * cor / 100.0
    out["instability_ratio"] = min(1.0, pga * cor / wall.slenderness)
    out["collapsed"] = int(wall.height > 3.0 and pga > 5.0)
    out["collapse_time"] = 0.5 if out["collapsed"] else math.nan
    out["base_impacts"] = int(round(10 * pga + 100 * cor))
    out["crack_impacts"] = 3
    out["status"] = "collapsed" if out["collapsed"] else "ok"
    if wall.height < 3.0 and pga > 5.0 and cor < 0.75:
        out.update({name: JUNK for name in variables.SCALARS})
        out.update(collapsed=1, base_impacts=999_999, crack_impacts=999_999,
                   status="event-limit")
    return out


def slow_kernel(*args, **kw):
    """`fake_kernel`, taking os.environ[SLEEP] seconds."""
    time.sleep(float(os.environ.get(SLEEP, "0")))
    return fake_kernel(*args, **kw)


def ida_threshold(slenderness: float, cor: float) -> float:
    """Scaled PGA at which `ida_kernel` collapses a wall: 20 / (slenderness * cor) [m s-2]
    (s08 at COR 0.8: 3.125; s18: 1.389)."""
    return 20.0 / (slenderness * cor)


def ida_kernel(wall, ground_acceleration, dt, *, scale=1.0, cor=0.8, impact="scale", **kw):
    """Stand-in for the IDA search: the wall collapses iff the scaled PGA reaches
    `ida_threshold`; the instability ratio grows in proportion to the PGA below it. Takes
    os.environ[SLEEP] seconds."""
    time.sleep(float(os.environ.get(SLEEP, "0")))
    pga = scale * float(np.max(np.abs(ground_acceleration)))
    ratio = min(1.0, pga / ida_threshold(wall.slenderness, cor))
    return {"status": "collapsed" if ratio >= 1.0 else "ok", "instability_ratio": ratio}


# 2 walls x 2 diaphragms x 2 records x 2 CORs = 16 cells; s18 is not run under "quake"
# (4 cells) and s08 under "shake" at COR 0.7 stops at the event limit (2 cells): 10 valid
STUDY = """\
[study]
name = "gaps"
walls = ["s08", "s18"]
diaphragms = ["D1", "D5"]
supports = "top"
records = ["quake", "shake"]
cor = [0.7, 0.8]
pairs = {s08 = ["quake", "shake"], s18 = ["shake"]}
"""

# the same study as an IDA study: s18 is not run under "quake" (2 diaphragms x 2 CORs = 4
# cells of 16); s08 survives max_intensity 2.0 m s-2 (censored, 8 cells); s18 collapses under
# "shake" (4 cells)
IDA_STUDY = STUDY.replace('"gaps"', '"ida-gaps"') + """
[study.ida]
im = "pga"
rtol = 1e-3
step = 1.5
max_intensity = 2.0
"""
IDA_RUN, IDA_CENSORED = 12, 8


MANY = [f"r{i:02d}" for i in range(40)]  # 40 synthetic records: PGA 0.1 ... 4.0 m s-2
WIDE = f"""\
[study]
name = "wide"
walls = "parametric"
diaphragms = ["D1", "D2", "D3", "D4", "D5"]
records = {MANY!r}
cor = [0.8]
"""


def many_acceleration() -> dict[str, np.ndarray]:
    """The samples of the `MANY` records: a pulse of PGA 0.1 ... 4.0 m s-2 (scale 1)."""
    return {rid: np.r_[np.zeros(5), 0.1 * (i + 1), -0.05, np.zeros(43)]
            for i, rid in enumerate(MANY)}
