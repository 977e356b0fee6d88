"""A study on a folder of one's own record files (`tests/test_cells.py` and
`tests/test_nothing_silent.py`): synthetic AT2 records and their manifest (`write_at2`,
`index_folder`, `own_record_folder`; fixture ``own_records`` in conftest.py), the study
template `OWN_GRID` written by `own_grid`, the grid stand-in kernel counted by `counting`
(and stopped with `Interrupt`), and `quiet_run`, a run whose progress is captured."""

from __future__ import annotations

import io
import sys
from pathlib import Path

import numpy as np
import xarray as xr

from urmx import study as st

from .grid_study import fake_kernel
from .runs import Interrupt
from .synthetic import at2_rows, at2_text


def counting(calls: list, stop: int | None = None):
    def kernel(*args, **kw):
        if stop is not None and len(calls) == stop:
            raise Interrupt
        calls.append(1)
        return fake_kernel(*args, **kw)

    kernel.__qualname__ = "counting"  # one kernel name (it is part of every cell's key)
    return kernel


def quiet_run(*args, **kw) -> tuple[xr.Dataset, str]:
    """`urmx.run_study` with progress on, returning (the archive loaded, what it said)."""
    err = io.StringIO()
    saved, sys.stderr = sys.stderr, err
    try:
        ds = st.run_study(*args, progress=True, **kw).load()
    finally:
        sys.stderr = saved
    return ds, err.getvalue()


def write_at2(path: Path, peak: float, n: int = 120) -> None:
    """A PEER AT2 record: a decaying 2 Hz sine of `peak` g, dt 0.01 s."""
    t = np.arange(n) * 0.01
    acc = peak * np.sin(2 * np.pi * 2.0 * t) * np.exp(-t)
    path.write_text(at2_text(at2_rows(acc, fmt=" .7E", sep=" "), title="synthetic test record",
                             npts_line=f"NPTS= {n:5d}, DT= .0100 SEC"))


def index_folder(folder: Path) -> None:
    from urmx.records.manifest import index, write_manifest

    entries, _ = index(folder, pattern="*.AT2")
    write_manifest(entries, folder / "manifest.toml")


OWN_GRID = """\
[study]
name = "own"
walls = {walls}
diaphragms = ["D1", "D3"]
supports = "top"
records = {records}
cor = {cor}
"""


def own_grid(make_study, walls=("s08", "s18"), records=("rec1", "rec2", "rec3"), cor=(0.7, 0.8),
             name="own"):
    text = OWN_GRID.format(walls=list(walls), records=list(records), cor=list(cor))
    return make_study(text.replace('"own"', f'"{name}"'), f"{name}-{len(walls)}-"
                      f"{len(records)}-{len(cor)}.toml")


def own_record_folder(tmp_path: Path) -> Path:
    """A records folder of four AT2 files ``rec1`` ... ``rec4`` (peaks 0.1 ... 0.4 g) and its
    manifest, in `tmp_path` (the ``own_records`` fixture, conftest.py)."""
    folder = tmp_path / "records"
    folder.mkdir()
    for i, peak in enumerate((0.1, 0.2, 0.3, 0.4), 1):
        write_at2(folder / f"rec{i}.AT2", peak)
    index_folder(folder)
    return folder
