"""Studies of any size (issue 29) and work reused, never mixed (issue 22, item 4): batches cut
over every dimension, finished work found per cell (a resume with another batch size, after
a SIGKILL, computes no finished cell), a study extended by a record, a wall or a cor value
computing only its new cells, an archive or parts folder of another study never overwritten
without ``force``, a changed record file recomputed, and the size of a study checked before
any work.

A vectorised stand-in kind (``sweep``: value = gain x record peak x wall height x cor x
scale) runs a COR x scale grid of 10^6 cells in seconds; the grid kind runs on a counting
stand-in kernel; records are in-memory samples or small PEER files in a temporary folder
with its own manifest (`urmx.records.manifest.index`).
"""

from __future__ import annotations

import io
import os
import sys
import time

import numpy as np
import pytest
import xarray as xr

import urmx
from urmx import study as st
from urmx.errors import OutputError, RunError
from urmx.study import kinds
from urmx.study.batches import Cut
from urmx.study.cells import Cells
from urmx.study.dataset import coord, grid_coords
from urmx.study.file import load_study
from urmx.study.limits import SizeError

from .fixtures.signals import killed_after_parts
from .helpers.grid_study import fake_kernel
from .helpers.own_records import (
    Interrupt,
    counting,
    index_folder,
    own_grid,
    quiet_run,
    write_at2,
)
from .helpers.runs import same_run
from .helpers.synthetic import DT, PULSE, PULSE_SCALE
from .helpers.synthetic import SWEEP_ACC as ACC
from .helpers.synthetic import SWEEP_SCALE as SCALE

# ---- a vectorised stand-in kind over cor x scale ------------------------------------------

SLEEP = "URMX_SWEEP_SLEEP"  # seconds a sweep batch takes (the killed process reads it)


def sweep_parse(study):
    return float(study.tables["sweep"].get("gain", 1.0))


def sweep_task(study, records, batch, kernel):
    b = batch.block
    return {"height": [study.walls[i].wall.height for i in b["wall"]],
            "cor": [study.cor[i] for i in b["cor"]],
            "scale": [study.extra["scale"][i] for i in b["scale"]],
            "gain": study.settings, "shape": batch.shape}


def sweep_run(task, acceleration):
    time.sleep(float(os.environ.get(SLEEP, "0")))
    peak = float(np.max(np.abs(acceleration)))
    h, c, s = (np.asarray(task[k]) for k in ("height", "cor", "scale"))
    value = task["gain"] * peak * h[:, None, None, None, None] * c[:, None] * s
    return {"value": np.broadcast_to(value, task["shape"]).copy()}


def sweep_assemble(study, records, cells, extras, attrs):
    coords = dict(grid_coords(study, records),
                  scale=coord("scale", "scale", np.array(study.extra["scale"])))
    return xr.Dataset({"value": (list(study.dims), cells["value"])}, coords=coords,
                      attrs=attrs)


SWEEP = kinds.register(kinds.Kind(name="sweep", table="sweep", unit="cells",
                                  outputs=("value",), parse=sweep_parse, task=sweep_task,
                                  run=sweep_run, assemble=sweep_assemble))

# 1 wall x 1 diaphragm x 1 record x 1000 cor x 1000 scale = 10^6 cells (on main at 7ab99c0
# one batch, whatever --batch-size)
MILLION = """\
[study]
name = "cor-scale"
walls = ["s16"]
diaphragms = ["D1"]
records = ["quake"]
cor = {start = 0.5, stop = 0.9995, step = 0.0005}
scale = {start = 0.001, stop = 1.0, step = 0.001}

[study.sweep]
gain = 2.0
"""
CELLS = 1_000_000


@pytest.fixture
def million(make_study, use_records):
    use_records(ACC, SCALE, DT)
    return make_study(MILLION, "million.toml")


def test_a_million_cells_are_cut_into_many_batches(million):
    study = load_study(million)
    records = st.resolve_records(study)
    cells = Cells(study, SWEEP, records)
    assert cells.size == CELLS
    assert Cut(cells, 16).counts() == (0, 63_000)  # every dimension is cut: 1000 cor x 63
    tasks = st.batch_tasks(study, records, 4000)
    assert len(tasks) == 250 and {b.size for b, _ in tasks} == {4000}
    assert len({b.key for b, _ in tasks}) == 250
    blocks = [(b.block["cor"][0], len(b.block["cor"]), len(b.block["scale"])) for b, _ in tasks]
    assert blocks[:2] == [(0, 4, 1000), (4, 4, 1000)]


RUN = """\
import sys
import urmx
import {module} as T
from tests.fixtures.pinned import served

with served(T.{acc}, T.{scale}, {dt}):
    urmx.run_study(sys.argv[1], out=sys.argv[2], scheduler="serial", progress=False,
                   batch_size=int(sys.argv[3]){kernel})
"""


def _child(acc: str = "ACC", scale: str = "SCALE", dt: float = DT, kernel: str = "") -> str:
    """The script of a child process that runs a study on in-memory records (this module's
    `acc` and `scale`), with ``kernel=T.<kernel>`` when given."""
    return RUN.format(module=__name__, acc=acc, scale=scale, dt=dt,
                      kernel=f", kernel=T.{kernel}" if kernel else "")


def _values(ds: xr.Dataset) -> np.ndarray:
    return np.asarray(ds["value"].values)


def test_a_million_cells_resume_after_a_kill_with_another_batch_size(million, tmp_path):
    """SIGKILL of the process running the 10^6-cell study (250 batches of 4000) once 20
    batches are saved; the resumed run, with batches of 10,000 cells, computes exactly the
    cells the killed run did not save, and its archive equals an uninterrupted run's."""
    out = tmp_path / "million.nc"
    parts = tmp_path / "million.nc.parts"
    kept = killed_after_parts(["-c", _child(), str(million), str(out), "4000"], parts, 20,
                              dict(os.environ, **{SLEEP: "0.1"}))
    assert 20 <= kept < 250 and not out.exists()
    err = io.StringIO()
    saved, sys.stderr = sys.stderr, err
    try:
        ds = urmx.run_study(million, out=out, scheduler="serial", progress=True,
                            batch_size=10_000)
    finally:
        sys.stderr = saved
    run = st.last_run()
    assert (run.from_parts, run.computed, run.runs) == (4000 * kept, CELLS - 4000 * kept, CELLS)
    assert run.batches >= (CELLS - 4000 * kept) // 10_000
    assert f"{4000 * kept:,} of {CELLS:,} cells found" in err.getvalue()
    assert not parts.exists()
    reference = urmx.run_study(million, scheduler="serial", progress=False, batch_size=50_000)
    np.testing.assert_array_equal(_values(ds), _values(reference))
    # s16 (h 3.68 m) at cor 0.7, scale 0.5: 2.0 x 2.0 x 3.68 x 0.7 x 0.5
    cell = ds.value.sel(cor=0.7, scale=0.5).squeeze()
    assert float(cell) == pytest.approx(2.0 * 2.0 * 3.68 * 0.7 * 0.5, rel=1e-12)


# ---- the grid kind: a COR x scale grid of 10^6 analyses, and a real one killed -------------

COR_SCALE = MILLION.split("\n[study.sweep]")[0].replace('"cor-scale"', '"cor-scale-grid"')


def test_a_million_analysis_cor_scale_grid_is_cut_into_many_batches(make_study, use_records):
    """1 wall x 1 diaphragm x 1 record over 1000 CORs x 1000 scales: 10^6 analyses of the
    grid kind, cut into many batches from the plan alone (nothing runs). On main at 8b38483
    (and 7ab99c0) the grid was cut by wall only: one batch of 10^6 analyses whatever
    --batch-size, run in the main process."""
    use_records(ACC, SCALE, DT)
    study = load_study(make_study(COR_SCALE, "cor-scale.toml"))
    grid_kind = kinds.get("grid")
    size = st.size_of(study, grid_kind)
    assert (size.cells, size.runs, size.unit) == (CELLS, CELLS, "analyses")
    records = st.resolve_records(study)
    cells = Cells(study, grid_kind, records)
    assert cells.shape == (1, 1, 1, 1000, 1000)
    assert Cut(cells, 16).counts() == (0, 63_000)  # the default --batch-size
    tasks = st.batch_tasks(study, records, 4000)
    assert len(tasks) == 250 and {b.size for b, _ in tasks} == {4000}
    assert len({b.key for b, _ in tasks}) == 250
    first, task = tasks[0]
    assert (first.block["cor"], len(first.block["scale"])) == ([0, 1, 2, 3], 1000)
    assert task["cor"] == [0.5, 0.5005, 0.501, 0.5015] and len(task["scale"]) == 1000
    keys = np.concatenate([b.cells.ravel() for b, _ in tasks])
    assert keys.size == CELLS and np.unique(keys).size == CELLS


REAL_SLEEP = "URMX_REAL_SLEEP"  # seconds the real-kernel stand-in waits per analysis
REAL_CALLS: list = []
REAL_GRID = """\
[study]
name = "real-cor-scale"
walls = ["s16"]
diaphragms = ["D1"]
records = ["pulse"]
cor = {start = 0.70, stop = 0.89, step = 0.01}
scale = {start = 0.5, stop = 2.9, step = 0.1}
"""
REAL_RUNS = 20 * 25


def slow_real(*args, **kw):
    """`urmx.kernel.run`, counted in :data:`REAL_CALLS` and slowed by ``$URMX_REAL_SLEEP``
    (so that a child process can be killed partway); its name is part of the cells' keys,
    the same in the child and here."""
    from urmx.kernel import run

    REAL_CALLS.append(1)
    time.sleep(float(os.environ.get(REAL_SLEEP, "0")))
    return run(*args, **kw)


def test_a_real_cor_scale_grid_resumes_after_a_kill_with_another_batch_size(
        make_study, use_records, tmp_path):
    """The grid kind on the real kernel, 1 wall x 1 diaphragm x 1 record x 20 CORs x 25
    scales: SIGKILL of the run (batches of 8) once 10 parts are saved; the resumed run, with
    batches of 25, keeps every finished batch, computes exactly the analyses not saved, and
    its archive holds the values of an uninterrupted run on `urmx.kernel.run`."""
    use_records(PULSE, PULSE_SCALE, 0.01)
    path = make_study(REAL_GRID, "real.toml")
    out = tmp_path / "real.nc"
    parts = tmp_path / "real.nc.parts"
    script = _child("PULSE", "PULSE_SCALE", 0.01, "slow_real")
    count = killed_after_parts(["-c", script, str(path), str(out), "8"], parts, 10,
                               dict(os.environ, **{REAL_SLEEP: "0.03"}))
    assert 10 <= count < 80 and not out.exists()  # 20 CORs x 4 pieces of the 25 scales
    kept = {p.name: int(np.load(p)["cell_key"].size) for p in parts.glob("*.npz")}
    saved = sum(kept.values())
    assert len(kept) == count and set(kept.values()) <= {7, 4}  # 7 + 7 + 7 + 4 scales
    REAL_CALLS.clear()
    err = io.StringIO()
    stderr, sys.stderr = sys.stderr, err
    try:
        ds = st.run_study(path, out=out, scheduler="serial", progress=True, batch_size=25,
                          kernel=slow_real).load()
    finally:
        sys.stderr = stderr
    run = st.last_run()
    assert (run.from_parts, run.computed, run.runs) == (saved, REAL_RUNS - saved, REAL_RUNS)
    assert len(REAL_CALLS) == REAL_RUNS - saved  # no finished analysis computed again
    assert f"resuming from {parts}: {saved:,} of {REAL_RUNS:,} analyses found" in err.getvalue()
    assert not parts.exists()
    reference = st.run_study(path, scheduler="serial", progress=False, batch_size=500)
    assert int((reference.status == 0).sum()) > 0 and int((reference.status == 1).sum()) > 0
    for name in reference.data_vars:
        assert np.asarray(ds[name].values).tobytes() == \
            np.asarray(reference[name].values).tobytes(), name


# ---- the grid kind: resume with another batch size ------------------------------------------

GRID = """\
[study]
name = "grid-cells"
walls = ["s08", "s18"]
diaphragms = ["D1", "D5-pinned"]
supports = "top"
records = ["quake", "shake"]
cor = {start = 0.70, stop = 0.79, step = 0.01}
scale = [0.5, 1.0, 2.0]
pairs = {s08 = ["quake", "shake"], s18 = ["shake"]}
"""
GRID_RUNS = (2 + 1) * 2 * 10 * 3  # (wall, record) pairs x diaphragms x cor x scale = 180


@pytest.fixture
def grid(make_study, use_records):
    from .helpers.grid_study import ACC as ACC2
    from .helpers.grid_study import SCALE as SCALE2

    use_records(ACC2, SCALE2, DT)
    return make_study(GRID, "grid.toml")


@pytest.mark.parametrize("first, second", [(7, 30), (30, 7), (4, 1)])
def test_a_grid_resumes_with_another_batch_size_computing_no_finished_cell(grid, tmp_path,
                                                                          first, second):
    calls: list = []
    reference = st.run_study(grid, kernel=counting(calls), scheduler="serial",
                             progress=False, batch_size=first)
    assert len(calls) == GRID_RUNS
    calls.clear()
    out = tmp_path / "grid.nc"
    with pytest.raises(Interrupt):
        st.run_study(grid, out=out, kernel=counting(calls, 100), scheduler="serial",
                     progress=False, batch_size=first)
    kept = sum(int(np.load(p)["cell_key"].size)
               for p in (tmp_path / "grid.nc.parts").glob("*.npz"))
    assert 0 < kept <= 100
    calls.clear()
    ds = st.run_study(grid, out=out, kernel=counting(calls), scheduler="serial",
                      progress=False, batch_size=second)
    assert len(calls) == GRID_RUNS - kept  # no finished cell computed again
    assert st.last_run().from_parts == kept and st.last_run().computed == len(calls)
    same_run(ds.load(), reference)


# ---- studies extended: only the new cells are computed ----------------------------------------

def _run_own(path, out, folder, calls, **kw):
    kw.setdefault("progress", False)
    return st.run_study(path, out=out, records_dir=folder, kernel=counting(calls),
                        scheduler="serial", **kw)


@pytest.mark.parametrize("change, new", [
    ({"records": ("rec1", "rec2", "rec3", "rec4")}, 2 * 2 * 1 * 2),  # a record
    ({"walls": ("s08", "s12", "s18")}, 1 * 2 * 3 * 2),  # a wall, between the others
    ({"cor": (0.7, 0.75, 0.8)}, 2 * 2 * 3 * 1),  # a cor value, between the others
])
def test_an_extended_study_computes_only_its_new_cells(make_study, own_records, tmp_path,
                                                       change, new):
    out = tmp_path / "own.nc"
    calls: list = []
    first = _run_own(own_grid(make_study), out, own_records, calls).load()
    assert len(calls) == 2 * 2 * 3 * 2
    calls.clear()
    err = io.StringIO()
    saved, sys.stderr = sys.stderr, err
    try:
        ds = _run_own(own_grid(make_study, **change), out, own_records, calls,
                      progress=True).load()
    finally:
        sys.stderr = saved
    assert len(calls) == new
    run = st.last_run()
    assert (run.from_archive, run.computed) == (24, new)
    assert f"24 of {24 + new} analyses reused (0 from parts, 24 from the archive), " \
           f"{new} to compute" in err.getvalue()
    old = ds.sel({k: first[k].values for k in ("wall", "record", "cor")})
    for name in first.data_vars:  # bitwise: NaN where NaN, every other bit equal
        a, b = np.asarray(first[name].values), np.asarray(old[name].values)
        assert a.tobytes() == b.tobytes(), name
    calls.clear()
    fresh = st.run_study(own_grid(make_study, **change), records_dir=own_records,
                         kernel=counting(calls), scheduler="serial", progress=False)
    same_run(ds, fresh)


def test_own_record_files_and_wall_extended_by_a_fourth_record(tmp_path):
    """Issue 22: three own record files (an AT2, one channel of a multi-channel V2A, a plain
    file with dt and unit) and an own wall with its own diaphragm, on the real kernel; the
    same study with a fourth record computes exactly its 2 new cells and takes the 6 others
    from the archive, bitwise equal; the archive lists every record's sha256 and file name;
    after one record file is edited, a third run computes that record's cells again."""
    import hashlib
    import shutil

    from .fixtures.records import record_file
    from .helpers.own_files import AT2, OWN_FILES, PLAIN, V2A

    data = tmp_path / "data"
    data.mkdir()
    for rel, name in ((AT2, None), (V2A, None), (PLAIN, "my-record.txt"),
                      ("formats/peer/RSN763_LOMAP_GIL337.AT2", None)):
        src = record_file(rel)
        shutil.copy(src, data / (name or src.name))
    three = tmp_path / "three.toml"
    three.write_text(OWN_FILES, encoding="utf-8")
    four = tmp_path / "four.toml"
    four.write_text(OWN_FILES.replace('records = ["gilroy", "wtmc", "mine"]',
                                'records = ["gilroy", "wtmc", "mine", "gil337"]')
                    + '\n[records.gil337]\nfile = "data/RSN763_LOMAP_GIL337.AT2"\n',
                    encoding="utf-8")
    out = tmp_path / "own.nc"
    first, _ = quiet_run(three, out=out, scheduler="serial")
    assert (st.last_run().from_archive, st.last_run().computed) == (0, 6)
    second, said = quiet_run(four, out=out, scheduler="serial")
    assert (st.last_run().from_archive, st.last_run().computed) == (6, 2)
    assert "urmx own-files: 6 of 8 analyses reused (0 from parts, 6 from the archive), " \
           "2 to compute" in said
    old = second.sel(record=["gilroy", "wtmc", "mine"])
    for name in first.data_vars:  # bitwise: every bit of every old cell
        assert np.asarray(first[name].values).tobytes() == \
            np.asarray(old[name].values).tobytes(), name
    files = {"gilroy": "data/RSN763_LOMAP_GIL067.AT2",
             "wtmc": "data/20161113_110259_WTMC_20.V2A", "mine": "data/my-record.txt",
             "gil337": "data/RSN763_LOMAP_GIL337.AT2"}
    assert list(second.record.values) == list(files)
    assert list(second.record_file.values) == list(files.values())
    assert list(second.record_sha256.values) == [
        hashlib.sha256((tmp_path / f).read_bytes()).hexdigest() for f in files.values()]
    fresh = st.run_study(four, scheduler="serial", progress=False)
    for name in fresh.data_vars:
        assert np.asarray(fresh[name].values).tobytes() == \
            np.asarray(second[name].values).tobytes(), name
    # one record file edited (a header line; its samples are the same): its cells again
    at2 = data / "RSN763_LOMAP_GIL067.AT2"
    lines = at2.read_text().splitlines(keepends=True)
    lines[1] = lines[1].replace("Loma Prieta", "Loma Prieta (edited)")
    at2.write_text("".join(lines))
    third, said = quiet_run(four, out=out, scheduler="serial")
    assert (st.last_run().from_archive, st.last_run().computed) == (6, 2)
    assert "6 of 8 analyses reused (0 from parts, 6 from the archive), 2 to compute" in said
    assert str(third.record_sha256.sel(record="gilroy").values) == \
        hashlib.sha256(at2.read_bytes()).hexdigest() != \
        str(second.record_sha256.sel(record="gilroy").values)


def test_a_changed_record_file_is_computed_again(make_study, own_records, tmp_path):
    out = tmp_path / "own.nc"
    calls: list = []
    path = own_grid(make_study)
    _run_own(path, out, own_records, calls)
    write_at2(own_records / "rec2.AT2", 0.25)  # the file changes (and its manifest entry with it)
    index_folder(own_records)
    calls.clear()
    ds = _run_own(path, out, own_records, calls).load()
    assert len(calls) == 2 * 2 * 2  # rec2's cells only
    assert (st.last_run().from_archive, st.last_run().computed) == (16, 8)
    # the new samples are in: 0.25 g x 9.80665 under rec2
    assert float(ds.pga.sel(record="rec2")) == pytest.approx(
        0.25 * 9.80665 * np.max(np.abs(np.sin(2 * np.pi * 2.0 * np.arange(120) * 0.01)
                                       * np.exp(-np.arange(120) * 0.01))), rel=1e-6)


def test_an_archive_of_another_study_is_refused_then_replaced_with_force(make_study,
                                                                         own_records, tmp_path):
    """Issue 34, rule 1: an archive belongs to a study definition, not a name. The same
    study renamed reuses every cell; a study of the same name with other walls (walls s08,
    s18 there, s14 here: a copy of the file, edited) is refused, the archive untouched, and
    replaces it only with force."""
    out = tmp_path / "own.nc"
    calls: list = []
    _run_own(own_grid(make_study), out, own_records, calls)
    renamed = _run_own(own_grid(make_study, name="renamed"), out, own_records, calls)
    assert renamed.attrs["study_name"] == "renamed" and len(calls) == 24  # none again
    assert st.last_run().from_archive == 24
    before = out.read_bytes()
    other = own_grid(make_study, walls=("s14",))
    calls.clear()
    with pytest.raises(OutputError, match=r"holds study 'renamed' of another definition "
                       r"\(wall s08, s18 there, s14 here\), not study 'own': its cells would "
                       r"be lost.*--force"):
        _run_own(other, out, own_records, calls)
    assert calls == [] and out.read_bytes() == before
    assert not (tmp_path / "own.nc.parts").exists()
    ds = _run_own(other, out, own_records, calls, force=True)
    assert list(ds.wall.values) == ["s14"] and len(calls) == 12  # nothing reused
    # a file that is no urmx archive is not overwritten either
    stranger = tmp_path / "data.nc"
    xr.Dataset({"x": ("t", [1.0, 2.0])}).to_netcdf(stranger)
    with pytest.raises(OutputError, match="holds no urmx study archive, not study 'own'"):
        _run_own(own_grid(make_study), stranger, own_records, calls)


def test_an_own_study_shrunk_keeps_working_and_says_what_it_leaves_out(
        make_study, own_records, tmp_path):
    """Rule 1: one's own study shrunk by a wall and extended by a record (each dimension's
    values hold the others or are held by them) is the same study: its cells are taken
    over and the run says which cells it leaves out."""
    out = tmp_path / "own.nc"
    calls: list = []
    _run_own(own_grid(make_study), out, own_records, calls)
    calls.clear()
    ds, said = quiet_run(own_grid(make_study, walls=("s18",),
                                  records=("rec1", "rec2", "rec3", "rec4")),
                         out=out, records_dir=own_records, kernel=counting(calls),
                         scheduler="serial")
    assert (st.last_run().from_archive, st.last_run().computed) == (12, 4)
    assert list(ds.wall.values) == ["s18"] and len(calls) == 4
    assert f"urmx: study 'own' leaves out wall s08 of the archive {out}: their cells are " \
           "not kept" in said


def test_parts_of_another_study_are_kept_unless_forced(make_study, own_records, tmp_path):
    out = tmp_path / "own.nc"
    parts = tmp_path / "own.nc.parts"
    calls: list = []
    with pytest.raises(Interrupt):
        st.run_study(own_grid(make_study), out=out, records_dir=own_records, batch_size=2,
                     kernel=counting(calls, 9), scheduler="serial", progress=False)
    kept = sorted(p.name for p in parts.glob("*.npz"))
    assert len(kept) == 4
    other = own_grid(make_study, walls=("s14",))  # same name, another definition
    with pytest.raises(RunError, match=r"holds 4 finished part\(s\) of study 'own' of another "
                                       r"definition \(wall s08, s18 there, s14 here\), not of "
                                       r"study 'own'.*--force"):
        _run_own(other, out, own_records, calls)
    assert sorted(p.name for p in parts.glob("*.npz")) == kept  # nothing deleted
    err = io.StringIO()
    saved, sys.stderr = sys.stderr, err
    try:
        _run_own(other, out, own_records, calls, force=True, progress=True)
    finally:
        sys.stderr = saved
    assert "--force: removed 4 finished part(s) of study 'own' of another definition (wall " \
           f"s08, s18 there, s14 here) from {parts}" in err.getvalue()


def test_the_command_line_refuses_another_study_and_replaces_it_with_force(
        make_study, own_records, tmp_path, capsys):
    from urmx.cli import main

    out = tmp_path / "cli.nc"
    first, other = own_grid(make_study), own_grid(make_study, walls=("s14",), name="another")
    common = ["--records", str(own_records), "--scheduler", "serial", "--quiet"]
    assert main(["run", str(first), "--out", str(out), *common]) == 0
    capsys.readouterr()
    assert main(["run", str(other), "--out", str(out), *common]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "'own'" in err[0] and "'another'" in err[0]
    assert main(["run", str(other), "--out", str(out), *common, "--force"]) == 0
    assert urmx.open_study(out).attrs["study_name"] == "another"


# ---- the size of a study, before any work -----------------------------------------------------

HUGE = """\
[study]
name = "huge"
walls = "parametric"
diaphragms = ["D1", "D2", "D3", "D4", "D5"]
records = ["quake", "shake"]
cor = {start = 0.5, stop = 0.9999, step = 0.0001}
scale = {start = 0.01, stop = 5.0, step = 0.01}
"""


def test_an_oversize_study_is_refused_before_any_work(grid, make_study, tmp_path, capsys):
    from urmx.cli import main

    path = make_study(HUGE, "huge.toml")
    size = st.size_of(load_study(path), kinds.get("grid"))
    assert size.cells == 9 * 5 * 2 * 5000 * 500 == 225_000_000
    assert size.bytes == size.cells * (14 * 8 + 3 * 4 + 1 + 8)
    calls: list = []
    out = tmp_path / "huge.nc"
    with pytest.raises(SizeError, match=r"'huge' is too large to start: 225,000,000 cells "
                                        r"\(limit 20,000,000, --max-cells\) and an archive of "
                                        r"about 29\.9 GB \(limit 20 GB, --max-gb\)"):
        st.run_study(path, out=out, kernel=counting(calls), scheduler="serial")
    assert calls == [] and not out.exists() and not (tmp_path / "huge.nc.parts").exists()
    assert main(["run", str(path), "--out", str(out)]) == 2
    assert "225,000,000 cells" in capsys.readouterr().err
    # the limits are the run's: a small grid passes under the defaults, not under a lower
    # limit, and --max-cells lets it through again
    with pytest.raises(SizeError, match=r"240 cells \(limit 100, --max-cells\).*runs 180 "
                                        "analyses"):
        st.run_study(grid, kernel=counting(calls), scheduler="serial", max_cells=100)
    with pytest.raises(SizeError, match="an archive of about 0.0 GB"):
        st.run_study(grid, kernel=counting(calls), scheduler="serial", max_gb=1e-6)
    assert calls == []
    st.run_study(grid, kernel=counting(calls), scheduler="serial", progress=False,
                 max_cells=1000)
    assert len(calls) == GRID_RUNS
    assert main(["run", str(grid), "--out", str(tmp_path / "g.nc"), "--max-cells", "100",
                 "--scheduler", "serial", "--quiet"]) == 2
    assert "240 cells (limit 100" in capsys.readouterr().err


# ---- the pieces: keys and the cut ---------------------------------------------------------------

def test_cell_keys_follow_what_decides_a_result(grid, make_study, monkeypatch):
    import urmx.jitcache

    study = load_study(grid)
    records = st.resolve_records(study)
    cells = Cells(study, kinds.get("grid"), records)
    every = [list(range(n)) for n in cells.shape]
    keys = cells.keys(every)
    assert keys.shape == cells.shape and len(np.unique(keys)) == keys.size
    # a cor value inserted: the other cells keep their keys
    wider = load_study(make_study(GRID.replace("step = 0.01}", "step = 0.005}"), "w.toml"))
    more = Cells(wider, kinds.get("grid"), records).keys(
        [list(range(n)) for n in (2, 2, 2, 19, 3)])
    np.testing.assert_array_equal(more[:, :, :, ::2], keys)
    # another kernel, kernel source, urmx version or record samples: other keys
    assert not np.isin(Cells(study, kinds.get("grid"), records, fake_kernel).keys(every),
                       keys).any()
    monkeypatch.setattr(urmx.jitcache, "SOURCE_HASH", "0" * 16)
    assert not np.isin(Cells(study, kinds.get("grid"), records).keys(every), keys).any()
    monkeypatch.undo()
    # versions come from git tags: the commits after a release keep its cells (the kernel's
    # source hash above guards the results), the next release computes them again
    for version, same in (("0.2.0.post3+g1234567", True), ("0.2.0.post9+gabcdef0.dirty", True),
                          ("0.2.0+unknown", True), ("0.3.0", False)):
        monkeypatch.setattr(urmx.provenance, "VERSION", version)
        base = Cells(study, kinds.get("grid"), records).keys(every)
        monkeypatch.setattr(urmx.provenance, "VERSION", "0.2.0")
        assert np.array_equal(base, Cells(study, kinds.get("grid"), records).keys(every)) \
            == same, version
    monkeypatch.undo()
    changed = dict(records)
    rec = records["shake"]
    changed["shake"] = type(rec)("shake", rec.acceleration * 1.001, rec.dt, rec.scale_factor)
    other = Cells(study, kinds.get("grid"), changed).keys(every)
    np.testing.assert_array_equal(other[:, :, 0], keys[:, :, 0])  # quake: the same
    assert not np.isin(other[:, :, 1], keys).any()  # shake: all new


@pytest.mark.parametrize("seed", range(6))
def test_the_cut_covers_exactly_the_cells_to_run_in_bounded_blocks(grid, seed):
    rng = np.random.default_rng(seed)
    study = load_study(grid)
    cells = Cells(study, kinds.get("grid"), st.resolve_records(study))
    runs = cells.runs([list(range(n)) for n in cells.shape]).ravel()
    done = rng.random(cells.size) < [0.0, 0.3, 0.9, 0.5, 0.1, 1.0][seed]
    size = int(rng.integers(1, 50))
    seen = np.zeros(cells.size, dtype=int)
    for batch in Cut(cells, size, done):
        assert 1 <= batch.size <= size and len(batch.block["record"]) == 1
        seen[cells.flat(list(batch.block.values())).ravel()] += 1
    np.testing.assert_array_equal(seen, (runs & ~done).astype(int))


def test_the_cut_runs_the_records_of_one_time_step_together():
    """A wall's kernel tables are per time step: the batches take the records of one step
    together (in the study's order within a step), so a worker builds them once a step;
    every cell is still cut once."""
    class Stand:  # what Cut reads of urmx.study.cells.Cells
        names, shape, record_axis = ["wall", "record", "cor"], (2, 4, 3), 1
        record_dt = [0.02, 0.005, 0.01, 0.005]

        def runnable(self):
            return np.ones((2, 4), dtype=bool)

    order = [b.record for b in Cut(Stand(), 3)]
    assert [r for i, r in enumerate(order) if i == 0 or order[i - 1] != r] == [1, 3, 2, 0]
    assert len(order) == 8 and all(order.count(r) == 2 for r in range(4))


@pytest.mark.parametrize("seed", range(5))
def test_a_chained_cut_keeps_every_chain_together(seed):
    """The IDA kinds' cells form chains along ``wall`` (warm starts): whatever the batch
    size and the finished cells, every cell to run is cut once, each block holds whole runs
    of cells to run along the chain (a block's first wall is the chain's first paired wall
    or follows a finished one), and the walls a record is not paired with are skipped."""
    rng = np.random.default_rng(seed)

    class Stand:  # what Cut reads of urmx.study.cells.Cells
        names, shape, record_axis, chain = ["wall", "diaphragm", "record", "cor"], \
            (7, 3, 2, 2), 2, 0
        record_dt = [0.01, 0.01]
        pairs = rng.random((7, 2)) < 0.8

        def runnable(self):
            return self.pairs

        def flat(self, block):
            return np.ravel_multi_index(np.ix_(*block), self.shape)

    cells = Stand()
    done = rng.random(int(np.prod(cells.shape))) < [0.0, 0.2, 0.5, 0.8, 0.3][seed]
    seen = np.zeros(done.size, dtype=int)
    for batch in Cut(cells, int(rng.integers(1, 40)), done):
        b = batch.block
        seen[cells.flat(list(b.values())).ravel()] += 1
        paired = list(np.flatnonzero(cells.pairs[:, batch.record]))
        at = paired.index(b["wall"][0])
        assert b["wall"] == paired[at:at + len(b["wall"])]  # consecutive paired walls
        if at:  # the wall before the block is finished, in every chain of the block
            before = [[paired[at - 1]], *list(b.values())[1:]]
            assert done[cells.flat(before).ravel()].all()
        after = paired[at + len(b["wall"]):at + len(b["wall"]) + 1]
        if after:  # the block ends its runs: the next paired wall is finished
            assert done[cells.flat([after, *list(b.values())[1:]]).ravel()].all()
    runs = np.broadcast_to(cells.pairs[:, None, :, None], cells.shape).ravel()
    np.testing.assert_array_equal(seen, (runs & ~done).astype(int))


def test_chained_keys_fold_the_walls_before(make_study):
    """An IDA cell's key holds the keys of the walls before it on its chain: a changed
    wall changes its own key and those after it, not those before."""
    from .helpers.ida_study import ACC as IDA_ACC
    from .helpers.ida_study import IDA_STUDY

    recs = {k: urmx.records.Record(k, v, 0.01) for k, v in IDA_ACC.items()}
    three = IDA_STUDY.replace('walls = ["s08", "s18"]', 'walls = ["s08", "s12", "s18"]')
    keys = [Cells(load_study(make_study(text, f"{i}.toml")), kinds.get("ida"), recs).keys(
        [[0, 1, 2], [0, 1], [0, 1], [0, 1]])
        for i, text in enumerate((three, three.replace('"s12"', '"s14"')))]
    np.testing.assert_array_equal(keys[0][0], keys[1][0])
    for iw in (1, 2):
        assert not np.isin(keys[1][iw], keys[0]).any()
    assert len(np.unique(keys[0])) == keys[0].size


# ---- reuse for the other kinds of cells: IDA capacities and kept time histories -------------

IDA = """\
[study]
name = "ida-reuse"
walls = ["s08", "s18"]
diaphragms = ["D1", "D5"]
supports = "top"
records = {records}
cor = [0.7, 0.8]

[study.ida]
im = "pga"
rtol = 1e-3
step = 1.5
max_intensity = 2.0
"""


def test_an_extended_ida_study_computes_only_its_new_capacities(make_study, use_records,
                                                                tmp_path):
    from .helpers.gaps_study import ACC as ACC3
    from .helpers.gaps_study import SCALE as SCALE3
    from .helpers.gaps_study import ida_kernel

    use_records(ACC3, SCALE3, DT)
    calls: list = []

    def kernel(*args, **kw):
        calls.append(1)
        return ida_kernel(*args, **kw)

    def run(records, out=None):
        path = make_study(IDA.format(records=records), f"ida-{len(records)}.toml")
        return st.run_study(path, out=out, kernel=kernel, scheduler="serial",
                            progress=False, batch_size=3)

    out = tmp_path / "ida.nc"
    first = run(["quake"], out).load()
    calls.clear()
    ds = run(["quake", "shake"], out).load()
    assert (st.last_run().from_archive, st.last_run().computed) == (8, 8)
    old = ds.sel(record=["quake"]).isel(intensity_step=slice(0, first.sizes["intensity_step"]))
    for name in ("collapse_intensity", "censored", "analyses", "instability_ratio",
                 "intensity", "record_intensity", "predominant_frequency"):
        assert np.asarray(first[name].values).tobytes() == \
            np.asarray(old[name].values).tobytes(), name
    analyses = len(calls)
    calls.clear()
    fresh = run(["quake", "shake"])
    assert len(calls) == analyses + float(first.analyses.sum())  # the reused analyses
    same_run(ds, fresh)


HISTORY = """
[[study.history]]
wall = "s18"
diaphragm = "D1"
record = "rec1"
cor = 0.8
"""


def test_kept_histories_are_computed_again_rather_than_taken_from_an_archive(
        make_study, own_records, tmp_path):
    out = tmp_path / "own.nc"
    calls: list = []
    first = own_grid(make_study)
    first.write_text(first.read_text() + HISTORY)
    _run_own(first, out, own_records, calls)
    extended = own_grid(make_study, records=("rec1", "rec2", "rec3", "rec4"))
    extended.write_text(extended.read_text() + HISTORY)
    calls.clear()
    ds = _run_own(extended, out, own_records, calls).load()
    assert len(calls) == 8 + 1  # rec4's cells and the one cell whose history is kept
    assert (st.last_run().from_archive, st.last_run().computed) == (23, 9)
    calls.clear()
    same_run(ds, st.run_study(extended, records_dir=own_records, kernel=counting(calls),
                           scheduler="serial", progress=False))
    assert ds.theta_lower.sizes["history"] == 1
