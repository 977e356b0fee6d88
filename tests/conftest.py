"""Shared fixtures: the records folder (a missing folder fails under CI, skips elsewhere),
the synthetic study Datasets, factories for walls and study files, and in-memory records
in place of the manifest."""

from __future__ import annotations

from pathlib import Path

import pytest

import urmx
from urmx.guard import benchmark_wall

from .fixtures import compiled, studies
from .fixtures.records import records_folder, samples_folder


@pytest.fixture(scope="session")
def records_dir() -> Path:
    """The records folder manifest ids resolve against (``$URMX_RECORDS``, else the
    records the repository ships); a named folder that is missing fails the test if the
    environment variable ``CI`` is set and skips it otherwise."""
    return records_folder()


@pytest.fixture(scope="session")
def sample_records() -> Path:
    """The records folder that holds the reader-format samples (the shipped records,
    ``records/formats``); missing, it fails the
    test under CI and skips it elsewhere."""
    return samples_folder()


@pytest.fixture(scope="module")
def single():
    """The synthetic single-storey study (`tests.fixtures.studies.single_storey`)."""
    return studies.single_storey()


@pytest.fixture(scope="module")
def multi():
    """The synthetic higher-storey study (`tests.fixtures.studies.multi_storey`)."""
    return studies.multi_storey()


@pytest.fixture(scope="module")
def verif():
    """The synthetic verification study (`tests.fixtures.studies.verification`)."""
    return studies.verification()


@pytest.fixture(scope="session")
def make_wall():
    """Factory: the benchmark wall (b 0.23 m, h 4.14 m, rigid base, top diaphragm
    815 kN/m, 20 t, 12 %), with any `urmx.Wall` fields replaced: ``make_wall(cor=...)``."""
    return benchmark_wall


@pytest.fixture
def make_study(tmp_path):
    """Factory: write a study file from its TOML text into the test's temporary folder
    and return its path: ``make_study(text, name="study.toml")``."""
    def make(text: str, name: str = "study.toml") -> Path:
        path = tmp_path / name
        path.write_text(text, encoding="utf-8")
        return path

    return make


@pytest.fixture
def use_records(monkeypatch):
    """Factory: serve in-memory records in place of the manifest and its loader for this
    test: ``use_records(acceleration, scale, dt)`` with ``{id: samples [m s-2]}`` and
    ``{id: scale factor}``."""
    from obspy import Trace

    def use(acceleration: dict, scale: dict, dt: float) -> None:
        def manifest(records_dir=None):
            return {k: {"scale_factor": scale[k], "paper_scale_factor": scale[k]}
                    for k in acceleration}

        def load(record_id, records_dir=None):
            return Trace(data=acceleration[record_id].copy(), header={"delta": dt})

        monkeypatch.setattr(urmx.records, "manifest", manifest, raising=False)
        monkeypatch.setattr(urmx.records, "load", load, raising=False)

    return use


@pytest.fixture
def own_records(tmp_path) -> Path:
    """A records folder of four synthetic AT2 records ``rec1`` ... ``rec4`` and their
    manifest (`tests.helpers.own_records.own_record_folder`)."""
    from .helpers.own_records import own_record_folder

    return own_record_folder(tmp_path)


@pytest.fixture
def grid_records(use_records):
    """The small grid study's two synthetic records in place of the manifest
    (`tests.helpers.grid_study`), with its stand-in kernel's call log emptied."""
    from .helpers import grid_study as G

    use_records(G.ACC, G.SCALE, G.DT)
    G.CALLS.clear()


@pytest.fixture
def gaps_records(use_records):
    """The "gaps" study's two synthetic pulse records in place of the manifest
    (`tests.helpers.gaps_study`)."""
    from .helpers import gaps_study as G

    use_records(G.ACC, G.SCALE, G.DT)


@pytest.fixture
def ida_records(use_records):
    """The IDA stand-ins' two synthetic records in place of the manifest
    (`tests.helpers.ida_study`), with `study_kernel`'s call log emptied."""
    from .helpers import ida_study as G

    use_records(G.ACC, G.SCALE, G.DT)
    G.CALLS.clear()


@pytest.fixture(scope="session")
def cold_kernel(tmp_path_factory) -> compiled.ColdCompile:
    """The suite's one cold compile of the kernel's loop, in a new process with an empty
    ``NUMBA_CACHE_DIR`` (`tests.fixtures.compiled`): tests that change its cache folder
    work on a copy (``compiled.copy_cache``)."""
    return compiled.cold_compile(tmp_path_factory.mktemp("numba-cold"))
