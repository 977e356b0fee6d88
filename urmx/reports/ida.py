"""``reports/fragility/``: figures and tables of an IDA archive (`urmx run`).

``write_report(archive, out_dir)`` writes ``REPORT.md`` and PNGs:

- ``ida_<diaphragm>.png``: the IDA curves (instability ratio against intensity) of every
  record, one panel per wall, one figure per diaphragm;
- ``fragility_curves.png``: the fitted lognormal collapse fragility of each wall, one panel
  per diaphragm, with the records' capacities as an empirical distribution;
- ``median_vs_slenderness.png`` and ``median_vs_frequency.png``: the median collapse
  intensity against h/t and against the diaphragm's frequency (the paper's two open
  questions: does h/t predict stability; are walls worst when the record's dominant
  frequency is near the diaphragm's);
- ``resonance.png``: each capacity relative to the same wall and record on the other
  flexible diaphragms, against the ratio of the record's predominant frequency to the
  diaphragm's;
- ``stiffening.png``: the effect of stiffening a diaphragm from D1 to D4 on the median;
- ``efficiency.png``: the dispersion of the capacities in every intensity measure (one run
  holds them all: the scale factor at collapse times each record's measure);
- ``collapse_risk.png``: the hazard curve and the annual rate of collapse of every wall.

The fragility curves carry their 90 % bootstrap bands; the sections "Which intensity
measure predicts collapse best?" (efficiency, sufficiency against the records' magnitude
and distance) and "Collapse risk" (a hazard curve, a design spectrum: by default the
illustrative ones of ``catalog/hazard/``) are computed from the archive without new
analyses (`urmx.analysis.ida`).

A section an archive cannot answer is left out and named, with what it needs: the
slenderness section a rank correlation over `MIN_WALLS` walls, the resonance section two
flexible diaphragms, the stiffening section D1 and D4; so an archive of one or two walls
gets the rest of the report.

Acceleration measures are shown in g (stored in m s-2).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import xarray as xr

from .. import plot as P
from ..analysis import ida as FA
from ..analysis.ida import GROUPS, STIFFEN
from ..catalog import catalog_dir
from ..errors import InputError
from ..fragility.fits import RESAMPLES, SEED
from ..markdown import number as _fmt
from ..markdown import table
from ..plot import plot_capacity_resonance as plot_resonance
from ..plot import plot_fragility_curves, plot_ida_curves, plot_median, plot_stiffening
from .common import (
    DEGENERATE,
    DEGENERATE_NOTE,
    enough_records,
    history_line,
    interval,
    made_from,
    open_archive,
    records_per_cell,
    save_figure,
    too_few,
)
from .ida_risk import (
    comparison_findings,
    im_comparison,
    measure_findings,
    measure_numbers,
    measures_section,
    risk_findings,
    risk_numbers,
    risk_section,
)

#: the illustrative site of the "Collapse risk" section (`catalog/hazard/`, README there)
HAZARD = "illustrative-pga-hazard.csv"
SPECTRUM = "illustrative-design-spectrum.csv"
YEARS = 50.0


def default_site() -> tuple[Path, Path]:
    """The illustrative hazard curve and design spectrum of ``catalog/hazard/``."""
    return catalog_dir() / "hazard" / HAZARD, catalog_dir() / "hazard" / SPECTRUM

# the figures and reductions this report used to hold, where they live now (urmx.plot,
# urmx.analysis.ida), under their names here too
__all__ = ["write_report", "open_ida", "plot_ida_curves", "plot_fragility_curves",
           "plot_median", "plot_resonance", "plot_stiffening", "resonance_table", "stiffening",
           "GROUPS", "STIFFEN"]
resonance_table, stiffening = FA.resonance_table, FA.stiffening
#: walls a rank correlation with slenderness needs (`urmx.analysis.spearman`)
MIN_WALLS = 3


def open_ida(archive) -> xr.Dataset:
    """An IDA archive (path or Dataset), loaded; a clear error for any other archive."""
    ds = open_archive(archive, "IDA archive")
    if "collapse_intensity" not in ds:
        raise InputError(f"{archive if not isinstance(archive, xr.Dataset) else 'Dataset'}: "
                         "not an IDA archive (no collapse_intensity); write one with "
                         "`urmx run STUDY --out FILE.nc`")
    return ds


def _save(axes, out: Path, name: str) -> str:
    """A palette PNG at 90 dpi (`urmx.reports.common.save_figure`) and its link."""
    return save_figure(axes, out, name, dpi=90, palette=True)


def _fname(label: str) -> str:
    return label.replace("/", "-")


def _group_name(group: str) -> str:
    """``single storey`` of ``single storey (diaphragm on top, ground below)``."""
    return GROUPS.get(group, group).split(" (")[0]


def write_report(archive, out_dir: str | os.PathLike, hazard=None, spectrum=None,
                 years: float = YEARS, records_dir=None) -> Path:
    """Write the figures and ``REPORT.md`` of an IDA archive into `out_dir`.

    Parameters
    ----------
    archive : path or Dataset
        An archive written by ``urmx run`` (`urmx.run_study` of a study with
        ``[study.ida]``).
    out_dir : path
        Created if needed; figures of the same names are replaced.
    hazard, spectrum : path, optional
        Hazard curve and design spectrum of the "Collapse risk" section
        (`urmx.fragility.risk`); default the illustrative ones (`default_site`).
    years : float
        Exposure time of the probabilities of collapse. [yr]
    records_dir : path, optional
        Records folder: the records' magnitudes and distances (sufficiency) and spectra
        (other sa_avg ranges); parts that need them are left out when it is not there.

    Returns
    -------
    Path
        ``REPORT.md``.
    """
    ds = open_ida(archive)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    site = default_site()
    hazard, spectrum = hazard or site[0], spectrum or site[1]
    groups = FA.record_groups(ds, records_dir)
    d = refit(FA.first_cor(ds), groups)
    ranks = FA.slenderness_ranks(d) if d.wall.size >= MIN_WALLS else None
    t, stf = FA.resonance_table(ds), FA.stiffening(ds)
    measures = measure_numbers(ds, records_dir)
    risk = risk_numbers(ds, hazard, spectrum, years, records_dir)
    comparison = im_comparison(ds, risk, spectrum, records_dir)
    lines = [*_header(ds, d), *_findings(d, ranks, t, stf),
             *measure_findings(measures), *risk_findings(risk),
             *comparison_findings(comparison, records_per_cell(ds)), "", *_medians(ds, d, groups),
             *_curves(ds, d, out), *measures_section(ds, measures, out),
             *_slenderness(ds, d, ranks, out), *_resonance(ds, t, out),
             *_stiffening(d, stf, out), *risk_section(ds, risk, out, comparison)]
    path = out / "REPORT.md"
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def _header(ds: xr.Dataset, d: xr.Dataset) -> list[str]:
    """Title, provenance, the grid, the search and the counts of analyses."""
    f, unit = P.display_scale(ds.collapse_intensity.attrs.get("units", ""))
    im = ds.attrs.get("intensity_measure", "intensity")
    ran = ds.analyses >= 0
    n_cells = int(ran.sum())
    lines = [
        "# Collapse fragility",
        "",
        f"{ds.attrs.get('title', ds.attrs.get('study_name', ''))}.",
        "",
        "Generated by `urmx fragility-report` (`urmx.fragility_report.write_report`) from the "
        f"archive of study `{ds.attrs.get('study_name', '?')}` ({history_line(ds)}); "
        "do not edit by hand.",
        "",
        made_from(ds),
        "",
        f"Grid: {ds.wall.size} walls x {ds.diaphragm.size} diaphragms x {ds.record.size} "
        f"records x COR {', '.join(f'{c:g}' for c in ds.cor.values)} = {n_cells} collapse "
        f"capacities. Intensity measure: `{im}` ({ds.collapse_intensity.attrs.get('long_name')})"
        f", shown in {unit}. Search: hunt on a geometric grid of scale factors (ratio "
        f"{ds.attrs.get('ida_step')}, striding over grid points far from collapse), then "
        f"bisection to rtol {ds.attrs.get('ida_rtol')}; "
        f"capacities are the first collapse the search saw (`urmx.fragility`); cells that "
        f"survive {_fmt(ds.attrs.get('ida_max_intensity', math.nan) * f)} {unit} are censored "
        "there and enter the fits as censored observations.",
        "",
        f"- analyses: {int(ds.analyses.where(ran).sum())} in all, "
        f"{float(ds.analyses.where(ran).mean()):.2f} per capacity "
        f"(max {int(ds.analyses.max())})",
        f"- censored cells: {int(ds.censored.sum())}; analyses stopped by the event bound: "
        f"{int(ds.event_limits.where(ran).sum())}",
        "- median and dispersion: lognormal maximum likelihood over the records with "
        "censoring (Baker 2015); showing COR "
        f"{float(d.cor):g}",
        "",
    ]
    if "supports" in ds.coords:
        lines += ["Diaphragms `D1` ... `D5` carry single-storey walls (the diaphragm on top, "
                  "the ground below); `D1/both` ... carry higher-storey walls between two "
                  "diaphragms alike. D5 is the catalog's D5 at the time of the run (see "
                  "`catalog/diaphragms.toml`).", ""]
    return lines


def refit(d: xr.Dataset, groups) -> xr.Dataset:
    """The archive at one COR with the median, the dispersion and their intervals fitted
    again from its capacities by `urmx.fragility.fit_lognormal` (studentized bootstrap,
    whole `groups` of records resampled when given: `urmx.analysis.ida.fit_cells`),
    whatever method the archive's own intervals came from."""
    out = FA.fit_cells(d.collapse_intensity.transpose("wall", "diaphragm", "record").values,
                       d.censored.transpose("wall", "diaphragm", "record").values, groups)
    dims = ("wall", "diaphragm")
    return d.assign({n: xr.DataArray(v, dims=dims, coords={k: d[k] for k in dims}).assign_attrs(
        d[n].attrs if n in d else {}) for n, v in out.items()})


def _medians(ds: xr.Dataset, d: xr.Dataset, groups=None) -> list[str]:
    """The median collapse intensity and dispersion of every wall and diaphragm, with their
    bootstrap intervals (`refit`)."""
    f, unit = P.display_scale(ds.collapse_intensity.attrs.get("units", ""))
    n = records_per_cell(ds)
    ci = "median_collapse_intensity_lower" in d and enough_records(n)
    level = f"{100 * float(ds.attrs.get('confidence_level', 0.9)):g} %"
    lines = ["## Median collapse intensity and dispersion", ""]
    if not enough_records(n):
        lines += [f"No intervals: {too_few(n, 'an interval')}; the medians and "
                  "dispersions below are estimates from these records alone.", ""]
    if ci:
        lines += [f"In brackets: the {level} studentized bootstrap interval (Efron & "
                  "Tibshirani 1993, Section 12.5: each resample standardised by its own "
                  "sandwich standard error; its coverage measured by simulation in the "
                  f"README), resampling {FA.grouping_sentence(groups)}; {RESAMPLES} "
                  f"resamples, seed {SEED}; `urmx.fragility.fit_lognormal`).", ""]

    def cell(c) -> str:
        med, beta = float(c.median_collapse_intensity) * f, float(c.dispersion)
        if not ci:
            return f"{_fmt(med)} ({_fmt(beta, 2)})"
        lo, hi = (float(c[f"median_collapse_intensity_{b}"]) * f for b in ("lower", "upper"))
        blo, bhi = (float(c[f"dispersion_{b}"]) for b in ("lower", "upper"))
        return (f"{_fmt(med)} {interval(med, lo, hi, _fmt)} ({_fmt(beta, 2)} "
                f"{interval(beta, blo, bhi, lambda v: _fmt(v, 2))})")

    for g, labels in FA.supports_groups(d).items():
        lines += [f"{GROUPS.get(g, g).capitalize()}: median [{unit}] (dispersion beta)", ""]
        rows = []
        for w in d.wall.values:
            c = d.sel(wall=w)
            rows.append([str(w), f"{float(c.slenderness):.0f}"]
                        + [cell(c.sel(diaphragm=lab)) for lab in labels])
        lines += table(["wall", "h/t", *labels], rows) + [""]
        if any(DEGENERATE in c for row in rows for c in row):
            lines += [DEGENERATE_NOTE, ""]
    return lines


def _curves(ds: xr.Dataset, d: xr.Dataset, out: Path) -> list[str]:
    """The IDA curves per diaphragm and the fragility curves."""
    lines = ["## IDA curves per wall and diaphragm", "",
             "Instability ratio (1.0 = collapse) against intensity for every record; red "
             "dots: capacities; dashed: the fitted median.", ""]
    for lab in [str(x) for x in d.diaphragm.values]:
        lines.append(_save(P.plot_ida_curves(ds, lab), out, f"ida_{_fname(lab)}.png"))
    return lines + ["", "## Fragility curves per diaphragm", "",
                    "Lognormal fits per wall (lines) with their 90 % bootstrap bands "
                    "(shaded: the pointwise 5-95 % range of the probability over the "
                    "records resampled, whole stations where the records carry a group) "
                    "and the records' capacities (dots, plotted at (i - 0.5)/n; censored "
                    "records are not dotted).", "",
                    _save(P.plot_fragility_curves(ds), out, "fragility_curves.png"), ""]


def _too_few_walls(d: xr.Dataset) -> str:
    return (f"needs at least {MIN_WALLS} walls for a rank correlation with h/t; the archive "
            f"has {d.wall.size}")


def _slenderness(ds: xr.Dataset, d: xr.Dataset, ranks: dict | None, out: Path) -> list[str]:
    """Does h/t predict stability: rank correlations and the stocky/slender ratio."""
    if ranks is None:
        return ["## Does slenderness predict stability?", "",
                f"_Left out: this section {_too_few_walls(d)}._", ""]
    lo_w, hi_w = ranks["stocky"], ranks["slender"]
    rows = []
    for i, lab in enumerate(str(x) for x in d.diaphragm.values):
        m = d.median_collapse_intensity.sel(diaphragm=lab)
        rr = ranks["rho_record"][i]
        rows.append([lab, _fmt(ranks["rho"][i], 3), _fmt(np.nanmedian(rr), 3),
                     f"{int(np.sum(rr < 0))}/{int(np.sum(np.isfinite(rr)))}",
                     _fmt(float(m.sel(wall=lo_w) / m.sel(wall=hi_w)), 3)])
    return ["## Does slenderness predict stability?", "",
            "Spearman rank correlation of the median collapse intensity with h/t over the "
            "walls; the same per record (median over records, and the records for which "
            "it is negative); and the ratio of the stockiest wall's median to the most "
            f"slender's ({lo_w} / {hi_w}).", "",
            *table(["diaphragm", "rho (medians)", "rho per record (median)",
                    "records with rho < 0", f"median {lo_w} / {hi_w}"], rows), "",
            _save(P.plot_median(ds, "slenderness"), out, "median_vs_slenderness.png"), ""]


def _resonance(ds: xr.Dataset, t: xr.Dataset, out: Path) -> list[str]:
    """Are walls worst when the record's dominant frequency is near the diaphragm's."""
    lines = ["## Are walls worst when the record's dominant frequency is near the "
             "diaphragm's?", "",
             "Median collapse intensity against the diaphragm's Table IV SDOF frequency "
             "(rigid supports left out):", "",
             _save(P.plot_median(ds, "frequency"), out, "median_vs_frequency.png"), "",
             "Per record: each capacity over the geometric mean of the same wall and record "
             "on the group's flexible diaphragms, against the record's predominant frequency "
             "(peak of the smoothed Fourier spectrum) over the diaphragm's. Resonance would "
             "show as binned medians below 1 near a frequency ratio of 1.", ""]
    if not t.cell.size:
        return lines + ["_Not available: fewer than two flexible diaphragms in every group._",
                        ""]
    rows = []
    for g in [g for g in GROUPS if g in set(t.group.values)]:
        for lo, hi, n, m in FA.binned(t, g):
            rows.append([_group_name(g), f"{lo:g}-{hi:g}", n,
                         _fmt(math.exp(m), 3) if np.isfinite(m) else "-"])
    lines += table(["walls", "frequency ratio", "cells", "median relative capacity"],
                   rows) + [""]
    return lines + [_save(P.plot_capacity_resonance(t), out, "resonance.png"), ""]


def _stiffening(d: xr.Dataset, stf: dict, out: Path) -> list[str]:
    """The effect of stiffening the diaphragm (`STIFFEN`) on the median, per wall."""
    lines = [f"## Stiffening the diaphragm: {STIFFEN[0]} -> {STIFFEN[1]}", ""]
    if not stf:
        return lines + [f"_Not available: the archive lacks {STIFFEN[0]} or {STIFFEN[1]}._", ""]
    rows = []
    for w in d.wall.values:
        row = [str(w), f"{float(d.slenderness.sel(wall=w)):.0f}"]
        for v in stf.values():
            row += [_fmt(float(v["ratio"].sel(wall=w)), 3),
                    f"{100 * float(v['share_up'].sel(wall=w)):.0f} %"]
        rows.append(row)
    head = ["wall", "h/t"]
    for g, v in stf.items():
        head += [f"{_group_name(g)}: median {v['stiff']} / {v['soft']}",
                 f"{_group_name(g)}: records whose capacity rises"]
    return lines + ["Ratio of the median collapse intensity with the stiffened diaphragm to "
                    "the as-built one, and the share of records (both uncensored) for which "
                    "the wall's capacity rises.", "", *table(head, rows), "",
                    _save(P.plot_stiffening(stf, d), out, "stiffening.png"), ""]


# ---- the findings: the answers in numbers, computed (so they stay true when regenerated) ----

def _findings(d: xr.Dataset, ranks: dict | None, t: xr.Dataset, stf: dict) -> list[str]:
    """The findings section: one bullet per question the report answers (and one per
    question it leaves out, saying what it needs)."""
    slender = (_slenderness_finding(d, ranks) if ranks is not None else
               f"- **Slenderness.** Left out: it {_too_few_walls(d)}.")
    return (["## Findings", "", slender] + _resonance_findings(t)
            + [_stiffening_finding(g, v) for g, v in stf.items()] + _left_out(t, stf))


def _left_out(t: xr.Dataset, stf: dict) -> list[str]:
    """Bullets naming the questions of the findings the archive cannot answer."""
    lines = []
    if not t.cell.size:
        lines.append("- **Resonance.** Left out: it needs two flexible diaphragms of one "
                     "supports group with collapses on both.")
    if not stf:
        lines.append(f"- **Stiffening.** Left out: it needs diaphragms {STIFFEN[0]} and "
                     f"{STIFFEN[1]} of one supports group.")
    return lines


def _slenderness_finding(d: xr.Dataset, ranks: dict) -> str:
    rho = ranks["rho"]
    med = d.median_collapse_intensity
    span = (med.sel(wall=ranks["stocky"]) / med.sel(wall=ranks["slender"])).values
    ok = np.isfinite(rho)
    return (f"- **Slenderness.** The median collapse intensity falls with h/t on "
            f"{int(np.sum(rho[ok] < 0))} of {int(ok.sum())} diaphragms (Spearman rho "
            f"{_fmt(np.min(rho[ok]), 2)} to {_fmt(np.max(rho[ok]), 2)}); the stockiest "
            f"wall's median is {_fmt(np.nanmin(span), 3)} to {_fmt(np.nanmax(span), 3)} "
            f"times the most slender's.")


def _resonance_findings(t: xr.Dataset) -> list[str]:
    lines = []
    for g in [g for g in GROUPS if t.cell.size and g in set(t.group.values)]:
        b = FA.binned(t, g)
        near = next(m for lo, hi, n, m in b if lo <= 1.0 < hi)
        low = min(b, key=lambda x: x[3] if np.isfinite(x[3]) else np.inf)
        near_text = (f"a capacity is a median {_fmt(math.exp(near), 3)} times the same wall "
                     "and record's geometric mean over the flexible diaphragms"
                     if np.isfinite(near) else "there are no cells")
        lines.append(
            f"- **Resonance, {_group_name(g)} walls.** Where the record's "
            f"predominant frequency is within 0.8-1.25 of the diaphragm's, {near_text}; the "
            f"lowest binned median is {_fmt(math.exp(low[3]), 3)}, at frequency ratios "
            f"{low[0]:g}-{low[1]:g}.")
    return lines


def _stiffening_finding(group: str, v: dict) -> str:
    r = v["ratio"]
    up = [str(w) for w in r.wall.values if float(r.sel(wall=w)) > 1.0]
    return (f"- **Stiffening {v['soft']} -> {v['stiff']}, {_group_name(group)} "
            f"walls.** The median changes by a factor {_fmt(float(r.min()), 3)} to "
            f"{_fmt(float(r.max()), 3)}; it rises for "
            + (f"{len(up)} of {r.wall.size} walls ({', '.join(up)})" if up else "no wall")
            + ".")
