"""urmx installed from a built wheel, outside the checkout: the wheel carries the catalog and
the records (the manifest and its record files; setup.py copies them into ``urmx/_data/``),
and ``urmx records list``, ``urmx simulate`` of a catalog wall under a manifest record and
``urmx run`` of a catalog study work with no records folder set and give the checkout's
numbers; outputs go to the current folder, never into the package. And the README's
Quick start, as written, from a clone with nothing beside it."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
import xarray as xr

import urmx
import urmx.records
from urmx.cli import main
from urmx.config import checkout, data_dir

from .helpers.runs import fallback_version

ROOT = Path(__file__).resolve().parent.parent
#: what a wheel is built from (the rest of the checkout is not needed)
SOURCES = ("pyproject.toml", "setup.py", "MANIFEST.in", "README.md", "urmx", "catalog",
           "records")


def _copy_sources(dest: Path) -> Path:
    """The files a wheel is built from, copied out (so the build leaves no build/ or
    egg-info in the checkout)."""
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "_data")
    dest.mkdir(parents=True)
    for name in SOURCES:
        src = ROOT / name
        if src.is_dir():
            shutil.copytree(src, dest / name, ignore=ignore)
        else:
            shutil.copy2(src, dest / name)
    return dest


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """A wheel built from the checkout's sources (``pip wheel . --no-deps``)."""
    tmp = tmp_path_factory.mktemp("wheel")
    src = _copy_sources(tmp / "src")
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", ".", "--no-deps", "-q",
                           "-w", str(tmp / "dist")], cwd=src, capture_output=True, text=True,
                          timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    (found,) = (tmp / "dist").glob("urmx-*.whl")
    return found


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory) -> Path:
    """The wheel installed with ``pip install --no-deps --target DIR`` (its dependencies are
    this environment's); the compiled kernel of the checkout, when there is one, is copied
    into it (the cache folder is named by the hash of the same sources and versions), so
    that the test does not compile the kernel a second time."""
    target = tmp_path_factory.mktemp("site") / "lib"
    proc = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "-q",
                           "--no-index", "--target", str(target), str(wheel)],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    from urmx.jitcache import SOURCE_HASH

    cache = ROOT / "urmx" / "__pycache__" / f"numba-{SOURCE_HASH}"
    if cache.is_dir():
        shutil.copytree(cache, target / "urmx" / "__pycache__" / cache.name)
    return target


def _urmx(target: Path, cwd: Path, *args: str,
          records: Path | None = None) -> subprocess.CompletedProcess:
    """``urmx ARGS`` of the installed wheel (its console script), run in `cwd` with only
    the install on PYTHONPATH, and no records folder set unless `records` is given."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "NUMBA_CACHE_DIR", "URMX_RECORDS")}
    env.update(PYTHONPATH=str(target), MPLBACKEND="Agg")
    if records is not None:
        env["URMX_RECORDS"] = str(records)
    return subprocess.run([sys.executable, str(target / "bin" / "urmx"), *args], cwd=cwd,
                          env=env, capture_output=True, text=True, timeout=900)


def test_the_wheel_carries_the_catalog_and_the_manifest(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    catalog = {f"urmx/_data/{p.relative_to(ROOT).as_posix()}"
               for p in (ROOT / "catalog").rglob("*") if p.is_file()
               and "__pycache__" not in p.parts}
    assert "urmx/_data/catalog/studies/verification.toml" in catalog
    assert catalog <= names
    assert "urmx/_data/records/manifest.toml" in names
    assert "urmx/_data/records/PROVENANCE.md" in names
    shipped = {f"urmx/_data/records/{e['file']}" for e in urmx.records.manifest().values()}
    assert len(shipped) == 47 and shipped <= names  # every record file of the manifest
    assert "urmx/_data/records/formats/manifest.toml" in names  # and the format samples
    assert "urmx/_data/records/formats/peer/RSN763_LOMAP_GIL067.AT2" in names
    assert "urmx/variables.toml" in names
    assert not any(n.startswith(("catalog/", "records/", "tests/", "benchmarks/"))
                   for n in names)


def test_the_checkout_reads_its_own_folders():
    """From the checkout (an editable install) urmx reads the top-level folders, not a
    copy: the one source."""
    assert checkout() == ROOT
    assert data_dir("catalog") == ROOT / "catalog"
    assert data_dir("records") == ROOT / "records"
    assert not (ROOT / "urmx" / "_data").exists()


@pytest.mark.slow
def test_a_build_outside_git_gets_the_fallback_version(wheel, installed, tmp_path):
    """The wheel is built from a copy of the sources without git (`_copy_sources`): it is
    the ``fallback_version`` of pyproject.toml, and ``urmx.__version__`` and ``urmx
    --version`` of its install say it (versions come from git tags, issue 40)."""
    version = fallback_version()
    assert wheel.name.startswith(f"urmx-{version}-")
    with zipfile.ZipFile(wheel) as z:
        meta = z.read(f"urmx-{version}.dist-info/METADATA").decode()
    assert f"\nVersion: {version}\n" in meta
    env = dict(os.environ, PYTHONPATH=str(installed))
    said = subprocess.run([sys.executable, "-c", "import urmx, urmx.cli as c; "
                           "print(urmx.__version__, urmx.__file__); c.main(['--version'])"],
                          cwd=tmp_path, env=env, capture_output=True, text=True)
    first, second = said.stdout.splitlines()
    assert first.split()[0] == version and Path(first.split()[1]).is_relative_to(installed)
    assert second == f"urmx {version}"


def test_installed_wheel_runs_outside_the_checkout(installed, tmp_path, records_dir, capsys):
    work = tmp_path / "elsewhere"
    work.mkdir()
    shutil.copy(ROOT / "catalog" / "examples" / "benchmark-wall.toml", work)
    probe = subprocess.run(
        [sys.executable, "-c", "import urmx, urmx.config as c; print(urmx.__file__); "
         "print(c.data_dir('catalog')); print(c.checkout())"],
        cwd=work, env={**os.environ, "PYTHONPATH": str(installed)}, capture_output=True,
        text=True, check=True)
    where, catalog, root = probe.stdout.split("\n")[:3]
    assert Path(where).is_relative_to(installed)  # not the checkout's editable urmx
    assert Path(catalog) == installed / "urmx" / "_data" / "catalog" and root == "None"

    listed = _urmx(installed, work, "records", "list")  # no records folder set
    assert listed.returncode == 0, listed.stderr
    shipped = installed / "urmx" / "_data" / "records"
    assert listed.stdout.startswith(f"shipped: 51 records from {shipped} (shipped with urmx)")
    assert "elcentro               shipped paper" in listed.stdout
    assert "p695-01-mul009" in listed.stdout

    sim = _urmx(installed, work, "simulate", "benchmark-wall.toml", "elcentro", "--scale",
                "0.5", "--out", "run.nc")
    assert sim.returncode == 0, sim.stderr
    assert main(["simulate", str(ROOT / "catalog/examples/benchmark-wall.toml"), "elcentro",
                 "--scale", "0.5", "--records", str(records_dir),
                 "--out", str(tmp_path / "run.nc")]) == 0
    with xr.open_dataset(work / "run.nc") as a, xr.open_dataset(tmp_path / "run.nc") as b:
        # the same numbers, bit for bit, and attributes, but for the provenance of the code
        # that ran: a wheel is no git checkout
        assert a.attrs["urmx_git_commit"] == "none"
        # built outside git: the fallback version of pyproject.toml (versions come from tags)
        assert a.attrs["urmx_version"] == fallback_version()
        assert b.attrs["urmx_git_commit"] != "none"
        assert a.attrs["kernel_source_hash"] == b.attrs["kernel_source_hash"]
        for ds, version in ((a, fallback_version()), (b, urmx.__version__)):
            for key in ("urmx_version", "urmx_git_commit", "urmx_git_dirty"):
                del ds.attrs[key]
            assert f"urmx {version} simulate(" in ds.attrs["history"]  # each its own version
            ds.attrs["history"] = ds.attrs["history"].replace(f"urmx {version} ", "urmx V ")
        xr.testing.assert_identical(a, b)
        assert a.sizes["time"] > 1000

    study = _urmx(installed, work, "run", "verification", "--out", "verification.nc",
                  "--scheduler", "serial", "--quiet")
    assert study.returncode == 0, study.stderr
    assert main(["run", "verification", "--out", str(tmp_path / "verification.nc"),
                 "--scheduler", "serial", "--quiet", "--records", str(records_dir)]) == 0
    with xr.open_dataset(work / "verification.nc") as a, \
            xr.open_dataset(tmp_path / "verification.nc") as b:
        # attributes differ: the command line, the time; and the cells' keys, which hold the
        # urmx version (the wheel, built outside git, has the fallback version)
        xr.testing.assert_equal(a.drop_vars("cell_key"), b.drop_vars("cell_key"))
        assert int((a.status <= 1).sum()) == 63  # 3 walls, each under its record, 21 CORs

    # an output the command is not told where to put goes to the current folder
    cal = _urmx(installed, work, "calibrate")
    assert cal.returncode == 0, cal.stderr
    assert (work / "reports" / "calibration.md").is_file()
    assert not list(installed.glob("reports")) and not list(installed.glob("results"))
    bench = _urmx(installed, work, "bench", "kernel")
    assert bench.returncode == 2 and len(bench.stderr.strip().splitlines()) == 1
    assert "source checkout" in bench.stderr


def test_what_needs_a_checkout_says_so_in_one_line(tmp_path, monkeypatch, capsys):
    """An installed urmx (no checkout above the package) refuses to store a guard baseline
    without --baseline, before measuring anything, and reads its data from the package."""
    import urmx.config

    monkeypatch.setattr(urmx.config, "project_root", lambda: tmp_path)
    assert urmx.config.checkout() is None
    assert urmx.config.data_dir("catalog").parts[-3:] == ("urmx", "_data", "catalog")
    assert main(["bench", "guard", "--update"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert "guard --update needs a source checkout of urmx" in err


#: what the clone's test run is limited to (module docstring of the test below)
QUICK_START_SUBSET = ("tests/test_fixtures.py "
                      "tests/test_records.py::test_shipped_records_are_the_manifests "
                      "tests/test_records.py::test_shipped_format_samples_are_their_manifests "
                      "tests/test_readers.py::test_describe_a_record_file "
                      "tests/test_records.py::test_load_paper_records "
                      "tests/test_records_checks.py::test_csv_with_a_header_row_reads_as_the_"
                      "bare_numbers")


def quick_start_commands(readme: Path = ROOT / "README.md") -> list[str]:
    """The README's Quick start commands, as written: the indented lines of its "Quick
    start" section that make a virtual environment."""
    text = readme.read_text(encoding="utf-8")
    section = text.split("\n## Quick start", 1)[1].split("\n## ", 1)[0]
    return [ln.strip() for ln in section.splitlines()
            if ln.startswith("    ") and ln.strip().startswith("python3 -m venv")]


def test_the_readme_names_two_quick_start_commands_and_nothing_outside():
    commands = quick_start_commands()
    assert len(commands) == 2
    assert commands[0].endswith("urmx paper") and "pytest" in commands[1]
    for c in commands:
        assert "URMX_RECORDS" not in c and ".." not in c
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "../shared" not in readme and "shared/design" not in readme


@pytest.mark.slow
def test_quick_start_from_a_clone(tmp_path):
    """The README's two Quick start commands, as written, in a clone of the repository in
    an empty folder (no ``../shared``), without ``URMX_RECORDS`` or ``CI``, each making its
    new virtual environment: both exit 0, and ``git status --porcelain`` is empty after them
    (`urmx paper` rewrote its report to the same bytes).

    The second command runs the test suite, this test among it. Run whole, it would run
    the suite inside the suite (a recursion, and twice the CI time), so it runs here as
    written but with ``PYTEST_ADDOPTS`` naming a small subset (`QUICK_START_SUBSET`: the
    fixtures' guard rails, the shipped records and format samples against their manifests
    and provenance, a format sample described, loading the paper's records, a CSV read)
    that needs nothing but the clone, and none of it skips; ``.ci/run`` runs the same
    command whole. pip uses its cache and the configured package index (no
    other network is needed)."""
    clone = tmp_path / "empty" / "urmx"
    clone.parent.mkdir()
    subprocess.run(["git", "clone", "--quiet", str(ROOT), str(clone)], check=True,
                   capture_output=True, timeout=300)
    assert not (clone.parent.parent / "shared").exists()
    venv_bin = str(Path(sys.prefix) / "bin")
    env = {k: v for k, v in os.environ.items()
           if k not in ("URMX_RECORDS", "PYTHONPATH", "VIRTUAL_ENV", "CI", "NUMBA_CACHE_DIR",
                        "PYTEST_ADDOPTS", "PYTEST_CURRENT_TEST")}
    env["PATH"] = os.pathsep.join(p for p in env["PATH"].split(os.pathsep) if p != venv_bin)
    env["MPLBACKEND"] = "Agg"
    first, second = quick_start_commands()
    for command, extra in ((first, {}), (second, {"PYTEST_ADDOPTS": QUICK_START_SUBSET})):
        proc = subprocess.run(["bash", "-c", command], cwd=clone, env={**env, **extra},
                              capture_output=True, text=True, timeout=3000)
        assert proc.returncode == 0, f"{command}\n{proc.stdout[-2000:]}\n{proc.stderr[-3000:]}"
    assert " passed" in proc.stdout and "failed" not in proc.stdout
    assert "skipped" not in proc.stdout  # the format samples, too, are in the clone
    status = subprocess.run(["git", "status", "--porcelain"], cwd=clone, capture_output=True,
                            text=True, check=True).stdout
    assert status == "", status


@pytest.mark.slow
def test_installed_wheel_names_the_catalog(installed, tmp_path, records_dir, capsys):
    """Issue 39: from a wheel outside the checkout, `urmx catalog list` lists the carried
    catalog, an example's name stands for a wall file (`urmx simulate benchmark-wall
    elcentro`, the checkout's numbers), `urmx catalog copy` copies a study out, and
    `urmx.config.data_dir()` needs no argument."""
    work = tmp_path / "elsewhere"
    work.mkdir()
    listed = _urmx(installed, work, "catalog", "list", records=records_dir)
    assert listed.returncode == 0, listed.stderr
    assert main(["catalog", "list"]) == 0
    assert listed.stdout == capsys.readouterr().out
    for name in ("benchmark-wall", "verification", "fema-p695-ida", "D5-pinned", "wall12"):
        assert name in listed.stdout

    sim = _urmx(installed, work, "simulate", "benchmark-wall", "elcentro", records=records_dir)
    assert sim.returncode == 0, sim.stderr
    assert main(["simulate", "benchmark-wall", "elcentro", "--records", str(records_dir)]) == 0
    ours = capsys.readouterr().out
    # the table of scalars (the first line names the wall file: the wheel's own copy)
    assert sim.stdout.splitlines()[1:] == ours.splitlines()[1:]
    assert str(installed) in sim.stdout.splitlines()[0]

    copied = _urmx(installed, work, "catalog", "copy", "verification", records=records_dir)
    assert copied.returncode == 0, copied.stderr
    assert (work / "verification.toml").read_text(encoding="utf-8") == \
        (ROOT / "catalog" / "studies" / "verification.toml").read_text(encoding="utf-8")
    probe = subprocess.run(
        [sys.executable, "-c", "import urmx.config as c; print(c.data_dir())"],
        cwd=work, env={**os.environ, "PYTHONPATH": str(installed)}, capture_output=True,
        text=True, check=True)
    assert Path(probe.stdout.strip()) == installed / "urmx" / "_data" / "catalog"
