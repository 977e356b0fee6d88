"""Bad input, on the command line and through the API: each gives a clear error that names
the bad value, as a `urmx.UrmxError` (API) or one line on stderr and exit status 2 (CLI),
never a traceback. Nothing here computes an analysis: every check runs before the kernel.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import urmx
import urmx.records as R
from urmx import errors as E
from urmx import fragility as F
from urmx import paper as P
from urmx.catalog import CatalogError
from urmx.cli import main
from urmx.config import project_root, shipped_records
from urmx.config import records_dir as _records_dir
from urmx.reports import ida as FR
from urmx.study.file import load_study

from .helpers.synthetic import at2_text

WALL = "thickness = 0.23\nheight = 4.14\ncrack_ratio = 0.6667\nmass = 3000.0\n"
STUDY = ('[study]\nname = "bad"\nwalls = ["s18"]\ndiaphragms = ["D1"]\nrecords = ["{rec}"]\n'
         "cor = {cor}\n{extra}")


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("bad")
    out = {"tmp": d}

    def put(name, text, mode="w"):
        p = d / name
        (p.write_bytes if mode == "wb" else p.write_text)(text)
        out[name.split(".")[0]] = p

    put("at2.AT2", at2_text())
    put("at2_dt0.AT2", at2_text(dt=".0000"))
    put("at2_dtneg.AT2", at2_text(dt="-.0100"))
    put("plain.txt", "0.01\n0.02\n-0.01\n0.0\n")
    put("pickle.dat", b"cobspy.core.stream\nStream\n0(lp0\n.", "wb")
    put("empty.dat", "")
    put("textnc.nc", "not a netCDF file\n")
    put("afile.txt", "")
    put("wall.toml", WALL)
    put("wall_damp50.toml", WALL + "top_stiffness = 815e3\ntop_mass = 1000.0\n"
        "top_damping = 50\n")
    put("wall_crack.toml", WALL.replace("0.6667", "1.5"))
    put("wall_typo.toml", WALL.replace("height", "heigth"))
    put("wall_badtoml.toml", "thickness = = 0.23\n")
    put("wall_mm.toml", WALL.replace("0.23", "230"))
    put("study_damp50.toml", STUDY.format(rec="elcentro", cor="[0.8]", extra="")
        .replace('["s18"]', '["mine"]') + "\n[walls.mine]\nthickness = 0.23\nheight = 4.14\n"
        "crack_ratio = 0.6667\nmass = 3000.0\ntop_damping = 50\n")
    put("study_dampdim.toml", STUDY.format(rec="elcentro", cor="[0.8]", extra="damping = [50]\n"))
    put("study_diaph.toml", STUDY.format(rec="elcentro", cor="[0.8]", extra="")
        .replace('["D1"]', '["soft"]') + "\n[diaphragms.soft]\nstiffness = 1e6\ndamping = 12\n")
    put("study_cor.toml", STUDY.format(rec="elcentro", cor="[1.5]", extra=""))
    put("study_rec.toml", STUDY.format(rec="nope", cor="[0.8]", extra=""))
    put("study_one.toml", STUDY.format(rec="elcentro", cor="[0.8]", extra=""))
    put("study_ida_im.toml", STUDY.format(rec="elcentro", cor="[0.8]",
                                          extra='[study.ida]\nim = "sa"\n'))
    xr.Dataset({"x": ("x", [1.0])}).to_netcdf(d / "grid.nc")
    out["grid"] = d / "grid.nc"
    return out


def _argv(template: str, files: dict[str, Path]) -> list[str]:
    return [part.format(**{k: str(v) for k, v in files.items()}) for part in template.split()]


# (id, argv with {file} placeholders, text the error line must contain)
CLI = [
    ("records-dir-before", "records --records {tmp}/nope list", "nope"),
    ("records-dir-after", "records list --records {tmp}/nope", "nope"),
    ("records-dir-show", "records show elcentro --records {tmp}/nope", "nope"),
    ("records-set", "records list --set bogus", "'bogus'"),
    ("records-unit-missing", "records show {plain}", "plain.txt"),
    ("records-dt-missing", "records show {plain} --unit g", "--dt"),
    ("records-dt-negative", "records show {plain} --dt -1 --unit g", "-1.0"),
    ("records-header-dt0", "records show {at2_dt0}", "dt=0.0 s"),
    ("records-header-dt-neg", "records show {at2_dtneg}", "dt=-0.01 s"),
    ("records-pickle", "records show {pickle}", "pickle"),
    ("records-empty", "records show {empty}", "empty.dat: file is empty"),
    ("records-plot-out", "records plot {at2} --out {afile}/x.png", "afile.txt"),
    ("records-unit-choice", "records show {at2} --unit furlongs", "'furlongs'"),
    ("sim-cor-high", "simulate {wall} {at2} --cor 1.5", "cor=1.5"),
    ("sim-cor-zero", "simulate {wall} {at2} --cor 0", "cor=0.0"),
    ("sim-tail", "simulate {wall} {at2} --tail -1", "tail=-1.0"),
    ("sim-scale-nan", "simulate {wall} {at2} --scale nan", "scale=nan"),
    ("sim-scale-negative", "simulate {wall} {at2} --scale -1", "scale=-1.0 must be a positive"),
    ("sim-scale-zero", "simulate {wall} {at2} --scale 0", "scale=0.0 must be a positive"),
    ("sim-wall-millimetres", "simulate {wall_mm} {at2}", "thickness=230 m lies outside the "
     "plausible 0.02-2 m (in millimetres? 230 millimetres is 0.23 m)"),
    ("sim-record", "simulate {wall} nosuchrecord", "'nosuchrecord'"),
    ("sim-wall-missing", "simulate {tmp}/missing.toml {at2}", "missing.toml"),
    ("sim-damping-50", "simulate {wall_damp50} {at2}", "top_damping=50"),
    ("sim-crack", "simulate {wall_crack} {at2}", "crack_ratio=1.5"),
    ("sim-key-typo", "simulate {wall_typo} {at2}", "'heigth'"),
    ("sim-bad-toml", "simulate {wall_badtoml} {at2}", "wall_badtoml.toml: not valid TOML"),
    ("sim-out-folder", "simulate {wall} {at2} --out {tmp}", "is a folder"),
    ("sim-plot-under-file", "simulate {wall} {at2} --plot {afile}/x.png", "afile.txt"),
    ("sim-pickle", "simulate {wall} {pickle}", "pickle"),
    ("sim-dt-negative", "simulate {wall} {plain} --dt -1 --unit g", "-1.0"),
    ("sim-dt-contradicts", "simulate {wall} {at2} --dt 0.02", "dt=0.02"),
    ("run-out-folder", "run paper-single-storey --out {tmp}", "is a folder"),
    ("run-out-under-file", "run paper-single-storey --out {afile}/x.nc", "afile.txt"),
    ("run-batch-zero", "run paper-single-storey --out {tmp}/x.nc --batch-size 0", "'0'"),
    ("run-batch-negative", "run paper-single-storey --out {tmp}/x.nc --batch-size -3", "'-3'"),
    ("run-batch-word", "run paper-single-storey --out {tmp}/x.nc --batch-size two", "'two'"),
    ("run-scheduler", "run paper-single-storey --out {tmp}/x.nc --scheduler bogus", "'bogus'"),
    ("run-study-name", "run nosuchstudy --out {tmp}/x.nc", "'nosuchstudy'"),
    ("run-wall-damping-50", "run {study_damp50} --out {tmp}/x.nc", "top_damping=50"),
    ("run-damping-dim-50", "run {study_dampdim} --out {tmp}/x.nc", "damping=50"),
    ("run-diaphragm-damping", "run {study_diaph} --out {tmp}/x.nc", "damping=12"),
    ("run-cor", "run {study_cor} --out {tmp}/x.nc", "1.5"),
    ("run-record", "run {study_rec} --out {tmp}/x.nc", "'nope'"),
    ("run-records-dir", "run paper-single-storey --out {tmp}/x.nc --records {tmp}/nope", "nope"),
    ("report-missing", "report {tmp}/none.nc", "none.nc"),
    ("report-not-netcdf", "report {textnc}", "textnc.nc"),
    ("report-out-file", "report {textnc} --out {afile}", "afile.txt"),
    ("paper-out-file", "paper --out {afile}", "afile.txt"),
    ("paper-report-file", "paper --out {tmp}/res --report {afile}", "afile.txt"),
    ("calibrate-out-file", "calibrate --out {afile}", "afile.txt"),
    ("ida-not-ida", "ida paper-single-storey --out {tmp}/x.nc", "'paper-single-storey'"),
    ("ida-out-folder", "ida fema-p695-ida --out {tmp}", "is a folder"),
    ("ida-out-under-file", "ida fema-p695-ida --out {afile}/x.nc", "afile.txt"),
    ("ida-batch-zero", "ida fema-p695-ida --out {tmp}/x.nc --batch-size 0", "'0'"),
    ("ida-scheduler", "ida fema-p695-ida --out {tmp}/x.nc --scheduler bogus", "'bogus'"),
    ("ida-study-name", "ida nosuchstudy --out {tmp}/x.nc", "'nosuchstudy'"),
    ("ida-im", "ida {study_ida_im} --out {tmp}/x.nc", "'sa'"),
    ("fragility-report-missing", "fragility-report {tmp}/none.nc --out {tmp}/rep", "none.nc"),
    ("fragility-report-not-netcdf", "fragility-report {textnc} --out {tmp}/rep", "textnc.nc"),
    ("fragility-report-not-ida", "fragility-report {grid} --out {tmp}/rep",
     "not an IDA archive"),
    ("fragility-report-out-file", "fragility-report {textnc} --out {afile}", "afile.txt"),
]
CLI_RECORDS = [  # these reach the records folder
    ("records-id", "records show nosuchid", "'nosuchid'"),
    ("run-unreachable-scheduler", "run {study_one} --out {tmp}/one.nc --scheduler "
     "tcp://127.0.0.1:1", "tcp://127.0.0.1:1"),
]


def _cli(argv, capsys) -> tuple[int, str]:
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    return code, capsys.readouterr().err


def _check_cli(template, needle, files, capsys):
    code, err = _cli(_argv(template, files), capsys)
    assert code == 2, err
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if "analyses/s" not in ln  # progress
             and "replaced by `urmx " not in ln]  # an old command's note (commands/aliases)
    errors = [ln for ln in lines if "error:" in ln]
    assert len(errors) == 1, err
    if not err.startswith("usage:"):  # urmx's own errors: the one line is all
        assert len(lines) == 1 and lines[0].startswith("urmx "), err
    assert needle in errors[0], err


@pytest.mark.parametrize(("template", "needle"), [c[1:] for c in CLI], ids=[c[0] for c in CLI])
def test_cli_bad_input(files, capsys, template, needle):
    _check_cli(template, needle, files, capsys)


@pytest.mark.parametrize(("template", "needle"), [c[1:] for c in CLI_RECORDS],
                         ids=[c[0] for c in CLI_RECORDS])
def test_cli_bad_input_with_records(records_dir, files, capsys, template, needle):
    import dask
    import distributed  # noqa: F401 - its config defaults must exist before the override

    with dask.config.set({"distributed.comm.timeouts.connect": "2s"}):
        _check_cli(template, needle, files, capsys)


def test_paper_without_records_says_so_before_any_study(tmp_path, monkeypatch, capsys):
    """A records folder named by URMX_RECORDS that is missing stops `urmx paper` at once:
    the error is the only line (no study started, no cluster)."""
    monkeypatch.setenv("URMX_RECORDS", str(tmp_path / "nope"))
    code, err = _cli(["paper", "--out", str(tmp_path / "res"), "--report",
                      str(tmp_path / "rep")], capsys)
    assert code == 2
    assert err.strip().splitlines() == [
        f"urmx paper: error: records directory '{tmp_path / 'nope'}' (from $URMX_RECORDS) "
        "does not exist"]


def _wall():
    return urmx.Wall(thickness=0.23, height=4.14, crack_ratio=2 / 3, mass=3000.0)


def _trace(f):
    return R.read(f["at2"])[0]


def _run_study(**kw):
    return urmx.run_study("paper-single-storey", progress=False, **kw)


# (id, call on the files, exception type, text its message must contain)
API = [
    ("read-dt0", lambda f: R.read(f["at2_dt0"]), R.MissingTimeStepError, "dt=0.0"),
    ("read-pickle", lambda f: R.read(f["pickle"]), R.UnsupportedRecordError, "pickle"),
    ("read-format-pickle", lambda f: R.read(f["at2"], format="pickle"),
     R.UnsupportedRecordError, "'pickle'"),
    ("read-format-unknown", lambda f: R.read(f["at2"], format="xyz"),
     R.UnsupportedRecordError, "'xyz'"),
    ("read-missing", lambda f: R.read(f["tmp"] / "missing.AT2"), E.MissingFileError,
     "missing.AT2"),
    ("read-unit", lambda f: R.read(f["plain"], unit="furlongs"), R.RecordUnitError,
     "'furlongs'"),
    ("read-dt-zero", lambda f: R.read(f["plain"], dt=0.0, unit="g"), R.MissingTimeStepError,
     "0.0"),
    ("spectrum-damping-0", lambda f: R.response_spectrum(_trace(f), damping=0.0),
     E.InputError, "damping=0.0"),
    ("spectrum-damping-1.5", lambda f: R.response_spectrum(_trace(f), damping=1.5),
     E.InputError, "damping=1.5"),
    ("spectrum-damping-neg", lambda f: R.response_spectrum(_trace(f), damping=-0.05),
     E.InputError, "damping=-0.05"),
    ("spectrum-period", lambda f: R.response_spectrum(_trace(f), periods=[0.5, -1.0]),
     E.InputError, "-1.0"),
    ("sdof-damping", lambda f: R.sdof_displacement(np.zeros(10), 0.01, 0.5, damping=2.0),
     E.InputError, "damping=2.0"),
    ("scale-neither", lambda f: R.scale(_trace(f)), E.InputError, "factor="),
    ("simulate-record-id", lambda f: urmx.simulate(_wall(), "nosuchrecord"),
     E.MissingFileError, "'nosuchrecord'"),
    ("simulate-no-dt", lambda f: urmx.simulate(_wall(), np.zeros(10)), E.InputError, "dt"),
    ("simulate-cor", lambda f: urmx.simulate(_wall(), _trace(f), cor=2.0), E.InputError,
     "cor=2.0"),
    ("simulate-method", lambda f: urmx.simulate(_wall(), _trace(f), method="rk4"),
     E.InputError, "'rk4'"),
    ("simulate-rtol", lambda f: urmx.simulate(_wall(), _trace(f), method="reference",
                                              rtol=5.0), E.InputError, "rtol=5.0"),
    ("simulate-impact", lambda f: urmx.simulate(_wall(), _trace(f), impact="sticky"),
     E.InputError, "'sticky'"),
    ("simulate-pickle", lambda f: urmx.simulate(_wall(), f["pickle"]),
     R.UnsupportedRecordError, "pickle"),
    ("study-batch-zero", lambda f: _run_study(batch_size=0), E.InputError, "batch_size=0"),
    ("study-batch-float", lambda f: _run_study(batch_size=2.5), E.InputError,
     "batch_size=2.5"),
    ("study-scheduler", lambda f: _run_study(scheduler="bogus"), E.InputError, "'bogus'"),
    ("study-out-folder", lambda f: _run_study(out=f["tmp"]), E.OutputError, "is a folder"),
    ("load-study-damping", lambda f: load_study(f["study_damp50"]), CatalogError,
     "top_damping=50"),
    ("load-study-cor", lambda f: load_study(f["study_cor"]), CatalogError, "1.5"),
    ("open-study-missing", lambda f: urmx.open_study(f["tmp"] / "none.nc"),
     E.MissingFileError, "none.nc"),
    ("peak-profiles-quantity", lambda f: urmx.analysis.peak_profiles(xr.Dataset(), "velocity",
                                                                     "kobe"),
     E.InputError, "'velocity'"),
    ("records-dir", lambda f: _records_dir(f["tmp"] / "nope"), E.MissingFileError, "nope"),
    ("read-wall-damping", lambda f: urmx.catalog.read_wall(f["wall_damp50"]),
     CatalogError, "top_damping=50"),
    ("wall-unknown-field", lambda f: urmx.Wall(thickness=0.23, height=4.14, crack_ratio=0.5,
                                                mass=3000.0, crack_height=2.76),
     E.InputError, "Wall has no field 'crack_height' (did you mean"),
    ("wall-missing-field", lambda f: urmx.Wall(thickness=0.23, height=4.14),
     E.InputError, "Wall needs crack_ratio, mass"),
    ("wall-millimetres", lambda f: urmx.Wall(thickness=350, height=4.14, crack_ratio=0.5,
                                              mass=3000.0), E.InputError, "in millimetres?"),
    ("capacity-im", lambda f: F.collapse_capacity(_wall(), (np.ones(10), 0.01), im="sa"),
     E.InputError, "'sa'"),
    ("capacity-record-dt", lambda f: F.collapse_capacity(_wall(), (np.ones(10), -0.01)),
     E.InputError, "dt=-0.01"),
    ("capacity-step", lambda f: F.collapse_capacity(_wall(), (np.ones(10), 0.01), step=0.9),
     E.InputError, "step=0.9"),
    ("fit-lognormal-negative", lambda f: F.fit_lognormal([1.0, -2.0, 3.0]), E.InputError,
     "-2.0"),
    ("fit-stripes-counts", lambda f: F.fit_multiple_stripe([1.0, 2.0], 10, [3, 11]),
     E.InputError, "collapses <= analyses"),
    ("open-ida-not-ida", lambda f: FR.open_ida(f["grid"]), E.InputError, "grid.nc"),
    ("open-ida-missing", lambda f: FR.open_ida(f["tmp"] / "none.nc"), E.MissingFileError,
     "none.nc"),
    ("load-paper-missing", lambda f: P.load_paper(f["tmp"] / "nopaper.toml"),
     E.MissingFileError, "nopaper.toml"),
    ("load-paper-bad-toml", lambda f: P.load_paper(f["wall_badtoml"]), CatalogError,
     "wall_badtoml.toml: not valid TOML"),
]


@pytest.mark.parametrize(("call", "error", "needle"), [c[1:] for c in API],
                         ids=[c[0] for c in API])
def test_api_bad_input(files, call, error, needle):
    with pytest.raises(error) as err:
        call(files)
    assert isinstance(err.value, E.UrmxError)
    assert needle in str(err.value)
    assert "\n" not in str(err.value)


def test_enough_bad_inputs():
    assert len(CLI) + len(CLI_RECORDS) + len(API) >= 40


def test_errors_keep_their_builtin_types():
    """Code that caught ValueError or FileNotFoundError before still does."""
    assert issubclass(R.RecordError, ValueError) and issubclass(CatalogError, ValueError)
    assert issubclass(urmx.analysis.MissingDataError, ValueError)
    assert issubclass(E.MissingFileError, FileNotFoundError)
    assert issubclass(E.OutputError, OSError)
    for cls in (R.RecordError, CatalogError, urmx.analysis.MissingDataError, E.InputError,
                E.MissingFileError, E.OutputError, E.RunError):
        assert issubclass(cls, urmx.UrmxError)


def test_bugs_are_not_hidden(monkeypatch, capsys):
    """An exception that is not a UrmxError is a bug: the CLI lets it through."""
    import urmx.commands.records as cmd

    def broken(args):
        raise KeyError("a bug")

    monkeypatch.setattr(cmd, "_run", broken)
    with pytest.raises(KeyError, match="a bug"):
        main(["records", "list"])


def test_catalog_examples_still_load():
    """The damping check accepts every wall and study the project ships."""
    for path in (project_root() / "catalog" / "examples").glob("*.toml"):
        urmx.catalog.read_wall(path)
    for path in (project_root() / "catalog" / "studies").glob("*.toml"):
        load_study(path)
    assert os.path.isdir(project_root() / "catalog")


def test_simulate_takes_a_record_id_or_file(records_dir):
    """simulate(wall, "elcentro") loads the manifest record (it used to ask for dt)."""
    wall = urmx.Wall(thickness=0.23, height=4.14, crack_ratio=2 / 3, mass=3000.0)
    by_id = urmx.simulate(wall, "elcentro", scale=0.5)
    tr = R.load("elcentro")
    by_trace = urmx.simulate(wall, tr, scale=0.5)
    assert by_id.attrs["dt"] == tr.stats.delta == 0.02
    for name in ("peak_top_displacement", "instability_ratio", "base_impacts"):
        assert float(by_id[name]) == float(by_trace[name])


def test_simulate_runs_an_unusual_wall_on_purpose(files, capsys):
    """`--allow-unusual` is the documented way to run a wall outside the plausible ranges."""
    assert main(["simulate", str(files["wall_mm"]), str(files["at2"]), "--allow-unusual"]) == 0
    assert "status" in capsys.readouterr().out


@pytest.mark.parametrize(("text", "needle"), [
    ("records_dir = = 1\n", "urmx.toml: not valid TOML: Invalid value (at line 1, column 15)"),
    ("records_dir = 42\n", "urmx.toml: records_dir = 42 must be a folder path in quotes"),
    ("records_dir = ''\n", "urmx.toml: records_dir = '' must be a folder path in quotes"),
])
def test_bad_urmx_toml_is_one_line(tmp_path, monkeypatch, capsys, text, needle):
    """An invalid urmx.toml (TOMLDecodeError) or records_dir = 42 (TypeError) in the working
    folder were tracebacks."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("URMX_RECORDS", raising=False)
    (tmp_path / "urmx.toml").write_text(text)
    with pytest.raises(E.InputError) as err:
        _records_dir()
    assert needle in str(err.value) and str(tmp_path / "urmx.toml") in str(err.value)
    code, out = _cli(["records", "show", "elcentro"], capsys)
    assert code == 2 and out.count("\n") == 1 and needle in out


def test_urmx_toml_without_records_dir_says_so(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("URMX_RECORDS", raising=False)
    (tmp_path / "urmx.toml").write_text('record_dir = "/data/records"\n')
    with pytest.raises(E.InputError, match="urmx.toml has no records_dir \\(it has "
                                            "'record_dir': a misspelling\\?\\)"):
        _records_dir()
    (tmp_path / "urmx.toml").write_text('workers = 2\n')  # no records key: the shipped ones
    assert _records_dir() == shipped_records()
    (tmp_path / "records").mkdir()
    (tmp_path / "urmx.toml").write_text('records_dir = "records"\n')
    assert _records_dir() == tmp_path / "records"
