"""Studies on a real cluster: one code per run (a worker with another kernel is refused
before any work, a result from other code is never kept), a cluster that dies is said (all
workers lost, the scheduler lost: one line, the finished batches kept, a rerun finishes),
closed and unusable clients, the client the user already has, small studies run in this
process, progress in a notebook, and the provenance every archive records.

The external-cluster cases start a real ``dask scheduler`` and ``dask worker`` processes on
127.0.0.1 (`tests.fixtures.cluster`) and run `urmx run` as a child process (on in-memory
records with a stand-in kernel that takes a set time per analysis), so a hang is a
timeout of the child, never of the test run.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import xarray as xr

import urmx
import urmx.jitcache
import urmx.provenance
from urmx import study as st
from urmx.errors import InputError, RunError
from urmx.study import clients, engine

from .fixtures import cluster as C
from .helpers.gaps_study import STUDY, fake_kernel, ida_kernel

ENDS_WITHIN = 60  # s: a run that loses its cluster must have ended by then (it takes ~3 s)


@pytest.fixture
def external(tmp_path):
    """A `tests.fixtures.cluster.Cluster` in the test's folder, stopped afterwards."""
    c = C.Cluster(tmp_path)
    try:
        yield c
    finally:
        c.close()


@pytest.fixture
def cluster_study(tmp_path):
    path = tmp_path / "cluster.toml"
    path.write_text(C.STUDY)
    return path


def _reference(study, use_records) -> xr.Dataset:
    """The study's Dataset from a run in this process (no cluster) on the same records and
    stand-in kernel as the child processes'."""
    use_records(C.RECORDS, dict.fromkeys(C.RECORDS, 1.0), C.DT)
    return st.run_study(study, kernel=C.sleepy_kernel, batch_size=1, scheduler="serial",
                        progress=False)


def _same(a: xr.Dataset, b: xr.Dataset) -> None:
    a, b = a.copy(), b.copy()
    for ds in (a, b):
        ds.attrs["history"] = ds.attrs["history"].split(" ", 1)[1].split(":", 1)[0]
    xr.testing.assert_identical(a, b)


def _one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


# ---- one code per run -------------------------------------------------------------------

def test_a_worker_with_another_kernel_is_refused_before_any_work(external, cluster_study,
                                                                  tmp_path):
    """A worker whose urmx is a copy with one comment changed in the kernel's sources (so
    another SOURCE_HASH): the run stops before any batch, naming the worker and both
    hashes; nothing is computed or kept."""
    copy = tmp_path / "other"
    shutil.copytree(C.ROOT / "urmx", copy / "urmx",
                    ignore=shutil.ignore_patterns("__pycache__"))
    kernel = copy / "urmx" / "kernel" / "loop.py"
    kernel.write_text(kernel.read_text() + "\n# another kernel: one comment more\n")
    other_hash = subprocess.run(
        [sys.executable, "-c", "import urmx.jitcache; print(urmx.jitcache.SOURCE_HASH)"],
        env={"PYTHONPATH": str(copy), "PATH": "/usr/bin:/bin"}, cwd=tmp_path,
        capture_output=True, text=True, check=True).stdout.strip()
    assert other_hash != urmx.jitcache.SOURCE_HASH
    external.start_scheduler()
    external.add_worker()
    other = external.add_worker(path=[copy])
    external.wait_for_workers(2)
    addresses = {pid: address for address, pid in external.workers().items()}
    out = tmp_path / "mixed.nc"
    proc = C.urmx_run(["run", str(cluster_study), "--out", str(out), "--scheduler",
                       external.address, "--batch-size", "1", "--quiet"])
    _, err = proc.communicate(timeout=ENDS_WITHIN)
    line = _one_line(err)
    assert proc.returncode == 2
    assert line.startswith(f"urmx run: error: worker {addresses[other.pid]} runs other code "
                           "than this process")
    assert f"kernel {other_hash}" in line and f"kernel {urmx.jitcache.SOURCE_HASH}" in line
    assert "nothing was computed" in line
    assert not out.exists() and not out.with_name("mixed.nc.parts").exists()


def test_a_result_from_other_code_is_never_kept(gaps_records, make_study, tmp_path,
                                                monkeypatch):
    """A worker that passed the check when the run connected but then computes with other
    code (here: its identity differs on the worker threads only): its first result stops
    the run, naming the worker; no part of it is saved."""
    from distributed import Client

    real = urmx.provenance.identity()
    other = dict(real, kernel_source="0" * 16)

    def identity():
        return real if threading.current_thread() is threading.main_thread() else other

    study = make_study(STUDY, "gaps.toml")
    out = tmp_path / "late.nc"
    with Client(processes=False, n_workers=1, threads_per_worker=1,
                dashboard_address=":0") as client:
        worker = next(iter(client.scheduler_info()["workers"]))
        monkeypatch.setattr(engine, "check_workers", lambda client, timeout: 1)
        monkeypatch.setattr(urmx.provenance, "identity", identity)
        with pytest.raises(RunError, match=rf"worker {worker} runs other code .*kernel "
                           rf"{'0' * 16}, numpy \S+ there; .*kernel {real['kernel_source']}, "
                           r"numpy \S+ here\): its result of batch [\w-]+ is not kept") as err:
            st.run_study(study, out=out, kernel=fake_kernel, batch_size=2,
                         scheduler=client, progress=False)
    assert "\n" not in str(err.value)
    assert C.parts_of(out) == 0 and not out.exists()


# ---- a cluster that dies ------------------------------------------------------------------

def test_all_workers_lost_ends_the_run_and_a_rerun_finishes(external, cluster_study,
                                                           tmp_path, use_records):
    """SIGKILL of every worker mid-run: the run stops within --worker-timeout (2 s here)
    with one line, the finished batches kept; with a new worker the same command
    finishes, and the archive equals a run in one process."""
    reference = _reference(cluster_study, use_records)
    external.start_scheduler()
    workers = [external.add_worker(sleep=0.05) for _ in range(2)]
    external.wait_for_workers(2)
    out = tmp_path / "lost.nc"
    args = ["run", str(cluster_study), "--out", str(out), "--scheduler", external.address,
            "--batch-size", "1", "--worker-timeout", "2", "--quiet"]
    proc = C.urmx_run(args)
    C.wait_until(lambda: C.parts_of(out) >= 4, C.START, "4 batches saved", proc)
    for w in workers:
        external.kill(w)
    _, err = proc.communicate(timeout=ENDS_WITHIN)
    line = _one_line(err)
    kept = C.parts_of(out)
    assert proc.returncode == 2 and 4 <= kept < C.BATCHES
    assert line == (f"urmx run: error: no dask worker left on the scheduler "
                    f"{external.address} for 2 s (urmx.worker-timeout; --worker-timeout); "
                    f"{kept} of {C.BATCHES} batches are kept in "
                    f"'{out.with_name('lost.nc.parts')}': run again to resume")
    external.add_worker()
    again = C.urmx_run(args)
    _, err = again.communicate(timeout=120)
    assert again.returncode == 0, err
    _same(reference, urmx.open_study(out).load())


def test_the_scheduler_lost_ends_the_run_and_a_rerun_finishes(external, cluster_study,
                                                             tmp_path, use_records):
    """SIGKILL of the scheduler mid-run: one line (no CommClosedError traceback), the
    finished batches kept; the same study run again (here in one process) finishes."""
    reference = _reference(cluster_study, use_records)
    external.start_scheduler()
    external.add_worker(sleep=0.05)
    external.wait_for_workers(1)
    out = tmp_path / "gone.nc"
    proc = C.urmx_run(["run", str(cluster_study), "--out", str(out), "--scheduler",
                       external.address, "--batch-size", "1", "--quiet"])
    C.wait_until(lambda: C.parts_of(out) >= 4, C.START, "4 batches saved", proc)
    external.kill(external.scheduler)
    _, err = proc.communicate(timeout=ENDS_WITHIN)
    line = _one_line(err)
    kept = C.parts_of(out)
    assert proc.returncode == 2 and 4 <= kept < C.BATCHES
    assert line == (f"urmx run: error: the dask scheduler {external.address} went away "
                    f"(connection lost); {kept} of {C.BATCHES} batches are kept in "
                    f"'{out.with_name('gone.nc.parts')}': run again to resume")
    again = C.urmx_run(["run", str(cluster_study), "--out", str(out), "--scheduler",
                        "serial", "--batch-size", "1", "--quiet"])
    _, err = again.communicate(timeout=120)
    assert again.returncode == 0, err
    _same(reference, urmx.open_study(out).load())


def test_a_cluster_without_workers_is_said_before_any_work(external, cluster_study,
                                                           tmp_path):
    """A scheduler with no worker at all: the run waits --worker-timeout, then says so."""
    external.start_scheduler()
    out = tmp_path / "empty.nc"
    proc = C.urmx_run(["run", str(cluster_study), "--out", str(out), "--scheduler",
                       external.address, "--worker-timeout", "1", "--quiet"])
    _, err = proc.communicate(timeout=ENDS_WITHIN)
    assert proc.returncode == 2
    assert _one_line(err) == (f"urmx run: error: no dask worker joined the scheduler "
                              f"{external.address} within 1 s (urmx.worker-timeout; "
                              "--worker-timeout): start workers, then run again")
    assert not out.with_name("empty.nc.parts").exists()


# ---- closed and unusable clients ---------------------------------------------------------

def test_a_closed_or_unusable_client_is_an_input_error(gaps_records, make_study):
    from distributed import Client

    study = make_study(STUDY, "gaps.toml")
    client = Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0")
    client.close()
    with pytest.raises(InputError, match=r"the distributed.Client given is not running "
                       r"\(status 'closed'"):
        st.run_study(study, kernel=fake_kernel, batch_size=2, scheduler=client,
                     progress=False)
    with ThreadPoolExecutor(1) as pool, \
            pytest.raises(InputError, match="ThreadPoolExecutor is not a distributed.Client"):
        st.run_study(study, kernel=fake_kernel, batch_size=2, scheduler=pool, progress=False)


# ---- dask as the user has it --------------------------------------------------------------

def _no_cluster(*args, **kw):
    raise AssertionError("a local cluster was started")


WHERE: list[bool] = []  # per batch: whether it ran in this process's main thread


def _stamped_where(*args):
    """`urmx.study.clients.run_stamped`, noting where it runs (in :data:`WHERE`; a module
    function, so the in-process workers share the list)."""
    WHERE.append(threading.current_thread() is threading.main_thread())
    return clients.run_stamped(*args)


def test_an_active_client_is_used(gaps_records, make_study, monkeypatch):
    """With a distributed.Client active (a notebook's), scheduler=None runs the batches on
    it: no cluster of urmx's own, nothing in this process."""
    from distributed import Client

    study = make_study(STUDY, "gaps.toml")
    serial = st.run_study(study, kernel=fake_kernel, batch_size=2, scheduler="serial",
                          progress=False)
    monkeypatch.setattr(clients, "local_client", _no_cluster)
    monkeypatch.setattr(engine, "_in_process", _no_cluster)
    monkeypatch.setattr(engine, "run_stamped", _stamped_where)
    WHERE.clear()
    with Client(processes=False, n_workers=1, threads_per_worker=2,
                dashboard_address=":0") as client:
        assert clients.active_client() is client
        ds = st.run_study(study, kernel=fake_kernel, batch_size=2, progress=False)
    assert WHERE == [False] * 6  # every batch on the client's worker, none here
    assert clients.active_client() is None  # closed: not used again
    _same(serial, ds)


def test_a_small_study_runs_in_this_process(gaps_records, make_study, monkeypatch):
    """scheduler=None without an active client: the first batch runs here, timed; a study
    estimated under urmx.serial-below seconds (10 by default) runs here entirely, a larger
    one sends the rest to a local cluster."""
    import dask.config

    study = make_study(STUDY, "gaps.toml")
    serial = st.run_study(study, kernel=fake_kernel, batch_size=2, scheduler="serial",
                          progress=False)
    monkeypatch.setattr(clients, "local_client", _no_cluster)
    _same(serial, st.run_study(study, kernel=fake_kernel, batch_size=2, progress=False))
    assert clients.setting("serial-below") == 10.0
    # above the threshold: one batch here, then a cluster for the other five
    ran: list = []

    def counting(*args, **kw):
        ran.append(threading.current_thread().name)
        return fake_kernel(*args, **kw)

    class Started(Exception):
        pass

    def local_client(**kw):
        raise Started

    monkeypatch.setattr(clients, "local_client", local_client)
    with dask.config.set({"urmx.serial-below": 0}), pytest.raises(Started):
        st.run_study(study, kernel=counting, batch_size=2, progress=False)
    assert len(ran) == 2  # the first batch: 2 analyses (wall s08, quake, D1, 2 CORs)
    assert engine.serial_estimate(0.5, 2, 16) == pytest.approx(4.0)
    with dask.config.set({"urmx.serial-below": "soon"}), \
            pytest.raises(InputError, match="urmx.serial-below='soon'"):
        st.run_study(study, kernel=counting, batch_size=2, progress=False)
    with dask.config.set({"urmx.worker-timeout": 0}), \
            pytest.raises(InputError, match=r"urmx.worker-timeout=0 .* must be a number of "
                          r"seconds > 0"):
        clients.worker_timeout()


def test_progress_in_a_notebook_uses_tqdm_auto(monkeypatch):
    """In a Jupyter kernel the bar is tqdm.auto's (a widget with ipywidgets), even though
    stderr is no terminal there; outside one, a log file still gets plain lines."""
    from tqdm.auto import tqdm

    from urmx.study import progress

    assert not progress.in_notebook()  # pytest is no Jupyter kernel
    monkeypatch.setattr(progress, "in_notebook", lambda: True)
    bar = progress.Progress(10, 0, True, label="urmx demo")
    assert isinstance(bar.bar, tqdm)
    bar.update(10)
    assert bar.bar.n == 10
    bar.close()


# ---- provenance ---------------------------------------------------------------------------

def _git(*args: str) -> str:
    return subprocess.run(["git", "-C", str(C.ROOT), *args], capture_output=True, text=True,
                          check=True).stdout.strip()


@pytest.mark.parametrize("kind", ["grid", "ida"])
def test_archives_record_how_they_were_made(gaps_records, make_study, tmp_path, kind):
    import dask
    import distributed
    import netCDF4
    import numba
    import obspy
    import scipy

    from .helpers.gaps_study import IDA_STUDY

    text, kernel = (STUDY, fake_kernel) if kind == "grid" else (IDA_STUDY, ida_kernel)
    out = tmp_path / f"{kind}.nc"
    st.run_study(make_study(text, f"{kind}.toml"), out=out, kernel=kernel, batch_size=2,
                 scheduler="serial", progress=False)
    attrs = urmx.open_study(out).attrs
    if (C.ROOT / ".git").exists():  # the checkout the tests run from
        commit = _git("rev-parse", "HEAD")
        dirty = bool(_git("status", "--porcelain", "--", "urmx", "pyproject.toml"))
        assert attrs["urmx_git_commit"] == commit and attrs["urmx_git_dirty"] == int(dirty)
        release = urmx.provenance.git_release() or urmx.__version__.split("+")[0]
        assert attrs["urmx_version"] == (f"{release}+g{commit[:7]}"
                                         + (".dirty" if dirty else ""))
    else:  # a copy without git: the package version alone
        assert attrs["urmx_git_commit"] == "none" and attrs["urmx_git_dirty"] == -1
        assert attrs["urmx_version"] == urmx.__version__
    assert attrs["kernel_source_hash"] == urmx.jitcache.SOURCE_HASH
    assert attrs["python_version"] == sys.version.split()[0]
    for name, module in (("numba", numba), ("numpy", np), ("scipy", scipy),
                         ("xarray", xr), ("dask", dask), ("distributed", distributed),
                         ("netcdf4", netCDF4), ("obspy", obspy)):
        assert attrs[f"{name}_version"] == module.__version__, name
    assert attrs["study"] == text and attrs["study_name"] == ("gaps" if kind == "grid"
                                                              else "ida-gaps")
    assert set(urmx.provenance.ATTRS) <= set(attrs)


def test_the_version_outside_a_checkout_is_the_package_version(tmp_path, monkeypatch):
    monkeypatch.setattr(urmx.provenance, "ROOT", tmp_path)
    urmx.provenance.git_commit.cache_clear()
    try:
        assert urmx.provenance.git_commit() is None
        assert urmx.provenance.code_version() == urmx.__version__
        attrs = urmx.provenance.attrs()
        assert attrs["urmx_git_commit"] == "none" and attrs["urmx_git_dirty"] == -1
    finally:
        urmx.provenance.git_commit.cache_clear()


def test_version_option_says_which_code_runs(capsys):
    from urmx.cli import main

    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0
    assert capsys.readouterr().out == f"urmx {urmx.provenance.code_version()}\n"
    if (C.ROOT / ".git").exists():
        release = urmx.provenance.git_release() or urmx.__version__.split("+")[0]
        assert urmx.provenance.code_version().startswith(f"{release}+g")


def test_a_script_without_a_main_guard_is_told_what_to_do(tmp_path, records_dir):
    """A script calling run_study at its top level, run where the study starts a local
    cluster: each worker process imports the script again and used to run the study a
    second time (tracebacks of 'another urmx run is writing', then 'Nanny failed to
    start'). Now each worker stops with one line, and run_study's error says the fix."""
    import os

    script = tmp_path / "unguarded.py"
    script.write_text('import urmx\n'
                      'urmx.run_study("paper-single-storey", out="a.nc", progress=False)\n')
    env = dict(os.environ, URMX_RECORDS=str(records_dir), DASK_URMX__SERIAL_BELOW="0")
    proc = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    err = proc.stderr
    assert proc.returncode == 1
    assert "another urmx run" not in err and "spawn_main" not in err, err
    worker = [ln for ln in err.splitlines() if ln.startswith("urmx: a worker process")]
    assert worker and all(ln == worker[0] for ln in worker)
    assert 'under `if __name__ == "__main__":`' in worker[0]
    last = err.strip().splitlines()[-1]
    assert last.startswith("urmx.errors.RunError: the local dask cluster did not start ")
    assert clients.UNGUARDED in last
