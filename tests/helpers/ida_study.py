"""The IDA stand-ins (`tests/test_fragility.py`, and the risk and statistics tests that read
the same archives): two synthetic records, "quake" (a sine after 20 zeros, PGA 2.0 m s-2,
200 samples) and "shake" (a pulse, PGA 3.0, 150 samples), scaled 1 and 2; `study_kernel`,
which collapses a wall at a known PGA (`threshold`), logs its calls in `CALLS` and raises
`Interrupt` at call number ``FAIL_AT[0]``; `stiff_kernel`, the same threshold raised with the
diaphragm's stiffness; the study files `IDA_STUDY`, `REP_IDA` and `SMALL_IDA` (catalog records,
for the real kernel); `run`, one serial run. Fixture: ``ida_records`` (conftest.py)."""

from __future__ import annotations

import numpy as np

from urmx import study as st

from .runs import Interrupt

DT = 0.01
ACC = {"quake": np.r_[np.zeros(20), 2.0 * np.sin(np.linspace(0, 6 * np.pi, 180))],
       "shake": np.r_[np.zeros(10), 3.0, -1.0, np.zeros(138)]}
SCALE = {"quake": 1.0, "shake": 2.0}
CALLS: list = []
FAIL_AT: list[int] = []


def study_kernel(w, ag, dt, *, scale=1.0, cor=0.8, impact="scale", **kw):
    """Collapse iff the scaled PGA reaches 40/slenderness * (samples/150) * cor [m s-2]:
    s08 5.33 (quake) / 4.0 (shake) at COR 1.0, s18 2.37 / 1.78."""
    if FAIL_AT and len(CALLS) == FAIL_AT[0]:
        raise Interrupt
    thr = 40.0 / w.slenderness * (len(ag) / 150.0) * cor
    pga = scale * float(np.max(np.abs(ag)))
    CALLS.append((w.slenderness, len(ag), round(scale, 12), cor))
    ratio = min(1.0, pga / thr)
    return {"status": "collapsed" if ratio >= 1.0 else "ok", "instability_ratio": ratio}


def threshold(slenderness, record, cor):
    return 40.0 / slenderness * (len(ACC[record]) / 150.0) * cor


IDA_STUDY = """\
[study]
name = "tiny-ida"
walls = ["s08", "s18"]
diaphragms = ["D1", "D2/both"]
records = ["quake", "shake"]
cor = [0.8, 1.0]

[study.ida]
im = "pga"
rtol = 1e-3
step = 1.5
max_intensity = 4.5
"""


SMALL_IDA = """
[study]
name = "small-ida"
walls = ["s08", "s12", "s16", "s20", "s24"]
diaphragms = ["D1", "D5", "D3/both"]
records = ["p695-01-mul009", "p695-09-dzc270", "p695-12-clwln", "p695-18-rio270"]
cor = [0.8]
[study.ida]
im = "pga"
"""


REP_IDA = """
[study]
name = "rep-ida"
walls = ["s08", "s16", "s24"]
diaphragms = ["D1", "D4", "D1/both", "D4/both"]
records = ["quake", "shake"]
cor = [0.8]
[study.ida]
max_intensity = 100.0
"""


def stiff_kernel(w, ag, dt, *, scale=1.0, cor=0.8, impact="scale", **kw):
    """As `study_kernel`, with the threshold times (k_top / 815 kN/m)**0.1: D4 is 1.478
    times as strong as D1 for every wall and record."""
    thr = 40.0 / w.slenderness * (len(ag) / 150.0) * cor * (w.top_stiffness / 815e3) ** 0.1
    ratio = min(1.0, scale * float(np.max(np.abs(ag))) / thr)
    return {"status": "collapsed" if ratio >= 1.0 else "ok", "instability_ratio": ratio}


def run(make_study, text, name, kernel=study_kernel):
    """The study `text`, written as `name`, run serially with `kernel` in batches of two."""
    return st.run_study(make_study(text, name), kernel=kernel, scheduler="serial",
                        progress=False, batch_size=2)
