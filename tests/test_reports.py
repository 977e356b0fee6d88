"""write_report and `urmx report` on small synthetic archives."""

import numpy as np

from urmx.cli import main
from urmx.reports.paper import study_kind, write_report

from .fixtures import paper_studies as F
from .fixtures.studies import multi_storey, single_storey

FIGURES = ["fig6_peak_acceleration.png", "fig7_peak_displacement.png", "fig8_histories.png",
           "fig9_stability_single.png", "fig10_stability_multi.png", "resonance_multi.png",
           "resonance_single.png", "verification_cor.png"]


def test_full_report(tmp_path):
    path = write_report([F.single(), F.multi(), F.verification()], tmp_path)
    text = path.read_text()
    assert path == tmp_path / "REPORT.md"
    for name in FIGURES:
        assert (tmp_path / name).stat().st_size > 1000, name
        assert f"]({name})" in text
    # Table III: 45 rows beside the paper's; Table IV with the fitted ranges
    t3 = text.split("## Table III")[1].split("## Table IV")[0]
    assert t3.count("| wall12 |") + t3.count("| west |") + t3.count("| c9 |") == 45
    assert "| D5 | 1e+09 | 1e+09 | 30-40 |" in text and "fitted" in text
    # Table VI: the paper's numbers beside the computed ones, the like-for-like column (2)
    assert "| D5 | paper | 33 | 47 | 230 | 230 | 0.2 | 0.14 | 0.2 | - | 0.015 | 2 |" in text
    assert "| D1 | paper | 22 | 16 | 230 | 62 | 0.07 | 0.35 | 0.35 | 22 | > 0.5 | 3 |" in text
    assert "| D1 | urmx | " in text and "| 22 | 0.6 | 3 |" in text
    assert "| D5-pinned | urmx |" in text
    # Figs. 6/7 tables in g and mm
    assert "peak absolute acceleration at wall top [g]" in text
    assert "peak displacement at wall top [mm]" in text
    # the verification says per wall, in words, whether the paper's COR is reproduced
    ver = text.split("## Verification")[1].split("## Findings")[0]
    for wall in ("wall12", "west", "c9"):
        assert f"**{wall}**" in ver
    assert "best COR 0.82" in ver and "not reproduced" in ver
    findings = text.split("## Findings")[1]
    assert findings.count("| yes |") == 30 and "| **no** |" not in findings
    assert "Not available" not in text.split("## Resonance")[0]


def test_figures_in_paper_order_and_units(tmp_path):
    from urmx import plot as P
    from urmx.analysis import grid as A
    from urmx.paper import load_paper
    from urmx.reports.paper import _paper_order, _record_titles

    ds = F.single()
    assert _paper_order(ds, load_paper()) == ["nahanni", "christchurch", "elcentro"]
    titles = _record_titles(ds, load_paper())
    assert titles["nahanni"].startswith("nahanni x 0.94") and "g)" in titles["nahanni"]
    axes = P.plot_stability(A.governing_instability(ds).sel(record=_paper_order(ds, load_paper())),
                            titles=titles)
    assert axes[0].get_title().startswith("(a) nahanni")
    labels = [t.get_text() for t in axes[0].get_legend().get_texts()]
    assert "D5 (33 Hz)" in labels and "D5-pinned (pinned)" in labels
    hist = P.in_display_units(A.displacement_histories(ds, 4.14, ("D1",), "christchurch"))
    assert hist["crack_displacement"].attrs["units"] == "mm"
    assert float(abs(hist["crack_displacement"]).max()) == 50.0


def test_cor_figure_draws_round_off_flat_and_skips_cells_not_run():
    import xarray as xr

    from urmx import plot as P

    cor = [0.7, 0.75, 0.8]
    da = xr.DataArray([[0.11 + 1e-15, 0.11, 0.11 - 1e-15], [np.nan] * 3], dims=("record", "cor"),
                      coords={"record": ["nahanni", "bigbear"], "cor": cor},
                      attrs={"units": "m", "long_name": "x"})
    ax = P.plot_cor_match(da)
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["nahanni"]
    lo, hi = ax.get_ylim()
    assert hi - lo > 1e-3  # a 1e-15 wiggle is not blown up into spikes


def test_missing_archives_are_reported_not_fatal(tmp_path):
    text = write_report([single_storey(histories=False)], tmp_path).read_text()
    assert "no paper-multi-storey archive was given" in text
    assert "no verification archive was given" in text
    assert "_Not available: time histories needs history_wall" in text or \
        "_Not available:" in text
    assert "_Not available: no paper-multi-storey archive was given._" in text
    assert "| n/a |" in text and (tmp_path / "fig6_peak_acceleration.png").exists()


def test_study_kind_from_study_runner_attrs():
    ds = multi_storey()
    ds.attrs = {"study_name": "paper-multi-storey", "study": '[study]\nname = "x"'}
    assert study_kind(ds) == "paper-multi-storey"
    ds.attrs = {"study": '# comment\n[study]\nname = "verification"\n'}
    assert study_kind(ds) == "verification"


def test_cli_report(tmp_path, capsys):
    single_storey().to_netcdf(tmp_path / "single.nc")
    out = tmp_path / "reports" / "paper"
    assert main(["report", str(tmp_path / "single.nc"), "--out", str(out)]) == 0
    assert (out / "REPORT.md").is_file() and (out / "fig9_stability_single.png").is_file()
    assert capsys.readouterr().out.strip().endswith("REPORT.md")


def test_cli_missing_file_is_one_line_error(tmp_path, capsys):
    assert main(["report", str(tmp_path / "nope.nc"), "--out", str(tmp_path)]) == 2
    assert "no study archive" in capsys.readouterr().err


def test_old_module_names_are_the_moved_modules():
    """Each old module name of `urmx.MOVED` imports the module that replaced it (the same
    object, its own __spec__ kept), and ``python -m`` of an old name runs the new module."""
    import importlib
    import subprocess
    import sys

    import urmx

    assert len(urmx.MOVED) == 13
    for old, new in urmx.MOVED.items():
        module = importlib.import_module(old)
        assert module is importlib.import_module(new) and module.__spec__.name == new
    from urmx.fragility_report import write_report as old_writer

    from urmx.reports import REPORTS
    assert old_writer is REPORTS["ida"] and urmx.reporting is urmx.reports.common
    done = subprocess.run([sys.executable, "-m", "urmx.predictors_report", "--help"],
                          capture_output=True, text=True)
    assert done.returncode == 0 and "--replicates" in done.stdout


def test_names_moved_out_of_a_module_are_still_served_there():
    """`urmx.MOVED_NAMES`: the study file's names of `urmx.catalog` and `compare` of
    `urmx.assess` are the moved objects; a name never there is still an AttributeError."""
    import pytest

    import urmx.analysis.assessment
    import urmx.assess
    import urmx.catalog
    import urmx.study.file
    from urmx.catalog import load_study

    assert load_study is urmx.study.file.load_study and urmx.catalog.Study is \
        urmx.study.file.Study
    assert urmx.assess.compare is urmx.analysis.assessment.compare
    with pytest.raises(AttributeError, match="has no attribute 'nothing'"):
        urmx.catalog.nothing  # noqa: B018
