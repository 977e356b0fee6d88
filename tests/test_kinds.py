"""Study kinds are plug-ins: a toy kind defined here in a few lines and registered from
outside the package (`urmx.study.kinds.register`) runs through `urmx.run_study` with an
archive, the lock, progress and a resume after a SIGKILL of the process running it, with no
edit to the engine, the catalog or the registry's other entries; and each built-in kind's
batch runs on numpy alone (a fresh process running one imports no xarray, dask or ObsPy)."""

from __future__ import annotations

import io
import json
import os
import pickle
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
import xarray as xr

import urmx
from urmx.catalog import CatalogError
from urmx.errors import RunError
from urmx.study import Lock, kinds
from urmx.study.dataset import grid_coords
from urmx.study.file import load_study

from .fixtures.signals import killed_after_parts
from .helpers.runs import same_run
from .helpers.synthetic import DT, SAMPLING_ACC
from .helpers.synthetic import TOY_ACC as ACC
from .helpers.synthetic import TOY_SCALE as SCALE

# ---- the toy kind: value = gain * record peak * wall height * cor, one value per cell -------

SLEEP = "URMX_TOY_SLEEP"  # seconds a toy batch takes (the killed process reads it)
RUNS: list[int] = []  # batches run in this process


def toy_parse(study):
    gain = study.tables["toy"].get("gain", 1.0)
    if isinstance(gain, bool) or not isinstance(gain, (int, float)) or gain <= 0:
        raise study.error("study.toy.gain", f"{gain!r} must be a positive number", "toy",
                          "gain")
    return float(gain)


def toy_task(study, records, batch, kernel):
    return {"heights": [study.walls[i].wall.height for i in batch.block["wall"]],
            "cor": [study.cor[i] for i in batch.block["cor"]], "gain": study.settings,
            "shape": batch.shape}


def toy_run(task, acceleration):
    time.sleep(float(os.environ.get(SLEEP, "0")))
    RUNS.append(1)
    peak = float(np.max(np.abs(acceleration)))
    value = task["gain"] * peak * np.outer(task["heights"], task["cor"])
    return {"value": np.broadcast_to(value[:, None, None, :], task["shape"]).copy()}


def toy_assemble(study, records, cells, extras, attrs):
    return xr.Dataset({"value": (list(study.dims), cells["value"])}, attrs=attrs,
                      coords=grid_coords(study, records))


TOY = kinds.register(kinds.Kind(name="toy", table="toy", unit="cells", outputs=("value",),
                                parse=toy_parse, task=toy_task, run=toy_run,
                                assemble=toy_assemble))

# ---- the tests -------------------------------------------------------------------------------

STUDY = """\
[study]
name = "toy-study"
walls = ["s08", "s16", "s24"]
diaphragms = ["D1", "D4"]
records = ["quake", "shake"]
cor = [0.7, 0.8]

[study.toy]
gain = 2.0
"""
BATCHES = 24  # 3 walls x 2 diaphragms x 2 records x 2 cor, one cell a batch (batch_size 1)


@pytest.fixture
def toy(make_study, use_records):
    use_records(ACC, SCALE, DT)
    RUNS.clear()
    return make_study(STUDY, "toy.toml")


def test_a_kind_registered_from_outside_runs_into_an_archive(toy, tmp_path):
    study = load_study(toy)
    assert (study.kind, study.settings) == ("toy", 2.0)
    out = tmp_path / "toy.nc"
    ds = urmx.run_study(toy, out=out, scheduler="serial", progress=False, batch_size=1)
    assert len(RUNS) == BATCHES and not (tmp_path / "toy.nc.parts").exists()
    cell = ds.value.sel(wall="s16", diaphragm="D4", record="shake", cor=0.8)
    assert float(cell) == pytest.approx(2.0 * 3.0 * 16 * 0.23 * 0.8, rel=1e-12)
    assert ds.value.dims == ("wall", "diaphragm", "record", "cor")
    assert ds.attrs["study_name"] == "toy-study"
    same_run(ds, urmx.open_study(out).load())
    assert [k.name for k in kinds.registered()][:2] == ["grid", "ida"]  # built-ins untouched


def test_the_catalog_refuses_tables_no_kind_reads_and_lets_the_kind_parse(make_study):
    path = make_study(STUDY.replace("[study.toy]", "[study.nokind]"), "bad.toml")
    with pytest.raises(CatalogError, match=r"bad\.toml:8: study\.nokind: unknown key"):
        load_study(path)
    path = make_study(STUDY.replace("gain = 2.0", "gain = -1"), "bad.toml")
    with pytest.raises(CatalogError, match=r"bad\.toml:9: study\.toy\.gain: -1 must be"):
        load_study(path)
    path = make_study(STUDY + '[study.ida]\nim = "pga"\n', "both.toml")
    with pytest.raises(CatalogError, match="make no one study kind"):
        load_study(path)


def test_the_lock_and_progress_hold_for_the_toy_kind(toy, tmp_path):
    out = tmp_path / "busy.nc"
    with Lock(tmp_path / "busy.nc.parts", out), \
            pytest.raises(RunError, match=r"another urmx run \(pid \d+"):
        urmx.run_study(toy, out=out, scheduler="serial", progress=False)
    assert RUNS == []
    err = io.StringIO()
    saved, sys.stderr = sys.stderr, err
    try:
        urmx.run_study(toy, out=out, scheduler="serial", progress=True, batch_size=1)
    finally:
        sys.stderr = saved
    lines = err.getvalue().splitlines()
    assert lines[0].startswith("urmx toy-study:   0% 0/24")  # 24 cells
    assert lines[-1].startswith("urmx toy-study: 100% 24/24") and "cells/s" in lines[-1]


RUN = f"""\
import sys
import urmx
import {__name__} as T
from tests.fixtures.pinned import served

with served(T.ACC, T.SCALE, T.DT):
    urmx.run_study(sys.argv[1], out=sys.argv[2], scheduler="serial", progress=False,
                   batch_size=1)
"""


def test_the_toy_kind_resumes_after_its_run_is_killed(toy, tmp_path):
    out = tmp_path / "killed.nc"
    parts = tmp_path / "killed.nc.parts"
    kept = killed_after_parts(["-c", RUN, str(toy), str(out)], parts, 3,
                              dict(os.environ, **{SLEEP: "0.5"}), timeout=120)
    assert 3 <= kept < BATCHES and not out.exists()
    ds = urmx.run_study(toy, out=out, scheduler="serial", progress=False, batch_size=1)
    assert len(RUNS) == BATCHES - kept  # the killed run's batches are not run again
    RUNS.clear()
    same_run(ds, urmx.run_study(toy, scheduler="serial", progress=False, batch_size=1))


# ---- a batch runs on numpy alone ---------------------------------------------------------------

HEAVY = ("xarray", "dask", "distributed", "obspy", "pandas")
BATCH = """\
import json, pickle, sys
from urmx.study import kinds
from urmx.study.clients import record_samples

name, task, acc = pickle.load(open(sys.argv[1], "rb"))
out = kinds.get(name).run(task, record_samples(acc))
assert all(isinstance(v, type(acc)) for v in out.values())
print(json.dumps(sorted({m.split(".")[0] for m in sys.modules} & set(sys.argv[2:]))))
"""


@pytest.mark.parametrize("extra", ["", '[study.ida]\nim = "sa_wall"\nrtol = 0.05\n'])
def test_a_batch_of_each_kind_imports_numpy_only(make_study, tmp_path, extra):
    """The batch runner of each built-in kind, run in a fresh process (the record samples
    through the task the engine submits for them), imports none of xarray, dask,
    distributed, ObsPy or pandas; the IDA batch computes its spectral intensity and the
    record's predominant frequency there."""
    from urmx.records import Record

    acc = SAMPLING_ACC["quake"]
    path = make_study('[study]\nwalls = ["s16"]\ndiaphragms = ["D1"]\nrecords = ["x"]\n'
                      "cor = [0.8]\n" + extra, "batch.toml")
    study = load_study(path)
    (batch, task), = urmx.study.batch_tasks(study, {"x": Record("x", acc, 0.01)})
    assert task.get("predominant", True)
    job = tmp_path / "job.pickle"
    job.write_bytes(pickle.dumps((study.kind, task, acc)))
    done = subprocess.run([sys.executable, "-c", BATCH, str(job), *HEAVY],
                          capture_output=True, text=True, check=True)
    assert json.loads(done.stdout.splitlines()[-1]) == []


# ---- a new kind end to end: one module's worth of code + one line in each registry ---------

def tiny_parse(study):
    return float(study.tables["tiny"].get("gain", 1.0))


def tiny_report(archive, out_dir):
    """The tiny kind's report (what ``reports/tiny.py`` would hold): its cells and the mean
    of its one output."""
    from pathlib import Path

    from urmx.study.archive import open_archive

    ds = open_archive(archive)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "REPORT.md"
    path.write_text(f"# {ds.attrs['study_name']}\n\n{ds.value.size} cells, mean value "
                    f"{float(ds.value.mean()):.6g}\n", encoding="utf-8")
    return path


@pytest.fixture
def tiny():
    """The kind ``tiny`` (the toy's functions, its own table) registered for one test with
    one line in the kinds' registry and one in the reports', then removed from both."""
    from urmx.reports import REPORTS

    kinds.register(kinds.Kind(name="tiny", table="tiny", unit="cells", outputs=("value",),
                              parse=tiny_parse, task=toy_task, run=toy_run,
                              assemble=toy_assemble))
    REPORTS["tiny"] = tiny_report
    yield
    if "tiny" in {k.name for k in kinds.registered()}:  # (the test may have removed it)
        kinds.unregister("tiny")
    REPORTS.pop("tiny", None)


def test_a_new_kind_runs_and_reports_with_one_line_in_each_registry(tiny, make_study,
                                                                   use_records, tmp_path,
                                                                   capsys):
    """`urmx run` and `urmx report` serve a kind registered from outside: the report is
    the kind's own (chosen by the archive's kind), its numbers those of the archive; once
    removed, the kind is unknown again and its archive gets the default report."""
    from urmx.cli import main
    from urmx.reports import DEFAULT, REPORTS, writer
    from urmx.study.summary import kind_of

    use_records(ACC, SCALE, DT)
    study = make_study(STUDY.replace("toy-study", "tiny-study").replace("[study.toy]",
                                                                       "[study.tiny]"))
    out = tmp_path / "tiny.nc"
    assert main(["run", str(study), "--out", str(out), "--scheduler", "serial",
                 "--quiet"]) == 0
    ds = urmx.open_study(out).load()
    assert kind_of(ds) == "tiny" and writer(ds) is tiny_report
    # value = gain 2 * record peak (2 or 3) * wall height * cor, as the toy computes it
    peak = xr.DataArray([2.0, 3.0], dims="record", coords={"record": ["quake", "shake"]})
    expected = 2.0 * peak * ds.height * ds.cor
    np.testing.assert_allclose(ds.value.values, expected.broadcast_like(ds.value)
                               .transpose(*ds.value.dims).values, rtol=1e-12)
    assert main(["report", str(out), "--out", str(tmp_path / "rep")]) == 0
    text = (tmp_path / "rep" / "REPORT.md").read_text()
    assert text == f"# tiny-study\n\n24 cells, mean value {float(expected.mean()):.6g}\n"
    capsys.readouterr()
    kinds.unregister("tiny")
    del REPORTS["tiny"]
    assert "tiny" not in {k.name for k in kinds.registered()}
    assert writer(ds) is REPORTS[DEFAULT] and REPORTS[DEFAULT] is not tiny_report


# ---- what a kind prepares while its cells run; the parts kept for the gathering --------------

PREPARED: list[tuple[str, int]] = []  # (thread, batches run before prepare began)


def prepped_parse(study):
    return float(study.tables["prepped"].get("gain", 1.0))


def prepped_prepare(study, records):
    PREPARED.append((threading.current_thread().name, len(RUNS)))
    if study.settings < 0.5:
        raise ValueError("prepare refused a gain below 0.5")
    return {rid: float(np.max(np.abs(records[rid].acceleration))) for rid in study.records}


def prepped_assemble(study, records, cells, extras, attrs, prepared=None):
    ds = toy_assemble(study, records, cells, extras, attrs)
    ds["peak"] = ("record", [prepared[rid] for rid in study.records])
    return ds


@pytest.fixture
def prepped(make_study, use_records):
    """The toy with a ``prepare`` (the record peaks) that assemble stores."""
    kinds.register(kinds.Kind(name="prepped", table="prepped", unit="cells",
                              outputs=("value",), parse=prepped_parse, task=toy_task,
                              run=toy_run, assemble=prepped_assemble,
                              prepare=prepped_prepare))
    use_records(ACC, SCALE, DT)
    RUNS.clear()
    PREPARED.clear()
    yield lambda gain: make_study(STUDY.replace("[study.toy]", "[study.prepped]").replace(
        "gain = 2.0", f"gain = {gain}"), "prepped.toml")
    kinds.unregister("prepped")


def test_a_kinds_prepare_runs_in_a_thread_once_the_cells_run_and_reaches_assemble(
        prepped, tmp_path):
    """``prepare`` starts with the first result (in its own thread, not while a cluster
    starts) and its value reaches ``assemble``; without cells to run it runs there."""
    out = tmp_path / "prepped.nc"
    ds = urmx.run_study(prepped(2.0), out=out, scheduler="serial", progress=False,
                        batch_size=1)
    (thread, before), = PREPARED
    assert thread == "urmx-prepare" and before >= 1  # after the first batch, in a thread
    np.testing.assert_array_equal(ds.peak.values, [2.0, 3.0])  # the records' peaks
    PREPARED.clear()
    again = urmx.run_study(prepped(2.0), out=out, scheduler="serial", progress=False)
    assert PREPARED[0][0] == "MainThread"  # every cell taken from the archive
    np.testing.assert_array_equal(again.peak.values, ds.peak.values)


def test_a_failing_prepare_fails_the_run_with_its_own_error(prepped, tmp_path):
    with pytest.raises(ValueError, match="prepare refused a gain below 0.5"):
        urmx.run_study(prepped(0.25), out=tmp_path / "bad.nc", scheduler="serial",
                       progress=False, batch_size=1)
    assert [t for t, _ in PREPARED] == ["urmx-prepare"] and len(RUNS) == BATCHES


def test_the_parts_just_saved_are_gathered_from_memory_with_the_same_archive(
        toy, tmp_path, monkeypatch):
    """The parts of a small study are gathered from the copies kept when they were saved
    (no file read back); with no room to keep them, from the files: the same archive."""
    from urmx.study import sources

    reads = []
    load = sources.load_part
    monkeypatch.setattr(sources, "load_part", lambda *a: reads.append(a) or load(*a))
    kept = urmx.run_study(toy, out=tmp_path / "kept.nc", scheduler="serial",
                          progress=False, batch_size=1)
    assert reads == []
    monkeypatch.setattr(sources, "RECENT_BYTES", 0)
    read = urmx.run_study(toy, out=tmp_path / "read.nc", scheduler="serial",
                          progress=False, batch_size=1)
    assert len(reads) == BATCHES
    same_run(kept, read)
    xr.testing.assert_identical(kept.value, read.value)
