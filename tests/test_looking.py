"""Looking at one's own results (issue 39): reports of small studies (no empty axes, no
statistic below `urmx.reporting.MIN_RECORDS`), collapsed cells never averaged with
survivors, every wall's own supports in ``urmx info``, ``urmx export``, ``urmx show``,
the catalog by name and an archive's history of every contributing run."""

from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

import urmx
from urmx.analysis.recompute import compare, compared, recompute
from urmx.cli import main
from urmx.errors import InputError
from urmx.plot import empty_axes, instability_history, panels, wall_of
from urmx.reports import common as reporting
from urmx.reports import grid as generic_report
from urmx.study.table import to_dataframe

RECORDS = """
[records.r0]
file = "r0.txt"
dt = 0.01
unit = "g"
[records.r1]
file = "r1.txt"
dt = 0.01
unit = "g"
[records.r2]
file = "r2.txt"
dt = 0.01
unit = "g"
"""

GRID = """[study]
name = "t-grid"
walls = ["s16", "s24"]
diaphragms = ["D1"]
records = ["r0", "r1", "r2"]
cor = [0.6, 0.8]
scale = [1.0, 2.0]
""" + RECORDS

IDA = """[study]
name = "t-ida"
walls = ["tall"]
diaphragms = ["specimen"]
supports = "specimen"
records = ["r0", "r1", "r2"]
cor = [0.8]

[study.ida]
im = "pga"

[walls.tall]
thickness = 0.23
height = 3.6
crack_ratio = 0.667
mass = 9000.0
top_stiffness = 1.5e6
top_mass = 8000.0
top_damping = 0.12
""" + RECORDS


def _records(folder) -> None:
    """Three short synthetic pulses (g), plain numbers at 0.01 s."""
    t = np.arange(0.0, 8.0, 0.01)
    for i, (f, a) in enumerate([(1.0, 0.25), (2.0, 0.3), (0.7, 0.2)]):
        np.savetxt(folder / f"r{i}.txt",
                   a * np.sin(2 * np.pi * f * t) * np.exp(-(((t - 3.0) / 1.5) ** 2)))


@pytest.fixture(scope="module")
def grid(tmp_path_factory):
    """A 2-wall grid archive with collapsed cells (14 of 24), on own record files."""
    folder = tmp_path_factory.mktemp("grid")
    _records(folder)
    (folder / "grid.toml").write_text(GRID, encoding="utf-8")
    out = folder / "grid.nc"
    urmx.run_study(folder / "grid.toml", out=out, scheduler="serial", progress=False)
    return out


@pytest.fixture(scope="module")
def ida(tmp_path_factory):
    """A 1-wall (own diaphragm), 1-diaphragm, 3-record IDA archive."""
    folder = tmp_path_factory.mktemp("ida")
    _records(folder)
    (folder / "ida.toml").write_text(IDA, encoding="utf-8")
    out = folder / "ida.nc"
    urmx.run_study(folder / "ida.toml", out=out, scheduler="serial", progress=False)
    return out


@pytest.fixture
def saved(monkeypatch):
    """Every figure a report saves, with its empty axes counted before it is written."""
    found: list[tuple[str, int, int]] = []
    original = Figure.savefig

    def savefig(self, fname, *args, **kwargs):
        found.append((str(getattr(fname, "name", fname)), len(self.axes),
                      len(empty_axes(self))))
        return original(self, fname, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return found


# ---- the checks themselves fail on bad data -------------------------------------------------

def test_empty_axes_are_found_and_panels_leave_none():
    fig = Figure()
    axes = fig.subplots(1, 3)
    axes[0].plot([0, 1], [0, 1])
    axes[1].plot([], [])  # an empty line draws nothing
    assert len(empty_axes(fig)) == 2  # what the old 3-column layout did for one group
    one = panels(None, 1, ncols=3)
    assert len(one[0].figure.axes) == 1
    two = panels(None, 2, ncols=3)
    assert len(two[0].figure.axes) == 2
    five = panels(None, 5, ncols=3)  # a 2 x 3 grid with its sixth place removed
    assert len(five[0].figure.axes) == 5


def test_percentages_ratios_and_degenerate_intervals():
    assert reporting.pct(0.022**2 / 0.34**2) == "0.42 %"  # the "0 %"
    assert reporting.pct(0.123) == "12 %"
    assert reporting.ratio(0.1234) == "0.12"

    def fmt(v):
        return f"{v:.2g}"

    assert reporting.interval(3.4e-5, 3.4e-5, 7.1e-5, fmt).endswith(reporting.DEGENERATE)
    assert reporting.interval(3.4e-5, 2.0e-5, 7.1e-5, fmt) == "[2e-05-7.1e-05]"
    assert reporting.interval(1.0, np.nan, np.nan, fmt) == "[no interval]"


# ---- reports of small studies ----------------------------------------------------------------

def test_small_ida_reports_state_nothing_below_the_minimum(ida, tmp_path, saved, capsys):
    from urmx.reports.ida import write_report

    report = write_report(ida, tmp_path / "frag").read_text(encoding="utf-8")
    assert saved and all(n_empty == 0 for _, _, n_empty in saved), saved
    # one wall on one diaphragm: one panel in the IDA curves and in the fragility curves
    # (saved first and second), not one drawn and two empty
    assert [n for _, n, _ in saved[:2]] == [1, 1]
    assert reporting.MIN_RECORDS > 3
    assert "recommends" not in report and "Not ranked" in report
    assert "needs at least 10 records per wall and diaphragm" in report
    assert "this archive has 3" in report
    assert "[---]" not in report and "[-" not in report.replace("[-]", "")
    assert "runs from" not in report  # no range over one diaphragm
    assert main(["risk", str(ida), "--hazard", str(urmx.config.data_dir() / "hazard" /
                                                    "illustrative-pga-hazard.csv")]) == 0
    risk = capsys.readouterr().out
    assert "no interval" in risk and not re.search(r"\d \[\d", risk)


def test_grid_report_leaves_collapsed_cells_out_of_means(grid, tmp_path, saved):
    ds = urmx.open_study(grid).load()
    gone = ds.collapsed == 1
    assert 0 < int(gone.sum()) < gone.size
    report = generic_report.write_report(grid, tmp_path / "rep").read_text(encoding="utf-8")
    assert saved and all(n_empty == 0 for _, _, n_empty in saved), saved
    n = int(gone.sum())
    assert f"{n} of {gone.size} cells collapsed" in report
    section = report.split("(`peak_top_displacement`)")[1].split("\n## ")[0]
    assert section.count("| collapsed |") + section.count("| collapsed\n") >= 1
    # the figure's line is the mean over the survivors, by hand
    shown = urmx.plot.in_display_units(ds.peak_top_displacement)
    ax = generic_report.plot_output(shown.where(~gone), gone=n)
    x, hue, rest = generic_report._axes_dims(shown)
    assert x == "cor" and ax.get_xlabel() == "coefficient of restitution [1]"
    assert f"({n} collapsed, left out)" in ax.get_title().replace("\n", " ")
    survivors = shown.where(~gone).mean(rest).squeeze(drop=True)
    averaged = shown.mean(rest).squeeze(drop=True)  # what the report used to draw
    for j, line in enumerate(ax.lines):
        y = survivors.isel({hue: j}).transpose(x).values
        np.testing.assert_array_equal(line.get_ydata(), y)
        assert not np.array_equal(np.nan_to_num(line.get_ydata()),
                                  np.nan_to_num(averaged.isel({hue: j}).transpose(x).values)
                                  ) or not bool(gone.isel({hue: j}).any())


# ---- urmx info: every wall's supports --------------------------------------------------------

def test_info_shows_own_supports(ida, capsys):
    found = urmx.study.info(ida)
    cells = found["items"]["wall, diaphragm"]
    assert cells["wall"] == ["tall"] and cells["diaphragm"] == ["specimen"]
    assert cells["cell_stiffness"] == [1.5e6] and cells["cell_diaphragm_mass"] == [8000.0]
    assert cells["cell_diaphragm_damping"] == [0.12]
    k, m, mw = 1.5e6, 8000.0, 9000.0  # Table IV SDOF: k over md + mw / 2
    assert cells["cell_frequency"][0] == pytest.approx(np.sqrt(k / (m + mw / 2)) / 2 / np.pi)
    assert main(["info", str(ida)]) == 0
    text = capsys.readouterr().out
    assert "nan | nan" not in text and "cell_stiffness" in text


# ---- urmx export -----------------------------------------------------------------------------

def test_export_round_trip(grid, tmp_path):
    out = tmp_path / "cells.csv"
    assert main(["export", str(grid), "--format", "csv", "--out", str(out)]) == 0
    back = pd.read_csv(out)
    table = urmx.study.to_dataframe(urmx.open_study(grid))
    pd.testing.assert_frame_equal(back, table, check_dtype=False)
    pd.testing.assert_frame_equal(table, to_dataframe(grid))
    assert len(table) == 2 * 1 * 3 * 2 * 2  # one row per cell
    assert "peak_top_displacement [m]" in back.columns and "cor [1]" in back.columns
    assert set(back["status"]) <= {"ok", "collapsed", "event_limit", "not_run"}
    ds = urmx.open_study(grid).load()
    assert (back["status"] == "collapsed").sum() == int((ds.collapsed == 1).sum())
    # the same numbers as xarray's own table of the archive
    native = ds[["peak_top_displacement"]].to_dataframe().reset_index()
    np.testing.assert_array_equal(back["peak_top_displacement [m]"].values,
                                  native["peak_top_displacement"].values)
    some = tmp_path / "some.csv"
    assert main(["export", str(grid), "--out", str(some), "--where", "wall=s24,record=r1"]) == 0
    part = pd.read_csv(some)
    assert len(part) == 4 and set(part.wall) == {"s24"} and set(part.record) == {"r1"}
    assert main(["export", str(grid), "--where", "wall=s99"]) == 2


def test_export_parquet_needs_pyarrow(grid, tmp_path, monkeypatch, capsys):
    import builtins

    real = builtins.__import__

    def no_pyarrow(name, *args, **kwargs):
        if name.startswith("pyarrow"):
            raise ImportError(name)
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pyarrow)
    assert main(["export", str(grid), "--format", "parquet",
                 "--out", str(tmp_path / "x.parquet")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "pip install 'urmx[parquet]'" in err[0]


def test_export_parquet(grid, tmp_path):
    pq = pytest.importorskip("pyarrow.parquet")
    out = tmp_path / "cells.parquet"
    assert main(["export", str(grid), "--format", "parquet", "--out", str(out)]) == 0
    back = pd.read_parquet(out)
    pd.testing.assert_frame_equal(back, to_dataframe(grid), check_dtype=False)
    field = pq.read_schema(out).field("peak_top_displacement [m]")
    assert field.metadata[b"units"] == b"m"


# ---- urmx show -------------------------------------------------------------------------------

def test_show_reproduces_the_archive_and_refuses_a_changed_record(grid, tmp_path):
    ds = urmx.open_study(grid).load()
    for cell in ({"wall": "s24", "record": "r1", "cor": 0.8, "scale": 2.0},
                 {"wall": "s16", "record": "r0", "cor": 0.6, "scale": 1.0}):
        sim, labels = recompute(grid, cell["wall"], "D1", cell["record"], cor=cell["cor"],
                                scale=cell["scale"])
        assert compared(grid, labels) == 17 and compare(grid, labels, sim) == {}
        stored = ds.sel(diaphragm="D1", **cell)
        for name in ("peak_top_displacement", "instability_ratio", "collapsed"):
            assert np.float64(sim[name]).tobytes() == np.float64(stored[name]).tobytes()
        assert "time" in sim.dims and "top_displacement" in sim
        # the drawn instability ratio over time: its peak on the record grid is at most
        # the kernel's exact peak (tracked between samples too), and close below it
        peak = float(instability_history(sim, wall_of(sim)).max())
        exact = float(sim["instability_ratio"])
        assert 0.9 * exact < peak <= exact * (1 + 1e-12)
    png, nc = tmp_path / "cell.png", tmp_path / "cell.nc"
    assert main(["show", str(grid), "--wall", "s24", "--diaphragm", "D1", "--record", "r1",
                 "--cor", "0.8", "--scale", "2", "--plot", str(png), "--out", str(nc)]) == 0
    assert png.stat().st_size > 10_000 and nc.is_file()
    assert main(["show", str(grid), "--wall", "s24", "--diaphragm", "D1",
                 "--record", "r1"]) == 2  # two CORs in the archive: name one
    with pytest.raises(InputError, match="no impact dimension"):
        recompute(grid, "s24", "D1", "r1", cor=0.8, scale=2.0, impact="contact")
    record = grid.parent / "r1.txt"
    kept = record.read_bytes()
    try:
        record.write_bytes(kept.replace(b"e-01", b"e-02", 1))
        with pytest.raises(InputError, match="SHA-256"):
            recompute(grid, "s24", "D1", "r1", cor=0.8, scale=2.0)
    finally:
        record.write_bytes(kept)


def test_show_refuses_another_kernel(grid, monkeypatch):
    import urmx.analysis.recompute as R

    monkeypatch.setattr(R, "SOURCE_HASH", "0" * 16)
    with pytest.raises(InputError, match="kernel"):
        recompute(grid, "s24", "D1", "r1", cor=0.8, scale=2.0)


# ---- the catalog by name; the run help; history ------------------------------------------------

def test_catalog_by_name(tmp_path, capsys, records_dir, monkeypatch):
    found = urmx.catalog.catalog_entries()
    assert "benchmark-wall" in dict(found["examples"])
    assert "verification" in dict(found["studies"])
    assert {"D1", "D5-pinned"} <= set(dict(found["diaphragms"]))
    assert {"wall12", "s16"} <= set(dict(found["walls"]))
    assert main(["catalog", "list"]) == 0
    assert "benchmark-wall" in capsys.readouterr().out
    monkeypatch.chdir(tmp_path)
    assert main(["catalog", "copy", "verification"]) == 0
    assert (tmp_path / "verification.toml").read_text(encoding="utf-8") == \
        (urmx.config.data_dir() / "studies" / "verification.toml").read_text(encoding="utf-8")
    assert main(["catalog", "copy", "verification"]) == 2  # never overwritten
    assert main(["catalog", "copy", "verifcation"]) == 2
    assert "did you mean verification" in capsys.readouterr().err
    assert urmx.config.data_dir() == urmx.config.data_dir("catalog")
    assert urmx.catalog.read_wall("benchmark-wall") == urmx.catalog.read_wall(
        urmx.config.data_dir() / "examples" / "benchmark-wall.toml")
    assert main(["simulate", "benchmark-wall", "elcentro", "--records", str(records_dir)]) == 0
    assert "status" in capsys.readouterr().out
    assert main(["simulate", "benchmark-wal", "elcentro"]) == 2


def test_run_help_states_the_default_scheduler(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "the active distributed.Client" in text and "under 10 s" in text
    assert "one per core" not in text.split("local cluster")[0]


def test_history_lists_every_contributing_run(tmp_path):
    _records(tmp_path)
    study = tmp_path / "grid.toml"
    study.write_text(GRID.replace('records = ["r0", "r1", "r2"]', 'records = ["r0", "r1"]')
                     .replace("[records.r2]\nfile = \"r2.txt\"\ndt = 0.01\nunit = \"g\"\n", ""),
                     encoding="utf-8")
    out = tmp_path / "g.nc"
    urmx.run_study(study, out=out, scheduler="serial", progress=False, command="first run")
    study.write_text(GRID, encoding="utf-8")
    urmx.run_study(study, out=out, scheduler="serial", progress=False, command="second run")
    lines = urmx.open_study(out).attrs["history"].splitlines()
    assert len(lines) == 2
    assert lines[0].endswith("second run") and lines[1].endswith("first run")
    urmx.run_study(study, out=tmp_path / "fresh.nc", scheduler="serial", progress=False,
                   command="alone")
    assert len(urmx.open_study(tmp_path / "fresh.nc").attrs["history"].splitlines()) == 1


def test_sensitivity_figure_says_negative_indices_are_noise():
    import xarray as xr

    from urmx.reports.sampling import _plot_sensitivity

    s1 = np.array([[[0.5, -0.26]]])  # wall, diaphragm, parameter
    sens = xr.Dataset({"prcc": (("wall", "diaphragm", "parameter"), s1 * 0.5),
                       "s1": (("wall", "diaphragm", "parameter"), s1)},
                      coords={"wall": ["s16"], "diaphragm": ["D1"],
                              "parameter": ["cor", "pmr"]})
    axes = _plot_sensitivity(sens, True)
    assert "estimator noise" in axes[1].get_title() and "-0.26" in axes[1].get_title()
    shown = axes[1].images[0].get_array()
    assert float(shown.min()) == 0.0  # coloured as 0, not off the 0-1 scale
    assert "-0.26" in [t.get_text() for t in axes[1].texts]  # the estimate still printed
    assert "noise" not in axes[0].get_title()


def test_one_record_ida_reports_draw_no_empty_axes(tmp_path, saved):
    """One wall under one record: no fit, no rate, no interval; every figure still says
    something in each panel and the report says why the numbers are missing."""
    from urmx.reports.ida import write_report

    _records(tmp_path)
    study = tmp_path / "one.toml"
    study.write_text(IDA.replace('records = ["r0", "r1", "r2"]', 'records = ["r0"]')
                     .split("\n[records.r1]")[0] + "\n", encoding="utf-8")
    out = tmp_path / "one.nc"
    urmx.run_study(study, out=out, scheduler="serial", progress=False)
    report = write_report(out, tmp_path / "frag").read_text(encoding="utf-8")
    generic_report.write_report(out, tmp_path / "generic")
    assert len(saved) >= 6 and all(n_empty == 0 for _, _, n_empty in saved), saved
    assert "No rate: no wall has a fitted fragility" in report
    assert "this archive has 1" in report and "recommends" not in report


def test_show_says_when_the_study_left_a_cell_out(tmp_path, capsys):
    _records(tmp_path)
    study = tmp_path / "pairs.toml"
    study.write_text(GRID.replace("scale = [1.0, 2.0]\n", "scale = [1.0, 2.0]\n\n"
                                  "[study.pairs]\ns16 = [\"r0\"]\ns24 = [\"r1\", \"r2\"]\n"),
                     encoding="utf-8")
    out = tmp_path / "pairs.nc"
    urmx.run_study(study, out=out, scheduler="serial", progress=False)
    args = ["show", str(out), "--diaphragm", "D1", "--cor", "0.6", "--scale", "1"]
    assert main([*args, "--wall", "s16", "--record", "r1"]) == 0
    assert "did not run this cell" in capsys.readouterr().out
    assert main([*args, "--wall", "s16", "--record", "r0"]) == 0
    assert "reproduced bit for bit" in capsys.readouterr().out


def test_at_the_minimum_the_statistics_are_stated(ida, tmp_path, monkeypatch):
    """With the minimum lowered to the archive's 3 records, the same report recommends a
    measure, with its share of records in two significant digits, and prints intervals
    (a degenerate one flagged and explained)."""
    from urmx.reports.ida import write_report

    monkeypatch.setattr(reporting, "MIN_RECORDS", 3)
    report = write_report(ida, tmp_path / "frag").read_text(encoding="utf-8")
    assert "urmx recommends `" in report and "Not ranked" not in report
    shares = re.findall(r"needs about ([0-9.e+-]+) % of the records", report)
    assert shares and all(len(s.replace(".", "").lstrip("0")) <= 2 for s in shares), shares
    assert "In brackets: the 90 % studentized bootstrap interval" in report
    if reporting.DEGENERATE in report:
        assert reporting.DEGENERATE_NOTE in report
