"""Results that cannot be silently wrong, record files that cannot run code, runs that
survive a lost worker, concurrent runs and damaged parts, for both study kinds (a grid of
analyses and an IDA study of collapse capacities).

Study tests use a small deterministic stand-in for the kernel (hand-computable outputs) and
synthetic records patched into ``urmx.records``, so no expected value depends on the
integrator's numbers.
"""

from __future__ import annotations

import io
import math
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import urmx
import urmx.records
from urmx import analysis as A
from urmx import study as st
from urmx import variables
from urmx.errors import OutputError, RunError, UrmxError

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


@pytest.fixture
def fake_records(use_records):
    use_records(ACC, SCALE, DT)


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


@pytest.fixture
def gaps(make_study):
    return make_study(STUDY, "gaps.toml")


def _run(path, kernel=fake_kernel, **kw):
    kw.setdefault("scheduler", "serial")
    kw.setdefault("progress", False)
    return st.run_study(path, kernel=kernel, batch_size=2, **kw)


def _same(a: xr.Dataset, b: xr.Dataset) -> None:
    """Two runs' Datasets are identical but for the start time heading `history`."""
    a, b = a.copy(), b.copy()
    for ds in (a, b):
        ds.attrs["history"] = ds.attrs["history"].split(" ", 1)[1]
    xr.testing.assert_identical(a, b)


# ---- cells without a valid result read as missing ---------------------------------------

# valid cells: s08/quake (D1, D5 x COR 0.7, 0.8): base impacts 80, 90, 80, 90;
# s08/shake/COR 0.8 (D1, D5): 140, 140; s18/shake (D1, D5 x 0.7, 0.8): 130, 140, 130, 140
VALID_CELLS = 10
BASE_IMPACTS = [80, 90, 80, 90, 140, 140, 130, 140, 130, 140]
COLLAPSES = 4  # s18 under shake


def _check_reductions(ds: xr.Dataset) -> None:
    assert int(ds.status.isin([0, 1]).sum()) == VALID_CELLS
    assert float(ds.collapsed.sum()) == COLLAPSES
    assert float(ds.collapsed.mean()) == pytest.approx(COLLAPSES / VALID_CELLS)
    assert float(ds.base_impacts.mean()) == pytest.approx(np.mean(BASE_IMPACTS))
    assert float(ds.base_impacts.sum()) == sum(BASE_IMPACTS)
    assert float(ds.base_impacts.max()) == 140
    assert float(ds.crack_impacts.sum()) == 3 * VALID_CELLS
    assert int(ds.crack_impacts.count()) == VALID_CELLS
    for name in variables.SCALARS:
        assert int(ds[name].count()) <= VALID_CELLS, name
        assert float(ds[name].max()) < JUNK, name
    not_run = ds.sel(wall="s18", record="quake")
    assert (not_run.status == st.NOT_RUN).all()
    stopped = ds.sel(wall="s08", record="shake", cor=0.7)
    assert (stopped.status == st.STATUS.index("event-limit")).all()
    for name in variables.SCALARS:
        assert bool(np.isnan(not_run[name]).all()) and bool(np.isnan(stopped[name]).all())


def test_cells_not_run_or_stopped_read_as_missing_after_round_trip(fake_records, gaps,
                                                                   tmp_path):
    out = tmp_path / "gaps.nc"
    ds = _run(gaps, out=out)
    _check_reductions(ds)
    back = urmx.open_study(out)
    assert back.base_impacts.chunks is not None  # lazy
    _check_reductions(back.load())
    _same(ds, back.load())
    for name in variables.INTEGER_SCALARS:
        assert "_FillValue -1" in back[name].attrs["comment"]
        assert back[name].encoding["dtype"] == np.int32
        assert back[name].encoding["_FillValue"] == -1
    # on disk: int32 with -1 in exactly the 6 cells without a valid result
    with xr.open_dataset(out, mask_and_scale=False) as raw:
        for name in variables.INTEGER_SCALARS:
            assert raw[name].dtype == np.int32 and raw[name].attrs["_FillValue"] == -1
            assert int((raw[name] == -1).sum()) == 16 - VALID_CELLS


def test_archive_without_fill_values_is_masked_by_status(fake_records, gaps, tmp_path):
    """An archive as urmx wrote it before (-1 in integer outputs, no _FillValue, partial
    peaks of event-limit cells): plain xarray reductions are wrong, open_study's are not."""
    ds = _run(gaps)
    invalid = ~ds.status.isin([0, 1])
    legacy = ds.copy()
    for name in variables.SCALARS:
        junk = -1 if name in variables.INTEGER_SCALARS else JUNK
        filled = legacy[name].where(~invalid, junk)
        if name in variables.INTEGER_SCALARS:
            filled = filled.astype(np.int32)
        legacy[name] = filled.assign_attrs(ds[name].attrs)
    enc = {name: {"_FillValue": None} for name in legacy.variables
           if legacy[name].dtype != object}
    path = tmp_path / "legacy.nc"
    legacy.to_netcdf(path, encoding=enc)
    with xr.open_dataset(path) as plain:
        assert float(plain.collapsed.sum()) == COLLAPSES - (16 - VALID_CELLS)  # silently wrong
        assert float(plain.base_impacts.mean()) < np.mean(BASE_IMPACTS)
    _check_reductions(urmx.open_study(path).load())


def test_analysis_reductions_skip_cells_without_valid_result(fake_records, gaps):
    ds = _run(gaps).assign_coords(frequency_low=("record", [0.5, 0.5]),
                                  frequency_high=("record", [10.0, 10.0]))
    ratio = A.governing_instability(ds, cor=0.7)
    assert np.isnan(ratio.sel(wall="s08", record="shake")).all()  # event-limit
    assert np.isnan(ratio.sel(wall="s18", record="quake")).all()  # not run
    res = A.resonance(ds, cor=0.7)
    # shake: only s18 has a result (6.0 * 0.7 / 18); quake: only s08 (1.0 * 0.7 / 8)
    assert float(res.mean_instability_ratio.sel(diaphragm="D1", record="shake")) == \
        pytest.approx(6.0 * 0.7 / 18.0)
    assert float(res.mean_instability_ratio.sel(diaphragm="D1", record="quake")) == \
        pytest.approx(1.0 * 0.7 / 8.0)
    assert float(res.collapses.sel(diaphragm="D5", record="shake")) == 1
    assert float(res.collapses.sel(diaphragm="D5", record="quake")) == 0
    # names instead of codes (synthetic Datasets) are understood too
    named = ds.assign(status=st.status_names(ds.status))
    assert float(A.valid_cells(named).collapsed.sum()) == COLLAPSES
    # an unmasked Dataset would have given the junk: the check can fail
    assert float(ds.instability_ratio.fillna(JUNK).max()) == JUNK


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


@pytest.fixture
def ida_gaps(make_study):
    return make_study(IDA_STUDY, "ida-gaps.toml")


def _run_ida(path, **kw):
    return _run(path, kernel=ida_kernel, **kw)


def _check_ida_reductions(ds: xr.Dataset) -> None:
    """Every per-cell output of the IDA study counts the 12 cells that ran, and only them."""
    from urmx.study.kinds import ida

    for name in ida.CELL_OUTPUTS:
        assert ds[name].dtype == np.float64, name
    assert int(ds.collapse_intensity.count()) == IDA_RUN
    assert float(ds.censored.sum()) == IDA_CENSORED
    assert int(ds.censored.count()) == IDA_RUN
    assert float(ds.censored.mean()) == pytest.approx(IDA_CENSORED / IDA_RUN)
    assert set(np.unique(ds.censored.values[np.isfinite(ds.censored.values)])) == {0.0, 1.0}
    assert float(ds.event_limits.sum()) == 0 and int(ds.event_limits.count()) == IDA_RUN
    # the analyses each cell ran, counted by the search itself on each cell alone
    expected = []
    for wid, s in (("s08", 8.0), ("s18", 18.0)):
        for rec in ("quake", "shake"):
            if wid == "s18" and rec == "quake":
                continue
            for d in ("D1", "D5"):
                for cor in (0.7, 0.8):
                    cell = ds.sel(wall=wid, diaphragm=d, record=rec, cor=cor)
                    thr = ida_threshold(s, cor)
                    if thr > 2.0:
                        assert float(cell.censored) == 1
                        assert float(cell.collapse_intensity) == 2.0
                    else:
                        assert float(cell.censored) == 0
                        assert thr <= float(cell.collapse_intensity) <= thr * 1.001
                    n = float(cell.analyses)
                    assert n == int(np.isfinite(cell.instability_ratio).sum()) > 0
                    expected.append(n)
    assert float(ds.analyses.sum()) == sum(expected)
    assert float(ds.analyses.mean()) == pytest.approx(np.mean(expected))
    not_run = ds.sel(wall="s18", record="quake")
    for name in ida.CELL_OUTPUTS:
        assert bool(np.isnan(not_run[name]).all()), name
    assert bool(np.isnan(not_run.intensity).all())


def test_ida_cells_not_run_read_as_missing_after_round_trip(fake_records, ida_gaps,
                                                            tmp_path):
    out = tmp_path / "ida.nc"
    ds = _run_ida(ida_gaps, out=out)
    _check_ida_reductions(ds)
    back = urmx.open_study(out)
    _check_ida_reductions(back.load())
    _same(ds, back.load())
    # on disk: int32 with the fill in exactly the 4 cells not run; censored 0/1 elsewhere
    # (True is not mistaken for a fill value)
    with xr.open_dataset(out, mask_and_scale=False) as raw:
        for name in ("censored", "analyses", "event_limits"):
            assert raw[name].dtype == np.int32 and raw[name].attrs["_FillValue"] == -1
            assert int((raw[name] == -1).sum()) == 16 - IDA_RUN
        assert int((raw.censored == 1).sum()) == IDA_CENSORED
        assert int((raw.censored == 0).sum()) == IDA_RUN - IDA_CENSORED


def test_ida_archive_without_fill_values_is_masked(fake_records, ida_gaps, tmp_path):
    """An IDA archive as urmx wrote it before (-1 counts, censored False where a cell was
    not run, no _FillValue): plain xarray reductions are wrong, open_study's are not."""
    ds = _run_ida(ida_gaps)
    ran = ds.analyses.notnull()
    legacy = ds.copy()
    legacy["censored"] = (legacy.censored == 1).assign_attrs(ds.censored.attrs)
    for name in ("analyses", "event_limits"):
        legacy[name] = ds[name].fillna(-1).astype(np.int32).assign_attrs(ds[name].attrs)
    enc = {name: {"_FillValue": None} for name in legacy.variables
           if legacy[name].dtype not in (object, np.float64) or name in legacy.coords}
    path = tmp_path / "legacy-ida.nc"
    legacy.to_netcdf(path, encoding=enc)
    with xr.open_dataset(path) as plain:
        assert plain.censored.dtype == bool
        assert float(plain.censored.mean()) == pytest.approx(IDA_CENSORED / 16)  # wrong
        assert float(plain.analyses.sum()) == float(ds.analyses.sum()) - (16 - IDA_RUN)
    back = urmx.open_study(path).load()
    _check_ida_reductions(back)
    for name in ("collapse_intensity", "censored", "analyses", "event_limits"):
        xr.testing.assert_equal(back[name].where(ran), ds[name])


# ---- record files cannot run code -------------------------------------------------------

def _pickle_payload(marker: Path) -> bytes:
    """A pickle that ObsPy's PICKLE detector would load (it starts with the ObsPy marker)
    and that creates `marker` when unpickled."""
    code = f"import pathlib; pathlib.Path({str(marker)!r}).touch()"
    return (b"cobspy.core.stream\nStream\n0cbuiltins\nexec\n(S" + repr(code).encode()
            + b"\ntR.")


def test_pickle_record_never_runs(tmp_path, capsys, monkeypatch):
    from urmx.cli import main
    from urmx.records import readers

    marker = tmp_path / "marker"
    evil = tmp_path / "record.dat"
    evil.write_bytes(_pickle_payload(marker))
    # the payload is live: ObsPy's own format detection runs it
    import obspy

    shutil.copy(evil, tmp_path / "control.dat")
    with pytest.raises(Exception):  # noqa: B017 - the unpickled object is not a Stream
        obspy.read(str(tmp_path / "control.dat"))
    assert marker.exists()
    marker.unlink()

    with pytest.raises(urmx.records.UnsupportedRecordError, match="pickle") as err:
        urmx.records.read(evil)
    assert str(evil) in str(err.value)
    with pytest.raises(urmx.records.UnsupportedRecordError, match="PICKLE"):
        urmx.records.read(evil, format="pickle")
    wall = urmx.Wall(thickness=0.11, height=1.5, crack_ratio=0.5, mass=400.0)
    with pytest.raises(UrmxError, match="pickle"):
        urmx.simulate(wall, evil)
    wall_file = tmp_path / "wall.toml"
    wall_file.write_text("thickness = 0.11\nheight = 1.5\ncrack_ratio = 0.5\nmass = 400.0\n")
    for argv in (["simulate", str(wall_file), str(evil)], ["records", "show", str(evil)],
                 ["records", "plot", str(evil), "--out", str(tmp_path / "x.png")]):
        assert main(argv) == 2
        errs = capsys.readouterr().err
        assert errs.count("\n") == 1 and "pickle" in errs and str(evil) in errs
    # the ObsPy allow-list alone (without the pickle sniffing) keeps the file out too
    monkeypatch.setattr(readers, "_looks_like_pickle", lambda head: False)
    with pytest.raises(urmx.records.UnknownFormatError):
        urmx.records.read(evil)
    assert "PICKLE" not in readers.OBSPY_FORMATS
    assert not marker.exists()


def test_safe_obspy_formats_are_still_detected(tmp_path):
    from obspy import Trace

    tr = Trace(np.sin(np.arange(300) * 0.1))
    tr.stats.delta = 0.01
    for fmt in ("MSEED", "SAC", "SLIST"):
        path = tmp_path / f"rec.{fmt.lower()}"
        tr.write(str(path), format=fmt)
        st_ = urmx.records.read(path, unit="m/s2")
        assert st_[0].stats.npts == 300 and fmt in st_[0].stats.processing[0]


# ---- record headers with a non-positive time step ---------------------------------------

@pytest.mark.parametrize("dt_text", [".0000", "-.0100"])
def test_header_dt_not_positive_is_refused(tmp_path, dt_text):
    path = tmp_path / "rec.AT2"
    path.write_text("PEER NGA STRONG MOTION DATABASE RECORD\nTest\nACCELERATION TIME SERIES "
                    f"IN UNITS OF G\nNPTS=  4, DT=   {dt_text} SEC\n 0.1 0.2 0.1 0.0\n")
    with pytest.raises(urmx.records.MissingTimeStepError, match=r"dt=-?0\.0?1?0* s") as err:
        urmx.records.read(path)
    assert str(path) in str(err.value)


# ---- a lost worker -----------------------------------------------------------------------

MANY = [f"r{i:02d}" for i in range(40)]  # 40 synthetic records: PGA 0.1 ... 4.0 m s-2
WIDE = f"""\
[study]
name = "wide"
walls = "parametric"
diaphragms = ["D1", "D2", "D3", "D4", "D5"]
records = {MANY!r}
cor = [0.8]
"""


@pytest.fixture
def many_records(use_records):
    acc = {rid: np.r_[np.zeros(5), 0.1 * (i + 1), -0.05, np.zeros(43)]
           for i, rid in enumerate(MANY)}
    use_records(acc, dict.fromkeys(acc, 1.0), DT)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["grid", "ida"])
def test_run_survives_a_killed_worker(many_records, tmp_path, monkeypatch, kind):
    """SIGKILL a worker that runs a batch (the one holding a record's samples when it is
    busy), mid-run: dask runs its batches again (the record samples are a task it can
    recompute) and every cell equals a serial run. With the record samples scattered
    (``client.scatter(..., broadcast=True)``) instead, the same kill cancelled the run
    (FutureCancelledError) in 3 tries of 3 with these 1800 batches (1 in 4 with 900).
    The same for an IDA study of the grid (one collapse capacity a batch)."""
    import psutil
    from distributed import Client, LocalCluster

    wide = tmp_path / "wide.toml"
    if kind == "grid":
        wide.write_text(WIDE)
        fast, slow, sleep = fake_kernel, slow_kernel, "0.005"
        n_batches = 9 * 5 * 40  # one analysis a batch
    else:  # half the records, a few analyses a capacity (coarse search)
        wide.write_text(WIDE.replace(repr(MANY), repr(MANY[:20]))
                        + '[study.ida]\nim = "pga"\nrtol = 0.2\nstep = 2.0\n'
                        "max_intensity = 5.0\n")
        fast, slow, sleep = ida_kernel, ida_kernel, "0.002"
        n_batches = 9 * 5 * 20  # one capacity a batch
    serial = st.run_study(wide, kernel=fast, batch_size=1, scheduler="serial",
                          progress=False)
    monkeypatch.setenv(SLEEP, sleep)
    killed: dict = {}

    def killer(client, parts):
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not killed:
            done = len(list(parts.glob("*.npz"))) if parts.is_dir() else 0
            busy = {w: ks for w, ks in client.processing().items() if ks}
            holders = {w for key, ws in client.who_has().items()
                       if str(key).startswith("urmx-record-") for w in ws}
            # the worker holding a record if it is busy, else (later) any busy one
            target = next((w for w in busy if w in holders), None)
            if target is None and done >= 60:
                target = next(iter(busy), None)
            if done >= 50 and target is not None:
                pid = client.run(os.getpid, workers=[target])[target]
                killed.update(address=target, pid=pid, parts_done=done,
                              batches=list(busy[target]), held_record=target in holders)
                os.kill(pid, signal.SIGKILL)
                return
            time.sleep(0.02)

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        out = tmp_path / "killed.nc"
        thread = threading.Thread(target=killer, args=(client, tmp_path / "killed.nc.parts"))
        thread.start()
        start = time.monotonic()
        ds = st.run_study(wide, out=out, kernel=slow, batch_size=1, scheduler=client,
                          progress=False)
        took = time.monotonic() - start
        thread.join()
        workers = set(client.scheduler_info()["workers"])
    assert killed, f"no worker was killed mid-run (the run took {took:.1f} s)"
    assert killed["parts_done"] < n_batches and killed["batches"]  # mid-run, work in hand
    assert not psutil.pid_exists(killed["pid"]) or \
        psutil.Process(killed["pid"]).status() == psutil.STATUS_ZOMBIE
    assert killed["address"] not in workers
    _same(serial, ds)
    _same(serial, urmx.open_study(out).load())


# ---- concurrent runs, damaged parts, unwritable outputs ---------------------------------

def test_second_run_on_the_same_archive_is_refused(fake_records, gaps, ida_gaps, tmp_path):
    out = tmp_path / "busy.nc"
    parts = tmp_path / "busy.nc.parts"
    with st.Lock(parts, out):  # what a running `urmx run` holds
        with pytest.raises(RunError, match=r"another urmx run \(pid \d+.*busy\.nc"):
            _run(gaps, out=out)
        with pytest.raises(RunError, match=r"another urmx run \(pid \d+.*busy\.nc"):
            _run_ida(ida_gaps, out=out)  # `urmx ida` takes the same lock
    assert not out.exists()
    _check_reductions(_run(gaps, out=out))  # free again


def test_lock_of_a_killed_run_is_released(fake_records, gaps, tmp_path):
    out = tmp_path / "dead.nc"
    code = ("import sys, time; from pathlib import Path; from urmx.study import Lock; "
            "Lock(Path(sys.argv[1]), Path(sys.argv[2])).__enter__(); print('held', "
            "flush=True); time.sleep(60)")
    proc = subprocess.Popen([sys.executable, "-c", code, str(tmp_path / "dead.nc.parts"),
                             str(out)], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "held"
        with pytest.raises(RunError, match=f"pid {proc.pid}"):
            _run(gaps, out=out)
    finally:
        proc.kill()
        proc.wait()
    _check_reductions(_run(gaps, out=out))


def test_foreign_and_damaged_parts_are_recomputed(fake_records, gaps, tmp_path):
    reference = _run(gaps)
    out = tmp_path / "parts.nc"
    parts = tmp_path / "parts.nc.parts"
    study = urmx.catalog.load_study(gaps)
    records = st.resolve_records(study)
    tasks = st.batch_tasks(study, records, 2, fake_kernel)
    assert len(tasks) == 6
    parts.mkdir()
    store = st.PartStore(parts, st.BATCH_OUTPUTS)
    for b, t in tasks:
        store.save(b.key, st.run_batch(t, ACC[study.records[b.record]]), b.cells)
    (a, _), (b, _), (c, _) = tasks[:3]
    shutil.copy(parts / f"{a.key}.npz", parts / f"{b.key}.npz")  # another batch's part
    damaged = (parts / f"{c.key}.npz").read_bytes()
    (parts / f"{c.key}.npz").write_bytes(damaged[: len(damaged) // 2])  # cut mid-write
    assert store.load(b.key) is None and store.load(c.key) is None
    assert store.load(a.key) is not None
    err = io.StringIO()
    sys_stderr, sys.stderr = sys.stderr, err
    try:
        ds = st.run_study(gaps, out=out, kernel=fake_kernel, batch_size=2, scheduler="serial",
                          progress=True)
    finally:
        sys.stderr = sys_stderr
    _same(reference, ds)
    assert "4 of 6 batches done; 2 damaged or foreign part file(s) are computed again" \
        in err.getvalue()
    assert not parts.exists()


def test_foreign_and_damaged_ida_parts_are_recomputed(fake_records, ida_gaps, tmp_path):
    """The same checks on an IDA study's parts (their own arrays, their own keys)."""
    from urmx.study.kinds import ida

    reference = _run_ida(ida_gaps)
    out = tmp_path / "ida.nc"
    parts = tmp_path / "ida.nc.parts"
    study = urmx.catalog.load_study(ida_gaps)
    records = st.resolve_records(study)
    tasks = st.batch_tasks(study, records, 2, ida_kernel)
    assert len(tasks) == 6 and all(b.key.startswith("ida-") for b, _ in tasks)
    parts.mkdir()
    store = st.PartStore(parts, ida.OUTPUTS)
    for b, t in tasks:
        store.save(b.key, ida.run_batch(t, records[study.records[b.record]].acceleration),
                   b.cells)
    with np.load(parts / f"{tasks[0][0].key}.npz") as z:
        assert str(z["batch_key"]) == tasks[0][0].key
        assert set(ida.OUTPUTS) <= set(z.files)
    (a, _), (b, _), (c, _) = tasks[:3]
    shutil.copy(parts / f"{a.key}.npz", parts / f"{b.key}.npz")  # another batch's part
    damaged = (parts / f"{c.key}.npz").read_bytes()
    (parts / f"{c.key}.npz").write_bytes(damaged[: len(damaged) // 2])  # cut mid-write
    assert store.load(a.key) is not None
    assert store.load(b.key) is None
    # a grid batch's outputs are not an IDA batch's: a part lacking them is recomputed
    assert st.PartStore(parts, st.BATCH_OUTPUTS).load(a.key) is None
    err = io.StringIO()
    sys_stderr, sys.stderr = sys.stderr, err
    try:
        ds = _run_ida(ida_gaps, out=out, progress=True)
    finally:
        sys.stderr = sys_stderr
    _same(reference, ds)
    assert "4 of 6 batches done; 2 damaged or foreign part file(s) are computed again" \
        in err.getvalue()
    assert "cells/s" in err.getvalue()  # progress counts collapse capacities
    assert not parts.exists()


class Interrupt(Exception):
    """Stands for Ctrl-C (or a killed run) partway through a study."""


@pytest.mark.parametrize("kind", ["grid", "ida"])
def test_parts_of_another_kernel_source_are_recomputed(fake_records, gaps, ida_gaps, tmp_path,
                                                       monkeypatch, kind):
    """A batch key holds `urmx.jitcache.SOURCE_HASH` (the compiled kernel's sources): after
    the kernel changes, parts an older kernel computed are not reused; with the same
    sources, they are."""
    import urmx.jitcache

    path, base = (gaps, fake_kernel) if kind == "grid" else (ida_gaps, ida_kernel)
    calls: list[int] = []
    stop: list[int] = []

    def kernel(*args, **kw):
        if stop and len(calls) == stop[0]:
            raise Interrupt
        calls.append(1)
        return base(*args, **kw)

    def run(out=None):
        return st.run_study(path, out=out, kernel=kernel, batch_size=2, scheduler="serial",
                            progress=False)

    reference = run()
    total = len(calls)

    def interrupted(out):
        calls.clear()
        stop[:] = [total // 2]
        with pytest.raises(Interrupt):
            run(out)
        stop.clear()
        kept = len(list(out.with_name(out.name + ".parts").glob("*.npz")))
        assert 0 < kept < 6
        calls.clear()

    study = urmx.catalog.load_study(path)
    records = st.resolve_records(study)
    old_keys = {b.key for b, _ in st.batch_tasks(study, records, 2, kernel)}
    # same sources: the kept parts are reused
    same = tmp_path / "same.nc"
    interrupted(same)
    _same(reference, run(same))
    assert 0 < len(calls) < total
    # another kernel source: every batch is computed again
    changed = tmp_path / "changed.nc"
    interrupted(changed)
    monkeypatch.setattr(urmx.jitcache, "SOURCE_HASH", "f" * 16)
    new_keys = {b.key for b, _ in st.batch_tasks(study, records, 2, kernel)}
    assert len(new_keys) == len(old_keys) == 6 and not new_keys & old_keys
    _same(reference, run(changed))
    assert len(calls) == total


def test_outputs_checked_before_any_work(fake_records, gaps, tmp_path):
    calls = []

    def counting(*args, **kw):
        calls.append(1)
        return fake_kernel(*args, **kw)

    blocker = tmp_path / "a-file"
    blocker.write_text("")
    for out, needle in ((tmp_path, "is a folder"), (blocker / "x.nc", "is a file, not a folder")):
        with pytest.raises(OutputError, match=needle) as err:
            st.run_study(gaps, out=out, kernel=counting, scheduler="serial", progress=False)
        assert str(out) in str(err.value)
    assert calls == []


# ---- progress ----------------------------------------------------------------------------

def test_progress_lines_in_a_log_file_and_bar_on_a_terminal():
    log = io.StringIO()
    bar = st.Progress(200, 0, True, label="urmx demo", stream=log)
    for _ in range(20):
        bar.update(10)
    bar.close()
    text = log.getvalue()
    assert "\r" not in text
    lines = text.splitlines()
    assert len(lines) == 11  # the start, then every tenth of the work
    assert lines[0].startswith("urmx demo:   0% 0/200")
    assert lines[-1].startswith("urmx demo: 100% 200/200")
    assert all("analyses/s" in ln and "<" in ln for ln in lines)  # rate and ETA

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    tty = Terminal()
    bar = st.Progress(200, 50, True, label="urmx demo", stream=tty)
    bar.update(150)
    bar.close()
    assert "\r" in tty.getvalue() and "200/200" in tty.getvalue()
    quiet = io.StringIO()
    st.Progress(200, 0, False, stream=quiet).update(200)
    assert quiet.getvalue() == ""


# ---- Ctrl-C: one line, no worker tracebacks ---------------------------------------------

@pytest.mark.slow
def test_ctrl_c_gives_one_line(tmp_path):
    """SIGINT to the whole process group of `urmx run` (what Ctrl-C in a terminal does)
    once a few batches are saved: exit 130 and one line saying what is kept."""
    from .fixtures.records import records_folder
    from .fixtures.signals import interruptible

    rdir = records_folder()
    ids = [e["id"] for e in urmx.records.manifest(rdir).values()
           if e["set"] == "fema-p695-far-field"]
    study = tmp_path / "big.toml"
    study.write_text(f'[study]\nname = "big"\nwalls = "parametric"\ndiaphragms = ["D1", "D2", '
                     f'"D3", "D4", "D5"]\nrecords = {ids!r}\ncor = [0.7, 0.8, 0.9]\n')
    out = tmp_path / "big.nc"
    parts = tmp_path / "big.nc.parts"
    env = dict(os.environ, URMX_RECORDS=str(rdir))
    proc = subprocess.Popen(
        [sys.executable, "-m", "urmx.cli", "run", str(study), "--out", str(out),
         "--batch-size", "4"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        start_new_session=True, env=env,
        preexec_fn=interruptible)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and proc.poll() is None:
        if parts.is_dir() and len(list(parts.glob("*.npz"))) >= 3:
            break
        time.sleep(0.05)
    if proc.poll() is not None:
        _, err = proc.communicate()
        raise AssertionError(f"the run ended before it could be interrupted "
                             f"(exit {proc.returncode}): {err.decode()[-2000:]}")
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    err = err.decode()
    lines = [ln for ln in err.splitlines() if "analyses/s" not in ln]
    assert proc.returncode == 130
    assert "Traceback" not in err
    assert len(lines) == 1, err
    assert lines[0].startswith("urmx run: interrupted; ") and str(parts) in lines[0]
    assert not out.exists() and len(list(parts.glob("*.npz"))) >= 3
