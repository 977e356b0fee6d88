"""Results that cannot be silently wrong, record files that cannot run code, runs that
survive a lost worker, concurrent runs and damaged parts, for both study kinds (a grid of
analyses and an IDA study of collapse capacities).

Study tests use a small deterministic stand-in for the kernel (hand-computable outputs) and
synthetic records patched into ``urmx.records``, so no expected value depends on the
integrator's numbers.
"""

from __future__ import annotations

import io
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
import urmx.netcdf
import urmx.records
from urmx import study as st
from urmx import variables
from urmx.analysis import grid as A
from urmx.errors import OutputError, RunError, UrmxError

from .helpers.gaps_study import (
    ACC,
    DT,
    IDA_CENSORED,
    IDA_RUN,
    IDA_STUDY,
    JUNK,
    MANY,
    SLEEP,
    STUDY,
    WIDE,
    fake_kernel,
    ida_kernel,
    ida_threshold,
    many_acceleration,
    slow_kernel,
)
from .helpers.runs import Interrupt
from .helpers.synthetic import at2_text


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


def test_cells_not_run_or_stopped_read_as_missing_after_round_trip(gaps_records, gaps,
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


def test_archive_without_fill_values_is_masked_by_status(gaps_records, gaps, tmp_path):
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


def test_analysis_reductions_skip_cells_without_valid_result(gaps_records, gaps):
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


def test_ida_cells_not_run_read_as_missing_after_round_trip(gaps_records, ida_gaps,
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


def test_ida_archive_without_fill_values_is_masked(gaps_records, ida_gaps, tmp_path):
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
    from urmx.records.readers import detect as readers  # where _looks_like_pickle lives

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
    """Through the API, both signs, the file named in the message (``test_bad_inputs`` holds
    the CLI's one line for both, but the API's error for dt = 0 only, on another file)."""
    path = tmp_path / "rec.AT2"
    path.write_text(at2_text(" 0.1 0.2 0.1 0.0\n", title="Test", npts=4, dt=dt_text))
    with pytest.raises(urmx.records.MissingTimeStepError, match=r"dt=-?0\.0?1?0* s") as err:
        urmx.records.read(path)
    assert str(path) in str(err.value)


# ---- a lost worker -----------------------------------------------------------------------

@pytest.fixture
def many_records(use_records):
    acc = many_acceleration()
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

def test_second_run_on_the_same_archive_is_refused(gaps_records, gaps, ida_gaps, tmp_path):
    out = tmp_path / "busy.nc"
    parts = tmp_path / "busy.nc.parts"
    with st.Lock(parts, out):  # what a running `urmx run` holds
        with pytest.raises(RunError, match=r"another urmx run \(pid \d+.*busy\.nc"):
            _run(gaps, out=out)
        with pytest.raises(RunError, match=r"another urmx run \(pid \d+.*busy\.nc"):
            _run_ida(ida_gaps, out=out)  # `urmx ida` takes the same lock
    assert not out.exists()
    _check_reductions(_run(gaps, out=out))  # free again


def test_lock_of_a_killed_run_is_released(gaps_records, gaps, tmp_path):
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


def test_foreign_and_damaged_parts_are_recomputed(gaps_records, gaps, tmp_path):
    reference = _run(gaps)
    out = tmp_path / "parts.nc"
    parts = tmp_path / "parts.nc.parts"
    study = urmx.study.load_study(gaps)
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


def test_foreign_and_damaged_ida_parts_are_recomputed(gaps_records, ida_gaps, tmp_path):
    """The same checks on an IDA study's parts (their own arrays, their own keys)."""
    from urmx.study.kinds import ida

    reference = _run_ida(ida_gaps)
    out = tmp_path / "ida.nc"
    parts = tmp_path / "ida.nc.parts"
    study = urmx.study.load_study(ida_gaps)
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


@pytest.mark.parametrize("kind", ["grid", "ida"])
def test_parts_of_another_kernel_source_are_recomputed(gaps_records, gaps, ida_gaps, tmp_path,
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

    study = urmx.study.load_study(path)
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
    again = run(changed)
    assert again.attrs["kernel_source_hash"] == "f" * 16  # the archive says which kernel
    again.attrs["kernel_source_hash"] = reference.attrs["kernel_source_hash"]
    _same(reference, again)
    assert len(calls) == total


def test_outputs_checked_before_any_work(gaps_records, gaps, tmp_path):
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


# ---- an input never becomes an output; outputs checked before the work ------------------

def _counting(calls: list):
    """`fake_kernel`, counting its calls in `calls`; under fake_kernel's name, so that its
    batches have fake_kernel's keys (a run with it resumes one with fake_kernel)."""
    def kernel(*args, **kw):
        calls.append(1)
        return fake_kernel(*args, **kw)

    kernel.__module__, kernel.__qualname__ = fake_kernel.__module__, fake_kernel.__qualname__
    return kernel


def test_an_input_is_never_the_output(gaps_records, gaps, tmp_path, monkeypatch, capsys):
    """`--out` naming the study file (by its name or a hard link), a record's file or the
    records manifest is refused before any work, and the input is left as it was."""
    from urmx.cli import main

    text = gaps.read_text()
    calls: list = []
    link = tmp_path / "alias.toml"
    os.link(gaps, link)
    for out in (gaps, link, tmp_path / "sub" / ".." / "gaps.toml"):
        with pytest.raises(OutputError, match=r"archive .* is the study file .*gaps\.toml.*"
                           "an input is never overwritten") as err:
            st.run_study(gaps, out=out, kernel=_counting(calls), scheduler="serial",
                         progress=False)
        assert str(out) in str(err.value)
    (tmp_path / "sub").mkdir()
    with pytest.raises(OutputError, match="is the study file"):
        st.run_study(gaps, out=tmp_path / "sub" / ".." / "gaps.toml", kernel=_counting(calls))
    # a record's file and its manifest, as the manifest names them
    files = {rid: tmp_path / f"{rid}.txt" for rid in ACC}
    manifest_file = tmp_path / "manifest.toml"
    for path in (*files.values(), manifest_file):
        path.write_text("kept\n")
    serve = urmx.records.manifest

    def manifest(records_dir=None):
        return {rid: dict(e, path=str(files[rid]), manifest=str(manifest_file))
                for rid, e in serve(records_dir).items()}

    monkeypatch.setattr(urmx.records, "manifest", manifest)
    for out, what in ((files["shake"], "the file of record 'shake'"),
                      (manifest_file, "the records manifest")):
        with pytest.raises(OutputError, match=f"is {what} "):
            st.run_study(gaps, out=out, kernel=_counting(calls), scheduler="serial")
        assert out.read_text() == "kept\n"
    assert calls == [] and gaps.read_text() == text
    # the command line: one line, exit 2
    assert main(["run", str(gaps), "--out", str(gaps), "--scheduler", "serial"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("urmx run: error: archive ") and err.count("\n") == 1
    assert gaps.read_text() == text


def test_simulate_and_records_never_write_over_their_inputs(tmp_path, capsys):
    from urmx.cli import main

    wall = tmp_path / "wall.toml"
    shutil.copy(Path(urmx.__file__).parents[1] / "catalog" / "examples" / "benchmark-wall.toml",
                wall)
    rec = tmp_path / "rec.txt"
    rec.write_text("\n".join(f"{v:.3f}" for v in ACC["quake"]) + "\n")
    before = {p: p.read_bytes() for p in (wall, rec)}
    common = ["simulate", str(wall), str(rec), "--dt", "0.01", "--unit", "m/s2"]
    for option, target, what in (("--out", rec, "the record file"),
                                 ("--plot", rec, "the record file"),
                                 ("--out", wall, "the wall file")):
        assert main([*common, option, str(target)]) == 2
        err = capsys.readouterr().err
        assert f"{option} {str(target)!r} is {what}" in err and err.count("\n") == 1
    assert main([*common, "--out", str(tmp_path / "a.nc"), "--plot",
                 str(tmp_path / "a.nc")]) == 2
    assert "name the same file" in capsys.readouterr().err
    assert main(["records", "plot", str(rec), "--dt", "0.01", "--unit", "m/s2", "--out",
                 str(rec)]) == 2
    assert "is the record file" in capsys.readouterr().err
    folder = tmp_path / "suite"
    folder.mkdir()
    shutil.copy(rec, folder / "a.txt")
    assert main(["records", "index", str(folder), "--dt", "0.01", "--unit", "m/s2", "--out",
                 str(folder / "a.txt")]) == 2
    assert "is the record file" in capsys.readouterr().err
    assert {p: p.read_bytes() for p in (wall, rec)} == before
    assert (folder / "a.txt").read_bytes() == before[rec]


def _leftovers(*folders: Path) -> list[Path]:
    """Temporary files (urmx's ``.*.tmp``, ``.*.npz.tmp`` and output probes) in `folders`,
    recursively."""
    return [p for f in folders for p in f.rglob(".*") if ".tmp" in p.name
            or p.name.startswith(".urmx-probe")]


def test_out_through_a_symlink_and_dotdot_is_resolved_before_the_work(gaps_records, gaps,
                                                                       tmp_path):
    """``link/../x.nc`` with ``link`` a symbolic link to ``a/b``: the operating system's
    ``a/x.nc``. The path is resolved before the work, and the run writes exactly there
    (it used to run the whole study, then fail, leaving the archive as a hidden .tmp file
    in another folder)."""
    (tmp_path / "a" / "b").mkdir(parents=True)
    (tmp_path / "link").symlink_to(tmp_path / "a" / "b")
    out = tmp_path / "link" / ".." / "x.nc"
    ds = _run(gaps, out=out)
    _check_reductions(ds)
    assert (tmp_path / "a" / "x.nc").is_file() and not (tmp_path / "x.nc").exists()
    _same(ds, urmx.open_study(tmp_path / "a" / "x.nc").load())
    assert _leftovers(tmp_path) == []
    assert not (tmp_path / "a" / "x.nc.parts").exists()


def test_out_name_that_is_not_utf8_is_refused_before_the_work(gaps_records, gaps, tmp_path):
    calls: list = []
    out = Path(os.fsdecode(os.fsencode(tmp_path) + b"/r\xe9sultat.nc"))  # Latin-1 bytes
    with pytest.raises(OutputError, match=r"r\\udce9sultat\.nc' cannot be written: its name is "
                       "not valid UTF-8"):
        st.run_study(gaps, out=out, kernel=_counting(calls), scheduler="serial",
                     progress=False)
    assert calls == [] and os.listdir(os.fsencode(tmp_path)) == [b"gaps.toml"]


# ---- a full disk --------------------------------------------------------------------------

@pytest.fixture
def small_disk(tmp_path):
    """A 2 MB tmpfs mounted for the test (None when mounting is not permitted: not root, or
    no tmpfs)."""
    folder = tmp_path / "disk"
    folder.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(folder)],
                          capture_output=True) if os.geteuid() == 0 else None
    if done is None or done.returncode != 0:
        yield None
        return
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], capture_output=True)


def fill(folder: Path) -> Path:
    """Fill the disk of `folder` to the last byte with a file; returns it."""
    import errno

    ballast = folder / "ballast"
    fd = os.open(ballast, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o600)
    try:
        for size in (1 << 20, 1 << 14, 1 << 10, 64, 1):
            try:
                while True:
                    os.write(fd, b"\0" * size)
            except OSError as exc:
                if exc.errno != errno.ENOSPC:
                    raise
    finally:
        os.close(fd)
    return ballast


def _disk(way: str, small_disk, tmp_path) -> Path:
    if way == "tmpfs":
        if small_disk is None:
            pytest.skip("mounting a tmpfs is not permitted here (the 'patched' case runs)")
        return small_disk
    return tmp_path


def _enospc():
    import errno

    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


@pytest.mark.parametrize("way", ["tmpfs", "patched"])
def test_a_full_disk_while_saving_parts_says_what_is_kept(gaps_records, gaps, small_disk,
                                                         tmp_path, monkeypatch, way):
    """The disk fills after 3 of 6 batches: one line saying how many batches are kept and
    what to do, no temporary file left (a 0-byte one used to stay), and after freeing
    space the same run finishes with the 3 kept."""
    disk = _disk(way, small_disk, tmp_path)
    out = disk / "gaps.nc"
    parts = disk / "gaps.nc.parts"
    reference = _run(gaps)
    saved = []
    real_save = st.PartStore.save
    real_savez = np.savez

    def save(self, key, result, *cells):
        if len(saved) == 3 and way == "tmpfs":
            fill(disk)
        path = real_save(self, key, result, *cells)
        saved.append(key)
        return path

    def savez(file, *args, **kw):  # the 'patched' disk: full at the fourth part
        if len(saved) == 3:
            file.write(b"PK")  # an open temporary file: a few bytes, then the disk is full
            raise _enospc()
        return real_savez(file, *args, **kw)

    with monkeypatch.context() as patch, pytest.raises(OutputError) as err:
        patch.setattr(st.PartStore, "save", save)
        if way == "patched":
            patch.setattr(np, "savez", savez)
        _run(gaps, out=out)
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith(f"cannot write part file in {str(parts)!r}: No space left on "
                              f"device; 3 finished batches kept in {str(parts)!r}: free space "
                              "on its disk and run the same command again to resume"), message
    assert len(list(parts.glob("*.npz"))) == 3 and _leftovers(disk) == []
    if way == "tmpfs":
        (disk / "ballast").unlink()
    calls: list = []
    ds = st.run_study(gaps, out=out, kernel=_counting(calls), batch_size=2, scheduler="serial",
                      progress=False)
    assert 0 < len(calls) < 12  # of the 12 analyses, those of the 3 kept batches not again
    _same(reference, ds)
    assert _leftovers(disk) == [] and not parts.exists()


@pytest.mark.parametrize("way", ["tmpfs", "patched"])
def test_a_full_disk_at_the_final_write_keeps_the_parts(gaps_records, gaps, small_disk,
                                                        tmp_path, monkeypatch, way):
    """The disk fills after the last batch is saved: the archive write fails with one line
    saying that the parts are kept and how to finish (it used to be `NetCDF: HDF error`
    alone), no temporary file is left, and after freeing space the same run writes the
    archive without computing anything."""
    disk = _disk(way, small_disk, tmp_path)
    out = disk / "gaps.nc"
    parts = disk / "gaps.nc.parts"
    reference = _run(gaps)
    real_save = st.PartStore.save

    def save(self, key, result, *cells):
        path = real_save(self, key, result, *cells)
        if way == "tmpfs" and self.count() == 6:
            fill(disk)
        return path

    def to_netcdf(self, path, *args, **kw):  # what netCDF4 raises when HDF5 fails
        Path(path).write_bytes(b"\x89HDF\r\n")
        raise RuntimeError("NetCDF: HDF error")

    with monkeypatch.context() as patch, pytest.raises(OutputError) as err:
        patch.setattr(st.PartStore, "save", save)
        if way == "patched":  # netCDF4's error, on a disk that says it is full
            patch.setattr(xr.Dataset, "to_netcdf", to_netcdf)
            patch.setattr(urmx.netcdf, "disk_full", lambda folder, below=1e6: True)
        _run(gaps, out=out)
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith(f"cannot write netCDF file {str(out)!r}: "), message
    assert "MB free on its disk: the disk is full); " in message  # whatever netCDF says
    if way == "patched":
        assert "NetCDF: HDF error (" in message
    assert message.endswith(f"; 6 finished batches kept in {str(parts)!r}: free space on its "
                            "disk and run the same command again: the archive is written "
                            "from them, nothing is computed again"), message
    assert not out.exists() and _leftovers(disk) == []
    assert len(list(parts.glob("*.npz"))) == 6
    if way == "tmpfs":
        (disk / "ballast").unlink()
    calls: list = []
    ds = st.run_study(gaps, out=out, kernel=_counting(calls), batch_size=2, scheduler="serial",
                      progress=False)
    assert calls == []
    _same(reference, ds)
    _same(reference, urmx.open_study(out).load())
    assert _leftovers(disk) == []


@pytest.mark.parametrize("way", ["tmpfs", "patched"])
def test_a_full_disk_before_the_run_is_said_before_any_work(gaps_records, gaps, small_disk,
                                                            tmp_path, monkeypatch, way):
    """A test file is written (and flushed) where the archive goes before anything is
    computed: a full disk stops the run at once."""
    disk = _disk(way, small_disk, tmp_path)
    out = disk / "gaps.nc"
    if way == "tmpfs":
        fill(disk)
    else:
        def fsync(fd):
            raise _enospc()

        monkeypatch.setattr(os, "fsync", fsync)
    calls: list = []
    with pytest.raises(OutputError, match=rf"archive {str(out)!r} cannot be written: a test "
                       rf"file in {str(disk)!r} failed: No space left on device"):
        st.run_study(gaps, out=out, kernel=_counting(calls), scheduler="serial",
                     progress=False)
    assert calls == [] and not (disk / "gaps.nc.parts").exists() and _leftovers(disk) == []


# ---- SIGTERM -------------------------------------------------------------------------------

def test_sigterm_stops_like_ctrl_c(tmp_path):
    """SIGTERM (``kill PID``, a batch system ending a job) once a few batches are saved:
    exit 143 and one line saying what is kept, as Ctrl-C does; the same command then
    finishes. (It used to die silently, with status -15.)"""
    from .fixtures import cluster as C

    study = tmp_path / "cluster.toml"
    study.write_text(C.STUDY)
    out = tmp_path / "term.nc"
    parts = tmp_path / "term.nc.parts"
    args = ["run", str(study), "--out", str(out), "--scheduler", "serial", "--batch-size",
            "1", "--quiet"]
    proc = C.urmx_run(args, sleep=0.05)
    C.wait_until(lambda: C.parts_of(out) >= 3, C.START, "3 batches saved", proc)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    kept = C.parts_of(out)
    assert proc.returncode == 143, err
    assert err == (f"urmx run: terminated; {kept} finished batches kept in {parts}/: run the "
                   "same command again to resume\n")
    assert 3 <= kept < C.BATCHES and not out.exists() and _leftovers(tmp_path) == []
    again = C.urmx_run(args)
    _, err = again.communicate(timeout=120)
    assert again.returncode == 0, err
    assert out.is_file() and not parts.exists()


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


def test_a_part_being_written_is_never_counted_as_a_part(tmp_path, monkeypatch):
    """A part is written under a temporary name that no ``*.npz`` glob matches: the
    interrupt test once saw three parts, of which one was still being written and was
    deleted by the SIGINT (a count that went down)."""
    from urmx.study.parts import PartStore

    store = PartStore(tmp_path, ("a",))
    seen = []
    real = os.replace

    def spy(src, dst):
        seen.append((Path(src).name, sorted(p.name for p in tmp_path.glob("*.npz"))))
        real(src, dst)

    monkeypatch.setattr(os, "replace", spy)
    store.save("k1", {"a": np.arange(3.0)}, np.arange(3, dtype=np.uint64))
    assert seen == [(f".k1.{os.getpid()}.npz.tmp", [])]
    assert store.count() == 1 and sorted(p.name for p in tmp_path.iterdir()) == ["k1.npz"]
    assert np.array_equal(store.load("k1")["a"], np.arange(3.0))
