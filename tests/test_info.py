"""A look at real archives (made here with the real kernel on small studies): ``urmx info``
(kind, sizes, cell counts, provenance), ``urmx diff`` (exit 0 / 1 / 2), the generic ``urmx
report`` of a user's own study, and ``urmx fragility-report`` on archives of one and two
walls."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

import urmx
from urmx import jitcache
from urmx.cli import main
from urmx.markdown import number
from urmx.model import PAPER_G
from urmx.provenance import code_version
from urmx.reports import grid as generic_report
from urmx.reports import ida as fragility_report
from urmx.study.summary import diff, format_info, info

GRID = """\
[study]
name = "tiny"
title = "Two walls under two records"
walls = ["s12", "s20"]
diaphragms = ["D1"]
supports = "top"
records = ["elcentro", "bigbear"]
cor = [0.75, 0.85]

[study.pairs]          # s20 is not run under bigbear: 2 cells not-run
s12 = ["elcentro", "bigbear"]
s20 = ["elcentro"]
"""

IDA = """\
[study]
name = "tiny-ida"
walls = ["s12", "s20"]
diaphragms = ["D1"]
supports = "top"
records = ["elcentro", "p695-01-mul009"]
cor = [0.8]

[study.ida]
im = "pga"
rtol = 1e-2
"""


def _run(tmp, name: str, text: str, records_dir) -> str:
    path = tmp / f"{name}.toml"
    path.write_text(text, encoding="utf-8")
    out = tmp / f"{name}.nc"
    urmx.run_study(path, out=out, scheduler="serial", progress=False, records_dir=records_dir,
                   command=f"urmx run {name}.toml --out {name}.nc")
    return str(out)


@pytest.fixture(scope="module")
def grid(tmp_path_factory, records_dir) -> str:
    """A grid archive of 8 cells (2 not run), computed by the kernel."""
    return _run(tmp_path_factory.mktemp("grid"), "tiny", GRID, records_dir)


@pytest.fixture(scope="module")
def ida(tmp_path_factory, records_dir) -> str:
    """An IDA archive of two walls, one diaphragm, two records (4 capacities)."""
    return _run(tmp_path_factory.mktemp("ida"), "tiny-ida", IDA, records_dir)


def test_info_of_a_grid_archive(grid, capsys):
    found = info(grid)
    with xr.open_dataset(grid) as ds:
        status = ds.status.values.ravel().tolist()
        ratio = ds.instability_ratio.sel(wall="s12", record="bigbear", cor=0.85).item()
    assert found["kind"] == "grid" and found["study_name"] == "tiny"
    assert found["dims"] == {"wall": 2, "diaphragm": 1, "record": 2, "cor": 2}
    assert found["total_cells"] == 8 and found["cells"]["not-run"] == 2
    assert found["cells"] == {name: status.count(code) for code, name in
                              enumerate(("ok", "collapsed", "event-limit", "not-run"))}
    assert found["cells"]["ok"] + found["cells"]["collapsed"] == 6
    assert found["file_size"] > 10_000
    assert found["attrs"]["urmx_version"] == code_version()
    assert found["attrs"]["kernel_source_hash"] == jitcache.SOURCE_HASH
    assert 'records = ["elcentro", "bigbear"]' in found["attrs"]["study"]
    assert found["items"]["wall"]["slenderness"] == pytest.approx([12.0, 20.0])
    assert found["items"]["record"]["record"] == ["elcentro", "bigbear"]
    assert found["variables"]["peak_top_displacement"]["units"] == "m"
    assert np.isfinite(ratio)

    assert main(["info", grid]) == 0
    text = capsys.readouterr().out
    assert f"{grid}: grid archive of study 'tiny'" in text
    assert "dimensions: wall 2, diaphragm 1, record 2, cor 2" in text
    assert (f"cells: 8 (ok {found['cells']['ok']}, collapsed {found['cells']['collapsed']}, "
            "event-limit 0, not-run 2)") in text
    assert f"urmx_version: {code_version()}" in text and "    | [study.pairs]" in text
    assert "history: " in text and "urmx run tiny.toml --out tiny.nc" in text
    assert text.strip() == format_info(found)
    assert main(["info", grid, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["cells"] == found["cells"]


def test_info_of_an_ida_archive_and_of_one_analysis(ida, tmp_path, records_dir):
    found = info(ida)
    with xr.open_dataset(ida) as ds:
        censored = ds.censored.values
    assert found["kind"] == "ida" and found["total_cells"] == 4
    assert found["cells"] == {"collapsed": int((censored == 0).sum()),
                              "censored": int((censored == 1).sum()), "missing": 0}
    assert found["attrs"]["intensity_measure"] == "pga"
    one = tmp_path / "run.nc"
    assert main(["simulate", str(urmx.config.data_dir("catalog") / "examples" /
                                 "benchmark-wall.toml"), "elcentro", "--records",
                 str(records_dir), "--out", str(one)]) == 0
    found = info(one)
    assert found["kind"] is None and found["cells"] == {} and "time" in found["dims"]
    assert "no study" in format_info(found)


def test_info_errors_are_one_line(tmp_path, capsys):
    assert main(["info", str(tmp_path / "nope.nc")]) == 2
    assert "no archive" in capsys.readouterr().err
    bad = tmp_path / "bad.nc"
    bad.write_text("not netCDF")
    assert main(["info", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "is not a readable archive" in err and len(err.strip().splitlines()) == 1


def test_diff_exit_status_and_what_it_lists(grid, tmp_path, capsys):
    assert main(["diff", grid, grid]) == 0
    assert "no differences beyond the tolerance" in capsys.readouterr().out
    with xr.open_dataset(grid) as ds:
        ds = ds.load()
    # one cell changed by 1e-6 relative: beyond the default rtol 1e-9, within 1e-3
    changed = ds.copy(deep=True)
    cell = dict(wall="s20", diaphragm="D1", record="elcentro", cor=0.75)
    old = float(changed.peak_top_displacement.sel(cell))
    changed["peak_top_displacement"].loc[cell] = old * (1 + 1e-6)
    changed.attrs["urmx_version"] = "9.9"
    b = tmp_path / "b.nc"
    changed.to_netcdf(b)
    assert main(["diff", grid, str(b)]) == 1
    out = capsys.readouterr().out
    assert "peak_top_displacement: 1 of 8 cells differ" in out
    assert f"  wall=s20 diaphragm=D1 record=elcentro cor=0.75: A {number(old, 6)}" in out
    assert "attributes that differ (not compared): urmx_version" in out
    assert out.strip().endswith("differ: 1 variable")
    assert main(["diff", grid, str(b), "--rtol", "1e-3"]) == 0
    capsys.readouterr()
    found = diff(grid, b)
    assert found["differ"] and [v["name"] for v in found["variables"]] == \
        ["peak_top_displacement"]
    assert found["variables"][0]["max_rel"] == pytest.approx(1e-6 / (1 + 1e-6), rel=1e-3)
    # a record less, and a variable less: dimensions and names in one archive only
    smaller = ds.isel(record=[0]).drop_vars("collapse_time")
    c = tmp_path / "c.nc"
    smaller.to_netcdf(c)
    assert main(["diff", grid, str(c)]) == 1
    out = capsys.readouterr().out
    assert "dimension record: only in A [bigbear], only in B []" in out
    assert "only in A: collapse_time" in out
    assert "peak_top_displacement" not in out  # the common cells are equal


def test_diff_errors_exit_2(grid, tmp_path, capsys):
    assert main(["diff", grid, str(tmp_path / "nope.nc")]) == 2
    assert "no archive" in capsys.readouterr().err
    assert main(["diff", grid, grid, "--rtol", "-1"]) == 2
    assert "rtol=-1.0" in capsys.readouterr().err


def test_generic_report_of_an_own_study(grid, tmp_path, capsys, monkeypatch):
    out = tmp_path / "rep"
    assert main(["report", grid, "--out", str(out)]) == 0
    assert capsys.readouterr().out.strip() == str(out / "REPORT.md")
    text = (out / "REPORT.md").read_text()
    assert text.startswith("# Study `tiny`")
    assert "- cells: 8 (" in text and "not-run 2)" in text
    assert "## governing instability ratio (`instability_ratio`)" in text
    with xr.open_dataset(grid) as ds:
        main_outputs = generic_report.main_outputs(ds)
        r = ds.instability_ratio.sel(wall="s12", diaphragm="D1", record="bigbear").values
        top = 1e3 * ds.peak_top_displacement.sel(wall="s12", diaphragm="D1",
                                                 record="elcentro").values
    assert main_outputs[:2] == ["instability_ratio", "collapsed"]
    for name in main_outputs:
        assert (out / f"{name}.png").stat().st_size > 5000, name
        assert f"]({name}.png)" in text
    ratio = text.split("(`instability_ratio`)")[1].split("## ")[0]
    assert "| wall | record | cor 0.75 | cor 0.85 |" in ratio and "at diaphragm D1" in ratio
    assert f"| s12 | bigbear | {number(r[0], 4)} | {number(r[1], 4)} |" in ratio
    assert "| s20 | bigbear | - | - |" in ratio  # not run
    shown = text.split("(`peak_top_displacement`)")[1].split("## ")[0]
    assert "In mm at diaphragm D1" in shown
    assert f"| s12 | elcentro | {number(top[0], 4)} | {number(top[1], 4)} |" in shown
    assert "| `urmx_version` |" in text and "```toml" in text
    assert "not a study kind this report uses" not in text
    # without --out: reports/<file name> in the current folder
    monkeypatch.chdir(tmp_path)
    assert main(["report", grid]) == 0
    assert (tmp_path / "reports" / "tiny" / "REPORT.md").is_file()


def test_fragility_report_of_one_and_two_walls(ida, tmp_path):
    ds = urmx.open_study(ida).load()
    for walls in (["s12"], ["s12", "s20"]):
        out = tmp_path / str(len(walls))
        path = fragility_report.write_report(ds.sel(wall=walls), out)
        text = path.read_text()
        assert f"the archive has {len(walls)}" in text
        assert "- **Slenderness.** Left out: it needs at least 3 walls" in text
        assert "- **Stiffening.** Left out: it needs diaphragms D1 and D4" in text
        for name in ("ida_D1.png", "fragility_curves.png"):
            assert (out / name).stat().st_size > 5000
        median = float(ds.median_collapse_intensity.sel(wall="s12", diaphragm="D1", cor=0.8))
        assert f"| s12 | 12 | {number(median / PAPER_G)} (" in text  # in g
    # the command line as well, on the archive of two walls
    assert main(["fragility-report", ida, "--out", str(tmp_path / "cli")]) == 0


def test_urmx_report_chooses_the_report_by_the_archives_kind(ida, grid, tmp_path, capsys):
    """`urmx report` writes an IDA archive's fragility report (the one `urmx fragility-report`
    wrote, which stays as an alias saying what replaced it) and a grid archive's generic
    report; --hazard belongs to the IDA report only."""
    from urmx.reports import REPORTS, writer

    assert main(["report", ida, "--out", str(tmp_path / "new"), "--years", "30"]) == 0
    assert capsys.readouterr().err == ""
    assert main(["fragility-report", ida, "--out", str(tmp_path / "old"), "--years", "30"]) == 0
    assert capsys.readouterr().err.strip() == ("urmx fragility-report: replaced by `urmx "
                                               "report` (this alias goes in the next release)")
    new = (tmp_path / "new" / "REPORT.md").read_text()
    assert new == (tmp_path / "old" / "REPORT.md").read_text()
    assert new.startswith("# Collapse fragility") and "probability of collapse in 30 years" in new
    with xr.open_dataset(ida) as a, xr.open_dataset(grid) as g:
        assert writer(a) is REPORTS["ida"] is fragility_report.write_report
        assert writer(g) is REPORTS["grid"] is generic_report.write_report
    code = main(["report", grid, "--out", str(tmp_path / "g"), "--hazard", "x.csv"])
    assert code == 2 and "--hazard does not apply to the report of a grid archive" in \
        capsys.readouterr().err
