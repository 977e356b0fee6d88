"""Study grids: Dataset schema, dask equality, netCDF round trip, resume, bad study files.

The kernel and the records are replaced by small deterministic stand-ins (passed as
``kernel=`` and monkeypatched into ``urmx.records``), so every expected value below is
computed by hand and no test depends on the integrator's numbers.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr

from urmx import study as st
from urmx import variables
from urmx.catalog import CatalogError
from urmx.study.file import load_study

from .helpers.grid_study import CALLS, DIMS_STUDY, DT, FAIL_AT, STUDY, Interrupt, fake_kernel


@pytest.fixture
def small(make_study):
    return make_study(STUDY, "small.toml")


def _run(small, **kw):
    kw.setdefault("scheduler", "serial")
    return st.run_study(small, kernel=fake_kernel, progress=False, batch_size=2, **kw)


def _same_history(a, b):
    """Archives of two runs differ only in the start time at the head of `history`."""
    a, b = a.copy(), b.copy()
    for ds in (a, b):
        ds.attrs["history"] = ds.attrs["history"].split(" ", 1)[1]
    return a, b


def test_dataset_schema_and_values(grid_records, small):
    ds = _run(small)
    assert dict(ds.sizes) == {"wall": 2, "diaphragm": 2, "record": 2, "cor": 2, "history": 2,
                              "time": 200}
    assert list(ds.wall.values) == ["s08", "s18"]
    np.testing.assert_allclose(ds.slenderness, [8.0, 18.0])
    np.testing.assert_allclose(ds.height, [1.84, 4.14])
    assert ds.stiffness.values[0] == 815e3 and math.isinf(ds.stiffness.values[1])
    np.testing.assert_allclose(ds.pga, [2.0, 3.0])
    np.testing.assert_allclose(ds.scale_factor, [0.5, 2.0])
    np.testing.assert_allclose(ds.scaled_pga, [1.0, 6.0])
    np.testing.assert_allclose(ds.record_dt, [DT, DT])
    # s18 on D1 under "shake" at COR 0.8: 6.0 m s-2 * 4.14 m * 0.8 / 100
    cell = ds.sel(wall="s18", diaphragm="D1", record="shake", cor=0.8)
    assert float(cell.peak_crack_displacement) == pytest.approx(0.19872, rel=1e-12)
    assert float(cell.peak_top_displacement) == pytest.approx(1.49, rel=1e-12)
    assert float(cell.instability_ratio) == pytest.approx(6.0 * 0.8 / 18.0, rel=1e-12)
    # s08 under "shake" at 0.8: ratio 4.8/8 = 0.6 (ok); every cell ran
    assert int(ds.status.sel(wall="s08", record="shake", cor=0.8, diaphragm="D5-pinned")) == 0
    # integer outputs are float64 in memory (NaN where no valid result), int32 on disk
    assert ds.base_impacts.dtype == np.float64 and float(ds.base_impacts.min()) == 7
    # D1's frequency, its own (the building's median parametric wall s16, whatever walls
    # the study has: here s08 and s18): sqrt(815e3 / (m_d + m/2)) / 2 pi with the catalog's
    # building: m = 20329.85 kg, m_d = 12869.50 kg; in Table IV's 0.8-1.1 Hz
    assert float(ds.frequency[0]) == pytest.approx(
        math.sqrt(815e3 / (12869.496 + 0.5 * 20329.851)) / (2 * math.pi), rel=1e-6)
    assert 0.8 < float(ds.frequency[0]) < 1.1
    for name in (*variables.SCALARS, "status"):
        assert ds[name].attrs["long_name"] and ds[name].dims == ("wall", "diaphragm", "record",
                                                                  "cor")
        if name != "status":
            assert ds[name].attrs["units"] == variables.attrs(name)["units"]
    assert ds.status.attrs["flag_meanings"] == "ok collapsed event_limit not_run"
    # histories: the s18/D1 wall under both records, NaN-padded to the longer record
    assert list(ds.history_record.values) == ["quake", "shake"]
    assert ds.theta_lower.dims == ("history", "time")
    assert float(ds.theta_lower.sel(history="s18/D1/quake/cor0.8")[199]) == 0.8
    assert np.isnan(ds.theta_lower.sel(history="s18/D1/shake/cor0.8")[150:]).all()
    assert ds.time.attrs["units"] == "s"
    assert ds.attrs["Conventions"] == "CF-1.8" and ds.attrs["study"] == STUDY
    assert "urmx" in ds.attrs["history"] and ds.attrs["urmx_version"]
    assert len(CALLS) == 16  # 2 walls x 2 diaphragms x 2 records x 2 cor, once each


def test_netcdf_round_trip_is_identical(grid_records, small, tmp_path):
    out = tmp_path / "small.nc"
    ds = _run(small, out=out)
    assert not (tmp_path / "small.nc.parts").exists()
    back = st.open_study(out)
    assert back.peak_crack_displacement.chunks is not None  # lazy dask
    xr.testing.assert_identical(ds, back.load())


def test_added_dimensions_and_pairs(grid_records, make_study):
    path = make_study(DIMS_STUDY, "dims.toml")
    ds = st.run_study(path, kernel=fake_kernel, scheduler="serial", progress=False)
    assert ds.peak_crack_displacement.dims == ("wall", "diaphragm", "record", "cor", "scale",
                                               "impact", "damping")
    np.testing.assert_allclose(ds.cor, [0.70, 0.71, 0.72])
    assert len(CALLS) == 3 * 3 * 2 * 2  # (s18, shake), (c9, quake), (c9, shake)
    assert (ds.status.sel(wall="s18", record="quake") == st.NOT_RUN).all()
    assert np.isnan(ds.peak_crack_displacement.sel(wall="s18", record="quake")).all()
    assert np.isnan(ds.base_impacts.sel(wall="s18", record="quake")).all()
    # c9 under quake x 2 at COR 0.71: 0.5*2*2.0 = 2.0 m s-2 * 2.79 m * 0.71 / 100
    v = ds.peak_crack_displacement.sel(wall="c9", record="quake", cor=0.71, scale=2.0,
                                       impact="contact", damping=0.05).squeeze()
    assert float(v) == pytest.approx(2.0 * 2.79 * 0.71 / 100, rel=1e-12)
    assert float(ds.peak_top_acceleration.sel(impact="contact").max()) == 1.0
    assert np.isnan(ds.stiffness).all()


def test_interrupted_run_resumes_without_recomputing(grid_records, small, tmp_path):
    reference = _run(small, out=tmp_path / "ref.nc")
    CALLS.clear()
    FAIL_AT.append(6)  # stop inside the fourth batch of two analyses
    out = tmp_path / "run.nc"
    try:
        with pytest.raises(Interrupt):
            _run(small, out=out)
    finally:
        FAIL_AT.clear()
    parts = tmp_path / "run.nc.parts"
    assert len(list(parts.glob("*.npz"))) == 3 and not out.exists()
    started = (parts / "started").read_text().strip()
    first = list(CALLS)
    CALLS.clear()
    ds = _run(small, out=out)
    computed = first + CALLS
    assert len(first) == 6 and len(CALLS) == 10
    assert len(set(computed)) == len(computed) == 16  # none twice, none lost
    assert ds.attrs["history"].startswith(started)
    xr.testing.assert_identical(*_same_history(st.open_study(out).load(), reference))


def test_local_cluster_equals_serial(grid_records, small):
    serial = _run(small)
    client = st.local_client(2)
    try:
        assert len(client.scheduler_info()["workers"]) == 2
        parallel = _run(small, scheduler=client)
    finally:
        st.close_client(client)
    assert client.status == "closed"
    xr.testing.assert_identical(*_same_history(serial, parallel))


def test_run_grid_in_memory_equals_run_study(grid_records, small, tmp_path):
    study = load_study(small)
    records = st.resolve_records(study)
    tasks = st.batch_tasks(study, records, batch_size=2, kernel=fake_kernel)
    assert len(tasks) == 8 and all(len(b.walls) == 1 and b.key for b, _ in tasks)
    CALLS.clear()
    ds = st.run_grid(study, records, "serial", batch_size=2, kernel=fake_kernel)
    assert len(CALLS) == 16 and not list(tmp_path.glob("*.nc*"))  # nothing on disk
    xr.testing.assert_identical(*_same_history(ds, _run(small)))


@pytest.mark.parametrize("body, needle, line", [
    ('walls = ["s08", "nope"]', "unknown wall id 'nope'", 4),
    ("cor = []", "study.cor: has no values", 8),
    ('diaphragms = ["D9"]', "unknown diaphragm id 'D9'", 5),
])
def test_bad_study_fails_with_file_line_and_key(make_study, body, needle, line):
    key = body.split(" =")[0]
    lines = [ln for ln in STUDY.splitlines()[:8]]
    lines = [body if ln.startswith(key + " =") else ln for ln in lines]
    path = make_study("\n".join(lines) + "\n", "bad.toml")
    with pytest.raises(CatalogError) as err:
        load_study(path)
    assert f"{path}:{line}:" in str(err.value) and needle in str(err.value)


def test_negative_stiffness_fails(make_study):
    path = make_study(STUDY.replace('["D1", "D5-pinned"]', '["D1", "soft"]') + """
[diaphragms.soft]
stiffness = -5.0e5
""", "neg.toml")
    with pytest.raises(CatalogError, match=r"neg\.toml:17: diaphragms\.soft\.stiffness: -500000"):
        load_study(path)


def test_missing_record_fails_before_any_analysis(grid_records, make_study):
    path = make_study(STUDY.replace('["quake", "shake"]\ncor', '["quake", "elsewhere"]\ncor'),
                      "rec.toml")
    with pytest.raises(CatalogError, match=r"rec\.toml:7: study\.records: record 'elsewhere'"):
        st.run_study(path, kernel=fake_kernel, scheduler="serial", progress=False)
    assert CALLS == []
