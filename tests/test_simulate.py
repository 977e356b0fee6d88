"""urmx.simulate (the labelled wrapper) and the ``urmx simulate`` command."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import urmx
import urmx.jitcache
import urmx.provenance
from urmx import Wall
from urmx.catalog import read_wall
from urmx.cli import main
from urmx.netcdf import write_netcdf
from urmx.variables import HISTORIES, INTEGER_SCALARS, SCALARS, attrs

from .helpers.kernel import c9_chatter

EXAMPLES = Path(__file__).resolve().parents[1] / "catalog" / "examples"
DT = 0.02


@pytest.fixture(scope="module")
def wall(make_wall):
    """The benchmark wall: b 0.23 m, h 4.14 m, crack at 2/3, 30 t, rigid base, top
    diaphragm 815 kN/m with 20 t and 12 % damping."""
    w = make_wall()
    assert w == Wall(thickness=0.23, height=4.14, crack_ratio=2 / 3, mass=30000.0,
                     top_stiffness=815e3, top_mass=20000.0, top_damping=0.12)
    return w


@pytest.fixture(scope="module")
def elcentro(records_dir):
    """El Centro 1940 S00E as an ObsPy Trace [m s-2]."""
    from urmx.records import read

    return read(records_dir / "elcentro1940" / "elcentro_S00E_1940.dat", dt=DT,
                unit="cm/s2")[0]


@pytest.fixture(scope="module")
def first5s(elcentro):
    """The first 5 s (251 samples) of El Centro. [m s-2]"""
    return elcentro.data[:251].copy()


@pytest.fixture(scope="module")
def response(first5s, wall):
    """Benchmark wall, El Centro 0-5 s x 0.5, with a 1 s tail and histories."""
    return urmx.simulate(wall, first5s, DT, scale=0.5, tail=1.0, history=True)


def test_scalar_variables_exactly_with_registry_attrs(first5s, wall):
    ds = urmx.simulate(wall, first5s, DT, scale=0.5)
    assert set(ds.data_vars) == set(SCALARS)
    assert list(ds.data_vars) == list(SCALARS)
    assert not ds.dims and not ds.coords
    for name in SCALARS:
        assert ds[name].attrs["units"] == attrs(name)["units"]
        assert ds[name].attrs["long_name"] == attrs(name)["long_name"]
        assert ds[name].dtype.kind == ("i" if name in INTEGER_SCALARS else "f")
    assert ds.attrs["status"] == "ok" and ds.attrs["method"] == "exact"
    assert ds.attrs["duration"] == pytest.approx(5.0, abs=1e-12)
    assert ds.attrs["cor"] == 0.8 and ds.attrs["scale"] == 0.5
    assert ds.attrs["impact"] == "scale"
    assert ds.attrs["urmx_version"] == urmx.provenance.code_version()
    release = urmx.provenance.git_release() or urmx.__version__.split("+")[0]
    assert ds.attrs["urmx_version"].startswith(release)
    assert ds.attrs["kernel_source_hash"] == urmx.jitcache.SOURCE_HASH
    assert ds.attrs["wall_top_stiffness"] == 815e3
    assert ds.attrs["wall_bottom_stiffness"] == "rigid"
    assert ds.attrs["events"] > 0


def test_scalar_values(response):
    """The benchmark wall under El Centro 0-5 s x 0.5 with a 1 s tail."""
    ds = response
    expected = {
        "peak_crack_displacement": 0.02134327737260208,
        "peak_top_displacement": 0.023741590073975895,
        "peak_upper_drift": 0.008905544084842822,
        "peak_top_acceleration": 1.6772902192036376,
        "peak_crack_acceleration": 2.8473038583724284,
        "peak_base_acceleration": 1.708525,  # = 0.5 * the record's 341.705 cm/s2
        "instability_ratio_lower": 0.27032706237910564,
        "instability_ratio_upper": 0.06453292815103494,
    }
    for name, value in expected.items():
        assert float(ds[name]) == pytest.approx(value, rel=1e-8), name
    assert float(ds.peak_base_displacement) == 0.0  # rigid base: exact, not round-off
    assert float(ds.peak_lower_drift) == float(ds.peak_crack_displacement)
    assert float(ds.instability_ratio) == float(ds.instability_ratio_lower)
    assert int(ds.collapsed) == 0 and math.isnan(float(ds.collapse_time))
    assert (int(ds.base_impacts), int(ds.crack_impacts)) == (14, 39)
    assert float(ds.unfavourable_fraction) == pytest.approx(0.25581827285340636, rel=1e-8)
    assert ds.attrs["duration"] == pytest.approx(6.0, abs=1e-12)


def test_history_on_the_record_grid(response, first5s, wall):
    ds = response
    n = 251 + 50  # record samples + 1 s tail at 0.02 s
    assert dict(ds.sizes) == {"time": n}
    np.testing.assert_allclose(ds.time.values, np.arange(n) * DT, rtol=0, atol=1e-12)
    assert ds.time.attrs["units"] == "s"
    assert set(ds.data_vars) == set(SCALARS) | set(HISTORIES) | {"ground_acceleration"}
    for name in (*HISTORIES, "ground_acceleration"):
        assert ds[name].dims == ("time",)
        assert ds[name].attrs["units"] == attrs(name)["units"]
        assert ds[name].attrs["long_name"]
    ag = ds.ground_acceleration.values
    np.testing.assert_array_equal(ag[:251], 0.5 * first5s)
    np.testing.assert_array_equal(ag[251:], 0.0)
    assert ds.pattern.dtype.kind == "i"
    assert set(np.unique(ds.pattern.values)) <= {11, 12, 21, 22}
    assert {11, 12, 21, 22} & set(np.unique(ds.pattern.values)) >= {12, 21, 22}
    # kinematics (MODEL.md section 1) and the rigid base reported exactly
    a1, a2 = wall.a1, wall.a2
    np.testing.assert_array_equal(ds.base_displacement.values, 0.0)
    np.testing.assert_array_equal(ds.base_acceleration.values, ag)
    np.testing.assert_allclose(ds.crack_displacement, a1 * ds.theta_lower, rtol=1e-12,
                               atol=1e-15)
    np.testing.assert_allclose(ds.top_displacement,
                               ds.crack_displacement + a2 * ds.theta_upper, rtol=1e-12,
                               atol=1e-15)
    # continuous-time peaks bound the grid values (and exceed them here)
    for peak, hist in (("peak_top_displacement", "top_displacement"),
                       ("peak_crack_displacement", "crack_displacement"),
                       ("peak_top_acceleration", "top_acceleration")):
        assert float(ds[peak]) >= float(np.abs(ds[hist]).max())
    assert float(ds.peak_top_displacement) > float(np.abs(ds.top_displacement).max())


def test_netcdf_round_trip(response, tmp_path):
    path = write_netcdf(response, tmp_path / "run.nc")
    assert path.is_file() and not list(tmp_path.glob(".*.tmp"))
    with xr.open_dataset(path) as back:
        back.load()
    xr.testing.assert_identical(back, response)
    assert back.pattern.dtype.kind == "i" and back.collapsed.dtype.kind == "i"


def test_reference_method_agrees(first5s, wall):
    ag = first5s[:126]  # 2.5 s keeps the scipy run short
    exact = urmx.simulate(wall, ag, DT, scale=0.5)
    ref = urmx.simulate(wall, ag, DT, scale=0.5, method="reference")
    assert ref.attrs["method"] == "reference" and ref.attrs["rtol"] == 1e-10
    assert "rtol" not in exact.attrs
    for name in SCALARS:
        if name in INTEGER_SCALARS:
            assert int(ref[name]) == int(exact[name]), name
        elif name != "collapse_time":
            assert float(ref[name]) == pytest.approx(float(exact[name]), rel=1e-6,
                                                     abs=1e-12), name
    assert float(exact.peak_crack_displacement) == pytest.approx(0.018173346475496947,
                                                                  rel=1e-8)


def test_collapse(first5s, wall):
    ds = urmx.simulate(wall, first5s, DT, scale=3.0, history=True)
    assert ds.attrs["status"] == "collapsed" and int(ds.collapsed) == 1
    t = float(ds.collapse_time)
    assert t == pytest.approx(3.031617891697535, abs=1e-9)
    assert ds.attrs["duration"] == pytest.approx(t, abs=1e-12)
    assert float(ds.instability_ratio) == 1.0
    after = ds.time.values > t
    assert (ds.pattern.values[after] == 0).all()
    assert np.isnan(ds.top_displacement.values[after]).all()
    below = urmx.simulate(wall, first5s, DT, scale=2.0)
    assert int(below.collapsed) == 0 and float(below.instability_ratio) < 0.6


def test_trace_input(elcentro, first5s, wall):
    tr = elcentro.copy()
    tr.data = first5s.copy()
    a = urmx.simulate(wall, tr, scale=0.5)
    b = urmx.simulate(wall, first5s, DT, scale=0.5)
    xr.testing.assert_identical(a.drop_attrs() if hasattr(a, "drop_attrs") else a,
                                b.drop_attrs() if hasattr(b, "drop_attrs") else b)
    assert urmx.simulate(wall, tr, DT, scale=0.5).attrs["dt"] == DT
    with pytest.raises(ValueError, match="differs from the trace's stats.delta"):
        urmx.simulate(wall, tr, 0.01)
    tr.stats.units = "cm/s2"
    with pytest.raises(ValueError, match="must be in m/s2"):
        urmx.simulate(wall, tr)


def test_public_name_is_the_function(first5s, wall):
    import urmx.simulation  # importing the module must not shadow urmx.simulate
    from urmx.simulation import simulate

    assert urmx.simulate is simulate
    xr.testing.assert_identical(urmx.simulate(wall, first5s[:20], DT),
                                simulate(wall, first5s[:20], DT))


@pytest.mark.parametrize("kwargs, message", [
    (dict(dt=0.0), r"dt=0.0 must be a positive"),
    (dict(dt=-0.02), r"dt=-0.02 must be a positive"),
    (dict(cor=0.0), r"cor=0.0 must lie in \(0, 1\]"),
    (dict(cor=1.2), r"cor=1.2 must lie in \(0, 1\]"),
    (dict(impact="newton"), r"impact='newton' is not an impact law"),
    (dict(method="rk4"), r"method='rk4' is not a method"),
    (dict(rtol=1e-8), r"rtol applies to method='reference' only"),
    (dict(method="reference", rtol=2.0), r"rtol=2.0 must lie in \(0, 1\)"),
    (dict(tail=-1.0), r"tail=-1.0 must be a non-negative"),
    (dict(dt=None), r"dt is required"),
])
def test_bad_arguments(first5s, kwargs, message, wall):
    kwargs = {"dt": DT, **kwargs}
    dt = kwargs.pop("dt")
    with pytest.raises(ValueError, match=message):
        urmx.simulate(wall, first5s[:20], dt, **kwargs)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_samples(first5s, bad, wall):
    ag = first5s[:20].copy()
    ag[7] = bad
    with pytest.raises(ValueError, match=r"1 NaN/inf sample\(s\), the first at index 7 "
                                         r"\(t = 0.14 s\)"):
        urmx.simulate(wall, ag, DT)


# ---- wall files -----------------------------------------------------------------------
def test_example_walls(wall):
    assert read_wall(EXAMPLES / "benchmark-wall.toml") == wall
    w12, west, c9 = (read_wall(EXAMPLES / f) for f in ("wall12.toml", "west-wall.toml",
                                                       "c9.toml"))
    assert w12.bottom_rigid and w12.top_rigid and w12.pmr == 72.0
    assert west.bottom_rigid and west.top_stiffness == 5.5e5 and west.top_mass == 780.0
    assert (c9.bottom_stiffness, c9.top_stiffness) == (39.4e3, 37e3)
    assert (c9.bottom_mass, c9.top_mass, c9.bottom_damping) == (655.0, 663.0, 0.12)
    assert c9.segment(3).M0 == pytest.approx(782.012, rel=1e-5)


def test_wall_top_level_keys(tmp_path):
    path = tmp_path / "w.toml"
    path.write_text("thickness = 0.11\nheight = 1.5\ncrack_ratio = 0.5\nmass = 297\n")
    assert read_wall(path) == Wall(thickness=0.11, height=1.5, crack_ratio=0.5, mass=297.0)


@pytest.mark.parametrize("text, message", [
    ("[wall]\nthickness = 0.1\nheight = 1.5\ncrack_ratio = 0.5\nmass = 297\nhieght = 2\n",
     "unknown wall key 'hieght'"),
    ("[wall]\nthickness = -0.1\nheight = 1.5\ncrack_ratio = 0.5\nmass = 297\n",
     "thickness=-0.1 must be greater than zero"),
    ("[wall]\nthickness = 0.1\nheight = 1.5\ncrack_ratio = 0.5\n", "missing"),
    ("[wall]\nthickness = 0.1\nheight = 1.5\ncrack_ratio = 0.5\nmass = 297\n"
     "top_stiffness = \"soft\"\n", "top_stiffness='soft' is not valid"),
    ("[wall]\nthickness = 0.1\n[other]\n", "unknown key(s) other beside the [wall] table"),
    ("thickness = = 1\n", "not valid TOML"),
])
def test_bad_wall_files(tmp_path, text, message):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ValueError) as err:
        read_wall(path)
    assert re.match(rf"{re.escape(str(path))}(:\d+)?: ", str(err.value))  # file (and line)
    assert message in str(err.value)


# ---- the command line -----------------------------------------------------------------
@pytest.fixture(scope="module")
def record5s(first5s, tmp_path_factory):
    """El Centro 0-5 s as a one-column file in m/s2 (needs --dt and --unit)."""
    path = tmp_path_factory.mktemp("rec") / "elcentro5s.txt"
    np.savetxt(path, first5s, fmt="%.17g")
    return path


def test_cli_table(capsys, record5s):
    rc = main(["simulate", str(EXAMPLES / "benchmark-wall.toml"), str(record5s), "--dt", "0.02",
               "--unit", "m/s2", "--scale", "0.5", "--tail", "1"])
    out, err = capsys.readouterr()
    assert rc == 0 and err == ""
    lines = out.splitlines()
    assert "status ok  analysed 6 s" in lines[1]
    rows = {line.split()[0]: line.split()[1:] for line in lines[2:]}
    assert list(rows) == list(SCALARS)
    assert rows["peak_top_displacement"] == ["0.0237416", "m"]
    assert rows["peak_top_acceleration"] == ["1.67729", "m", "s-2"]
    assert rows["crack_impacts"] == ["39", "1"]
    assert rows["collapse_time"] == ["nan", "s"]
    assert len({line.index(" m") for line in lines[2:5]}) == 1  # aligned unit column


def test_cli_closed_pipe_ends_quietly(record5s):
    """`urmx simulate ... | head -2`: the reader is gone before the table is printed; the
    command ends with 141 (128 + SIGPIPE) and no traceback (it used to print one)."""
    import subprocess
    import sys

    proc = subprocess.Popen(
        [sys.executable, "-m", "urmx.cli", "simulate", str(EXAMPLES / "benchmark-wall.toml"),
         str(record5s), "--dt", "0.02", "--unit", "m/s2"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader goes away before anything is written
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=300) == 141
    assert "Traceback" not in err and "BrokenPipe" not in err, err


def test_cli_out_and_plot(capsys, record5s, tmp_path, first5s, wall):
    nc, png = tmp_path / "run.nc", tmp_path / "run.png"
    rc = main(["simulate", str(EXAMPLES / "benchmark-wall.toml"), str(record5s), "--dt", "0.02",
               "--unit", "m/s2", "--scale", "3", "--cor", "0.7", "--impact", "contact",
               "--out", str(nc), "--plot", str(png)])
    out, _ = capsys.readouterr()
    assert rc == 0 and f"wrote {nc}" in out and f"wrote {png}" in out
    with xr.open_dataset(nc) as ds:
        ds.load()
    expected = urmx.simulate(wall, first5s, DT, scale=3.0, cor=0.7, impact="contact",
                             history=True)
    xr.testing.assert_allclose(ds, expected, rtol=1e-12)
    assert ds.attrs["impact"] == "contact" and ds.attrs["status"] == expected.attrs["status"]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000


def test_plot_simulation_artists(response):
    from urmx.plot import plot_simulation

    ax1, ax2 = plot_simulation(response)
    assert ax1.figure is ax2.figure and len(ax1.figure.axes) == 2
    assert [ln.get_label() for ln in ax1.lines] == [
        "displacement at wall top", "displacement at crack height", "base displacement"]
    assert len(ax2.lines) == 1 and ax2.get_xlabel() == "time [s]"
    assert [t.get_text() for t in ax2.get_yticklabels()] == ["0", "11", "12", "21", "22"]


def test_cli_manifest_record(capsys, monkeypatch, records_dir):
    monkeypatch.setenv("URMX_RECORDS", str(records_dir))
    rc = main(["simulate", str(EXAMPLES / "benchmark-wall.toml"), "elcentro", "--scale", "0.5"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    assert "record elcentro (dt 0.02 s, 2688 points)" in out
    assert re.search(r"\n  peak_top_displacement +0\.0237416  m\n", out)
    assert re.search(r"\n  base_impacts +162  1\n", out)


@pytest.mark.parametrize("argv, message", [
    (["missing.toml", "REC"], "wall file 'missing.toml' does not exist"),
    (["WALL", "no/such/record.txt"], "is neither a file nor a manifest record id"),
    (["BAD", "REC"], "unknown wall key 'colour'"),
    (["WALL", "REC", "--cor", "1.5"], "cor=1.5 must lie in (0, 1]"),
    (["WALL", "REC", "--dt", "-1"], "dt must be a positive number"),
])
def test_cli_errors_one_line(capsys, tmp_path, record5s, argv, message):
    bad = tmp_path / "bad.toml"
    bad.write_text("[wall]\nthickness = 0.1\nheight = 1.5\ncrack_ratio = 0.5\nmass = 297\n"
                   "colour = \"red\"\n")
    subst = {"WALL": str(EXAMPLES / "wall12.toml"), "BAD": str(bad), "REC": str(record5s)}
    argv = [subst.get(a, a) for a in argv]
    if "--dt" not in argv and argv[1] == str(record5s):
        argv += ["--dt", "0.02", "--unit", "m/s2"]
    rc = main(["simulate", *argv])
    out, err = capsys.readouterr()
    assert rc == 2
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert err.startswith("urmx simulate: error: ") and message in err
    if argv[0] == str(bad):
        assert str(bad) in err


# ---- t_rest, the rest time of held joints (issue 32) ----------------------------------

def test_simulate_passes_and_records_t_rest():
    case = c9_chatter()
    ds = urmx.simulate(case.pop("wall"), case.pop("ground_acceleration"), case.pop("dt"),
                       t_rest=0.02, **case)
    assert ds.attrs["t_rest"] == 0.02 and "t_rest=0.02" in ds.attrs["history"]
    assert int(ds["crack_impacts"]) == 130
