"""Nothing lost, nothing silent (issue 34): the cases an outside red team still found, each
shown with its clear error, its kept work or its right result.

Rule 1 (an archive belongs to a study definition, not a name) is also in test_cells.py
(`test_an_archive_of_another_study_is_refused_then_replaced_with_force`,
`test_an_own_study_shrunk_keeps_working_and_says_what_it_leaves_out`,
`test_parts_of_another_study_are_kept_unless_forced`); rule 2 (bounded shutdown) is at the
end, as slow tests of `urmx run` in a child process.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import urmx
from urmx import study as st
from urmx.catalog import CatalogError
from urmx.cli import main
from urmx.errors import InputError, OutputError, UrmxError
from urmx.study.file import load_study

from .helpers.own_records import Interrupt, counting, own_grid, quiet_run

ROOT = Path(__file__).resolve().parent.parent

# ---- rule 1: a study's name must name it -------------------------------------------------


@pytest.mark.parametrize("name", ['""', '"   "', "42"])
def test_a_blank_or_missing_study_name_is_refused(make_study, name, capsys):
    path = make_study(f'[study]\nname = {name}\nwalls = ["s18"]\ndiaphragms = ["D1"]\n'
                      'records = ["elcentro"]\ncor = [0.8]\n')
    with pytest.raises(CatalogError, match=r"study\.name: .* is not a name"):
        load_study(path)
    assert main(["run", str(path), "--out", str(path.with_suffix(".nc"))]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "is not a name" in err[0]


def test_a_range_whose_start_is_above_its_stop_says_so(make_study):
    path = make_study('[study]\nname = "r"\nwalls = ["s18"]\ndiaphragms = ["D1"]\n'
                      'records = ["elcentro"]\ncor = {start = 0.9, stop = 0.7, step = 0.05}\n')
    with pytest.raises(CatalogError, match=r"study\.cor: range start=0\.9 is above "
                                           r"stop=0\.7.*swap them"):
        load_study(path)


def test_an_unknown_benchmark_is_one_line(capsys):
    assert main(["bench", "bogus", "--quick"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("urmx bench: error: unknown benchmark "
                                               "'bogus' (known: all, render, ")


# ---- rule 5: labels never depend on the other cells ----------------------------------------


def test_a_diaphragms_frequency_is_its_own_whatever_the_walls(make_study):
    """D1's ``frequency`` is the same with walls s08, s10 as with s20, s24 (on main at
    834f656: the study's median wall's, 1.03 and 0.90 Hz), that of the building's median
    parametric wall s16: sqrt(815e3 / (m_d + m_s16 / 2)) / 2 pi, in Table IV's 0.8-1.1 Hz."""
    from urmx.study.dataset import _diaphragm_coords

    text = ('[study]\nname = "f"\nwalls = {walls}\ndiaphragms = ["D1", "D5"]\n'
            'records = ["elcentro"]\ncor = [0.8]\n')
    low = load_study(make_study(text.format(walls='["s08", "s10"]'), "low.toml"))
    high = load_study(make_study(text.format(walls='["s20", "s24"]'), "high.toml"))
    f_low = _diaphragm_coords(low)["frequency"].values
    f_high = _diaphragm_coords(high)["frequency"].values
    assert f_low.tobytes() == f_high.tobytes()
    b = low.catalog.building
    m = b.wall_mass(0.23, 16 * 0.23)
    expected = math.sqrt(815e3 / (b.diaphragm_mass + 0.5 * m)) / (2 * math.pi)
    assert f_low[0] == pytest.approx(expected, rel=1e-12)
    assert 0.8 < f_low[0] < 1.1 and 30.0 < f_low[1] < 40.0  # Table IV: D1, D5
    # the walls' own frequencies are the 2-D coordinate cell_frequency, and differ
    cells = _diaphragm_coords(low)["cell_frequency"]
    assert cells.dims == ("wall", "diaphragm") and cells.values[0, 0] > cells.values[1, 0]


def test_the_resonance_view_reads_the_diaphragms_own_frequency(single):
    """What the reports read from ``frequency`` (`urmx.analysis.resonance`, whose result
    the paper report's resonance table and `urmx.paper.findings` use) is the coordinate
    itself, so the same whatever walls are selected."""
    from urmx.analysis import grid as A

    ranges = {"elcentro": (0.2, 7.0), "nahanni": (7.0, 9.0), "christchurch": (0.2, 3.0)}
    some = single.isel(wall=slice(0, 2))
    full = A.resonance(single, cor=0.8, ranges=ranges)["frequency"]
    part = A.resonance(some, cor=0.8, ranges=ranges)["frequency"]
    np.testing.assert_array_equal(full.values, part.values)
    np.testing.assert_array_equal(full.values, np.asarray(single["frequency"].values, float))


# ---- parts of another kernel: dropped with a word ------------------------------------------


def test_parts_of_another_kernel_are_computed_again_with_a_word(make_study, tmp_path,
                                                                 own_records):
    out = tmp_path / "own.nc"
    calls: list = []
    with pytest.raises(Interrupt):
        st.run_study(own_grid(make_study), out=out, records_dir=own_records, batch_size=2,
                     kernel=counting(calls, 6), scheduler="serial", progress=False)
    parts = tmp_path / "own.nc.parts"
    assert len(list(parts.glob("*.npz"))) == 3
    other = counting([])
    other.__qualname__ = "another"  # another kernel: other cell keys
    calls.clear()
    ds, said = quiet_run(own_grid(make_study), out=out, records_dir=own_records,
                         kernel=other, scheduler="serial")
    assert st.last_run().from_parts == 0 and st.last_run().computed == 24
    assert (f"urmx: 3 finished part(s) in {parts} hold no cell of this run: they were "
            "computed by another kernel (kernel tests.helpers.own_records.counting there, "
            "tests.helpers.own_records.another now), so their cells are computed again") in said
    assert int(ds.sizes["wall"]) == 2


# ---- debris: a killed archive write's temporary file --------------------------------------

KILL_IN_WRITE = """\
import os, signal, sys
import urmx.netcdf as N
real = N.write_netcdf
def killed(ds, path):
    from pathlib import Path
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_bytes(b"half an archive")
    os.kill(os.getpid(), signal.SIGKILL)
N.write_netcdf = killed
import urmx.study.engine as E
E.write_netcdf = killed
from urmx.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_a_run_killed_while_writing_its_archive_leaves_a_temporary_file_that_the_next_run_removes(  # noqa: E501
        make_study, own_records, tmp_path):
    out = tmp_path / "own.nc"
    study = own_grid(make_study)
    argv = ["run", str(study), "--out", str(out), "--records", str(own_records),
            "--scheduler", "serial", "--quiet"]
    proc = subprocess.run([sys.executable, "-c", KILL_IN_WRITE, *argv], cwd=ROOT,
                          capture_output=True, timeout=600)
    assert proc.returncode == -signal.SIGKILL
    left = list(tmp_path.glob(".own.nc.*.tmp"))
    assert len(left) == 1 and not out.exists()
    pid = int(left[0].name.split(".")[-2])
    ds, said = quiet_run(study, out=out, records_dir=own_records, scheduler="serial")
    assert not list(tmp_path.glob(".own.nc.*.tmp")) and out.is_file()
    assert (f"urmx: removed {left[0]}, a temporary file left by a run that was killed while "
            f"writing it (pid {pid}, no longer running)") in said
    assert st.last_run().from_parts == 24  # its parts were kept: nothing computed again


def test_a_temporary_file_of_a_running_process_is_left_alone(tmp_path):
    from urmx.netcdf import remove_stale

    mine = tmp_path / f".x.nc.{os.getpid()}.tmp"
    mine.write_text("being written")
    assert remove_stale(tmp_path, ".x.nc.", ".tmp") == [] and mine.exists()


# ---- a file-size limit -----------------------------------------------------------------------


@pytest.fixture
def size_limit():
    """This process's file-size limit (``ulimit -f``) set to 200 kB for the test."""
    resource = pytest.importorskip("resource")
    before = resource.getrlimit(resource.RLIMIT_FSIZE)
    resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, before[1]))
    try:
        yield 200_000
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, before)


def test_a_file_size_limit_is_named_as_such(tmp_path, size_limit):
    """Python ignores SIGXFSZ, so a write past ``ulimit -f`` fails with EFBIG (a part) or
    netCDF's ``HDF error`` (an archive): both say it is the file-size limit."""
    from urmx.netcdf import write_netcdf
    from urmx.study.parts import PartStore

    rng = np.random.default_rng(1)
    ds = xr.Dataset({"x": ("n", rng.random(200_000))})
    with pytest.raises(OutputError, match=r"file-size limit of 0\.2 MB \(ulimit -f\)") as err:
        write_netcdf(ds, tmp_path / "big.nc")
    assert "MB free on its disk" not in str(err.value)
    assert not list(tmp_path.glob(".big.nc.*"))
    store = PartStore(tmp_path, ("x",))
    with pytest.raises(OutputError, match=r"File too large \(this process's file-size "
                                          r"limit, ulimit -f"):
        store.save("k", {"x": rng.random(100_000)}, np.arange(100_000, dtype=np.uint64))


def test_a_write_that_fails_for_another_reason_does_not_blame_the_size_limit(tmp_path):
    from urmx.netcdf import size_limit_hit

    small = tmp_path / "small"
    small.write_bytes(b"x" * 10)
    assert size_limit_hit(small, OSError(5, "I/O error")) == ""


# ---- rule 6: the Python API names the argument and what it got -----------------------------


def _wall():
    return urmx.Wall(thickness=0.23, height=4.14, crack_ratio=2 / 3, mass=3000.0)


def _flipped(tmp_path: Path) -> Path:
    """A pinned archive with bytes flipped in the middle (its compressed data)."""
    data = bytearray((ROOT / "tests/fixtures/pinned/paper-multi-storey.nc").read_bytes())
    for off in range(len(data) // 2, len(data) // 2 + 4000, 97):
        data[off] ^= 0xFF
    path = tmp_path / "flipped.nc"
    path.write_bytes(data)
    return path


TRACE = (np.zeros(100), 0.01)
# (id, the call, text the message must hold: the argument's name and what it got)
WRONG = [
    ("simulate-cor-str", lambda t: urmx.simulate(_wall(), TRACE[0], dt=0.01, cor="0.8"),
     "cor='0.8' must be a number, not str"),
    ("simulate-scale-list", lambda t: urmx.simulate(_wall(), TRACE[0], dt=0.01, scale=[2]),
     "scale=[2] must be a number, not list"),
    ("simulate-tail-str", lambda t: urmx.simulate(_wall(), TRACE[0], dt=0.01, tail="1"),
     "tail='1' must be a number, not str"),
    ("simulate-wall", lambda t: urmx.simulate("wall", TRACE[0], dt=0.01),
     "wall must be a urmx.Wall, not str"),
    ("wall-thickness-str", lambda t: urmx.Wall(thickness="0.23", height=4.14,
                                               crack_ratio=0.5, mass=3000.0),
     "Wall thickness='0.23' is not valid (a number)"),
    ("records-load-int", lambda t: urmx.records.load(42),
     "load: record_id must be a manifest record id (str), got 42 (int)"),
    ("records-read-int", lambda t: urmx.records.read(42),
     "read: path must be a file name (str or path), got 42 (int)"),
    ("fit-censored-str", lambda t: urmx.fragility.fit_lognormal(
        [1, 2, 3, 4], censored=["False", "False", "True", "False"]),
     "fit_lognormal: censored must be numbers (array_like of float), got ['False', "),
    ("fit-capacities-dict", lambda t: urmx.fragility.fit_lognormal({"a": 1}),
     "fit_lognormal: capacities must be numbers (array_like of float), got {'a': 1} (dict)"),
    ("bootstrap-capacities-str", lambda t: urmx.fragility.bootstrap_lognormal("1 2 3"),
     "bootstrap_lognormal: capacities must be numbers (array_like of float), got '1 2 3'"),
    ("stripe-levels-str", lambda t: urmx.fragility.stripe_counts([1.0, 2.0], None, ["a"]),
     "stripe_counts: levels must be numbers (array_like of float), got ['a'] (list)"),
    ("run-study-int", lambda t: urmx.run_study(42),
     "run_study: study must be a Study, a study file or a catalog study name, got 42 (int)"),
    ("open-study-int", lambda t: urmx.open_study(42),
     "open_study: path=42 must be a file name (str or path), not int"),
    ("open-study-flipped", lambda t: urmx.open_study(_flipped(t)).load(),
     "flipped.nc': variable 'peak_lower_drift_family1' cannot be read (NetCDF: HDF error): "
     "the file is damaged; run its study again"),
    ("load-study-int", lambda t: urmx.study.load_study(42),
     "load_study: path must be a file name (str or path), got 42 (int)"),
    ("read-wall-none", lambda t: urmx.catalog.read_wall(None),
     "read_wall: path must be a file name (str or path), got None (NoneType)"),
]


@pytest.mark.parametrize(("call", "needle"), [c[1:] for c in WRONG], ids=[c[0] for c in WRONG])
def test_the_python_api_names_the_argument_and_what_it_got(tmp_path, call, needle):
    with pytest.raises(UrmxError) as err:
        call(tmp_path)
    assert needle in str(err.value) and "\n" not in str(err.value)


def test_a_wrong_type_reaches_every_public_function_of_urmx_all():
    """Each function of ``urmx.__all__`` given a wrong type for its first argument says
    so as an `urmx.UrmxError` (never a TypeError from inside)."""
    class Wrong:
        def __repr__(self):
            return "<Wrong>"

    calls = {"Wall": lambda w: urmx.Wall(thickness=w, height=4.14, crack_ratio=0.5,
                                         mass=3000.0),
             "simulate": lambda w: urmx.simulate(w, np.zeros(10), dt=0.01),
             "run_study": lambda w: urmx.run_study(w),
             "open_study": lambda w: urmx.open_study(w)}
    public = [n for n in urmx.__all__ if callable(getattr(urmx, n))
              and not (isinstance(getattr(urmx, n), type)
                       and issubclass(getattr(urmx, n), (Warning, Exception)))]
    assert sorted(public) == sorted(calls)
    for call in calls.values():
        with pytest.raises(UrmxError, match="<Wrong>|Wrong"):
            call(Wrong())


#: public functions not given a wrong type by the test below, and why
EXEMPT = {
    "urmx.fragility.cell_capacity": "numpy-only step of collapse_capacity on checked inputs",
    "urmx.fragility.search": "model-free step of collapse_capacity on checked inputs",
    "urmx.fragility.trilinear": "a segment case of urmx.Wall.segment, inside the mechanism",
    **{f"urmx.study.{n}": "a part of the study engine re-exported for kinds and benchmarks"
       for n in ("batch_tasks", "check_size", "close_client", "compute", "format_diff",
                 "format_info", "global_attrs", "grid_coords", "resolve_records",
                 "run_batch", "size_of", "status_names")},
}


def _public_functions():
    import importlib
    import inspect

    for module in ("urmx", "urmx.records", "urmx.fragility", "urmx.catalog", "urmx.study"):
        mod = importlib.import_module(module)
        for name in mod.__all__:
            f = getattr(mod, name, None)
            if inspect.isfunction(f) and f"{module}.{name}" not in EXEMPT:
                required = [p for p in inspect.signature(f).parameters.values()
                            if p.default is p.empty and p.kind in (p.POSITIONAL_ONLY,
                                                                   p.POSITIONAL_OR_KEYWORD)]
                if required:
                    yield f"{module}.{name}", f, len(required)


@pytest.mark.parametrize("name, function, n", list(_public_functions()),
                         ids=[c[0] for c in _public_functions()])
def test_every_public_function_given_a_wrong_type_names_what_it_got(name, function, n):
    """Each public function (``__all__`` of urmx, urmx.records, urmx.fragility,
    urmx.catalog, urmx.study, but `EXEMPT`) with a wrong type for every required argument:
    an `urmx.UrmxError` of one line that says what it got, never a TypeError or an
    AttributeError from inside."""
    class Wrong:
        def __repr__(self):
            return "<Wrong>"

    with pytest.raises(UrmxError) as err:
        function(*[Wrong()] * n)
    assert "Wrong" in str(err.value) and "\n" not in str(err.value), name


def test_a_bad_value_still_says_what_it_is():
    """The argument checks let right values through: strings of numbers are refused, but
    a list of bools is censoring."""
    fit = urmx.fragility.fit_lognormal([1.0, 2.0, 3.0, 4.0], censored=[False, False, True,
                                                                       False])
    assert fit.n_censored == 1 and fit.n == 4
    with pytest.raises(InputError, match="cor=1.5"):
        urmx.simulate(_wall(), np.zeros(100), dt=0.01, cor=1.5)


# ---- rule 2: bounded shutdown (slow: a real local cluster) ---------------------------------

FINE = """\
[study]
name = "fine"
walls = ["s16"]
diaphragms = ["D1"]
records = ["short"]
cor = {start = 0.5, stop = 0.9995, step = 0.0005}
scale = {start = 0.01, stop = 10.0, step = 0.01}

[records.short]
file = "short.txt"
dt = 0.02
unit = "g"
"""


def _fine_run(tmp_path: Path) -> tuple[subprocess.Popen, Path, Path]:
    """`urmx run` of a fine one-wall grid (1,000 COR x 1,000 scales on a 150-sample
    record: 62,500 batches) on its local cluster, in its own session, once it holds 20
    finished batches."""
    from .fixtures.signals import interruptible

    t = np.arange(150) * 0.02
    (tmp_path / "short.txt").write_text("\n".join(
        f"{v:.6e}" for v in 0.3 * np.sin(2 * np.pi * 2 * t) * np.exp(-t)) + "\n")
    (tmp_path / "fine.toml").write_text(FINE)
    out, parts = tmp_path / "fine.nc", tmp_path / "fine.nc.parts"
    env = dict(os.environ, DASK_URMX__SERIAL_BELOW="0")
    proc = subprocess.Popen([sys.executable, "-m", "urmx.cli", "run", "fine.toml", "--out",
                             str(out), "--scheduler", "processes"], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                            start_new_session=True, preexec_fn=interruptible)
    deadline = time.monotonic() + 600
    while time.monotonic() < deadline and proc.poll() is None:
        if parts.is_dir() and len(list(parts.glob("*.npz"))) >= 20:
            break
        time.sleep(0.05)
    if proc.poll() is not None:
        _, err = proc.communicate()
        raise AssertionError(f"the run ended first (exit {proc.returncode}): "
                             f"{err.decode()[-2000:]}")
    return proc, out, parts


def _said(err: bytes) -> list[str]:
    return [ln for ln in err.decode().splitlines() if "analyses/s" not in ln]


@pytest.mark.slow
@pytest.mark.parametrize("sig, code, word", [(signal.SIGINT, 130, "interrupted"),
                                             (signal.SIGTERM, 143, "terminated")])
def test_a_stopped_fine_grid_stops_its_cluster_and_says_what_is_on_disk(tmp_path, sig, code,
                                                                         word):
    """Ctrl-C (to the process group, as a terminal sends it) or SIGTERM: one line, the
    count of batches it says is the count on disk, no dask message, exit 130 / 143, and
    no worker process left behind."""
    proc, out, parts = _fine_run(tmp_path)
    workers = _children(proc.pid)
    if sig == signal.SIGINT:
        os.killpg(proc.pid, sig)
    else:
        proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)  # a hang guard, not a timing
    lines = _said(err)
    assert proc.returncode == code, err.decode()[-3000:]
    assert len(lines) == 1, err.decode()[-3000:]
    n = len(list(parts.glob("*.npz")))
    assert lines[0] == (f"urmx run: {word}; {n} finished batches kept in {parts}/: run the "
                        "same command again to resume")
    assert not out.exists() and n >= 20
    assert not [p for p in workers if _alive(p)]


@pytest.mark.slow
def test_a_second_and_third_ctrl_c_end_it_at_once_without_a_traceback(tmp_path):
    proc, out, parts = _fine_run(tmp_path)
    workers = _children(proc.pid)
    for _ in range(3):
        os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    text = err.decode()
    assert proc.returncode == 130, text[-3000:]
    assert "Traceback" not in text and "Exception ignored" not in text, text[-3000:]
    lines = _said(err)
    assert len(lines) == 1 and lines[0].startswith("urmx run: "), text[-3000:]
    n = len(list(parts.glob("*.npz")))
    kept = (f"{n} finished batches kept in {parts}/: run the same command again to "
            "resume")
    assert lines[0] in (f"urmx run: Ctrl-C again: stopped at once; {kept}",
                        f"urmx run: interrupted; {kept}")  # the signals may arrive as one
    assert not [p for p in workers if _alive(p)]
    # what is kept resumes: the parts are whole
    from urmx.study.parts import load_part

    assert all(load_part(p, p.stem, ("status",)) is not None for p in parts.glob("*.npz"))


def test_a_stop_dropped_in_a_gc_callback_still_stops_the_run(monkeypatch):
    """The first Ctrl-C raises where the signal lands; in a GC callback (dask's GC
    diagnosis) Python drops it with an "Exception ignored" message, and a run once went on
    after a triple Ctrl-C (the three signals read as one). The ``urmx`` command's hook
    drops such a stop without a word, and the loop that takes a study's batches raises it
    again before the next batch; SIGTERM's stop stays a SIGTERM."""
    import gc

    from urmx import cli, errors
    from urmx.study import engine

    said = []
    hook = cli._quiet_stops(lambda u: said.append(u.exc_type))

    def callback(phase, info):
        raise KeyboardInterrupt

    monkeypatch.setattr(sys, "unraisablehook", hook)
    gc.callbacks.append(callback)
    try:
        gc.collect()
    finally:
        gc.callbacks.remove(callback)
    assert said == []  # dropped without a word
    hook(type("U", (), {"exc_value": ValueError("x"), "exc_type": ValueError})())
    assert said == [ValueError]  # anything else still reaches Python's hook

    ran = []
    tasks = [(type("B", (), {"record": 0})(), {}) for _ in range(3)]
    records = {"r": type("R", (), {"acceleration": None})()}

    def run(task, acc):
        ran.append(1)
        return {}

    monkeypatch.setattr(errors, "STOPS", [])
    engine._here(tasks, records, ["r"], lambda b, r: None, run)
    assert len(ran) == 3  # no stop asked: every batch runs
    for sig, raised in ((signal.SIGINT, KeyboardInterrupt), (signal.SIGTERM, errors.Terminated)):
        monkeypatch.setattr(errors, "STOPS", [sig])
        ran.clear()
        with pytest.raises(raised) as caught:
            engine._here(tasks, records, ["r"], lambda b, r: None, run)
        assert ran == [] and (caught.type is errors.Terminated) == (sig == signal.SIGTERM)


def _children(pid: int) -> list[int]:
    """The PIDs of the worker processes of `pid` (its children, from /proc)."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                found.append(int(entry.name))
    return found


def _alive(pid: int) -> bool:
    try:
        stat = (Path("/proc") / str(pid) / "stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"



# ---- an external cluster whose only worker runs an older urmx --------------------------


@pytest.mark.slow
def test_a_worker_with_an_older_urmx_of_the_same_version_is_named_at_once(tmp_path):
    """The only worker runs a copy of urmx as it was before this issue (its provenance
    module from the main branch: same version, same kernel sources, no source hash; on
    main at 834f656 such a worker passed the check and died unpickling a task, and the run
    said after 68 s only that no worker was left): the run stops before any work, naming
    the worker as an older urmx."""
    import shutil

    from .fixtures import cluster as C

    old = subprocess.run(["git", "show", "834f656:urmx/provenance.py"], cwd=ROOT,
                         capture_output=True, text=True)
    if old.returncode != 0:
        pytest.skip("no git history of urmx/provenance.py here")
    copy = tmp_path / "older"
    shutil.copytree(ROOT / "urmx", copy / "urmx", ignore=shutil.ignore_patterns("__pycache__"))
    (copy / "urmx" / "provenance.py").write_text(old.stdout)
    (copy / "urmx" / "study" / "definition.py").unlink()  # a module it did not have
    study = tmp_path / "cluster.toml"
    study.write_text(C.STUDY)
    external = C.Cluster(tmp_path)
    try:
        external.start_scheduler()
        worker = external.add_worker(path=[copy])
        external.wait_for_workers(1)
        address = {pid: a for a, pid in external.workers().items()}[worker.pid]
        out = tmp_path / "older.nc"
        proc = C.urmx_run(["run", str(study), "--out", str(out), "--scheduler",
                           external.address, "--batch-size", "1", "--quiet"])
        _, err = proc.communicate(timeout=120)  # a hang guard, not a timing
    finally:
        external.close()
    lines = err.strip().splitlines() if isinstance(err, str) else \
        err.decode().strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, lines
    assert lines[0].startswith(f"urmx run: error: worker {address} runs other code than this "
                               "process (urmx ")
    assert "(an older urmx: no source hash)" in lines[0] and "nothing was computed" in lines[0]
    assert not out.exists()
