"""``REPORT.md`` and PNG figures from study archives (the paper's Figs. 5-10, Table VI and
the findings of its Sections 6-7, regenerated).

``write_report(archives, out_dir)`` takes netCDF paths or Datasets of the kinds
``paper-single-storey``, ``paper-multi-storey`` and ``verification`` (global attr
``study``); a kind not given, or a piece an archive lacks, is reported as missing.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable
from pathlib import Path

import numpy as np
import xarray as xr

from . import analysis as A
from . import plot as P
from .errors import InputError, MissingFileError
from .markdown import table
from .variables import attrs as registry_attrs

KINDS = {"paper-single-storey": "single", "paper-multi-storey": "multi",
         "verification": "verification"}
TABLE_VI_COLUMNS = [  # (variable, header, scale to the paper's units)
    ("peak_lower_drift", "(2) crack height [mm]", 1e3),
    ("peak_upper_drift", "(3) differential top-crack [mm]", 1e3),
    ("instability_displacement_upper", "(4) Delta_ins upper [mm]", 1e3),
    ("instability_displacement_lower", "(5) Delta_ins lower [mm]", 1e3),
    ("instability_ratio_upper", "(6) ratio upper", 1.0),
    ("instability_ratio_lower", "(7) ratio lower", 1.0),
    ("instability_ratio", "(8) max (6, 7)", 1.0),
]


def open_archive(archive) -> xr.Dataset:
    """A Dataset loaded from a study archive path (`urmx.study.open_study`), or as given."""
    if isinstance(archive, xr.Dataset):
        return archive
    path = Path(archive)
    if not path.is_file():
        raise MissingFileError(f"no study archive {str(path)!r}")
    from .study import open_study

    try:
        return open_study(path).load()
    except (OSError, ValueError) as exc:  # not netCDF, or damaged
        raise InputError(f"{str(path)!r} is not a readable study archive: {exc}") from None


def study_kind(ds: xr.Dataset) -> str | None:
    """The study kind of an archive: attr ``study_name`` (as ``urmx.study`` writes it), or
    attr ``study`` when it is a kind itself or a study definition holding ``name = "..."``."""
    for key in ("study_name", "study"):
        value = str(ds.attrs.get(key, "")).strip()
        if value in KINDS:
            return value
    found = re.search(r'^\s*name\s*=\s*"([^"]+)"', str(ds.attrs.get("study", "")), re.M)
    return found.group(1) if found and found.group(1) in KINDS else None


def classify(archives: Iterable) -> tuple[dict[str, xr.Dataset], list[str]]:
    """Map each archive to single / multi / verification by its ``study`` attr."""
    studies, notes = {}, []
    for archive in archives:
        ds = open_archive(archive)
        name = archive if not isinstance(archive, xr.Dataset) else "(Dataset)"
        label = study_kind(ds)
        if label is None:
            notes.append(f"{name}: not a study kind this report uses "
                         f"({', '.join(KINDS)}); ignored")
            continue
        kind = KINDS[label]
        if kind in studies:
            notes.append(f"{name}: a second {label} archive; the later one is used")
        studies[kind] = ds
    return studies, notes


def _fmt(value, digits: int = 3) -> str:
    value = float(value)
    if not np.isfinite(value):
        return "inf" if value > 0 else ("-" if np.isnan(value) else "-inf")
    return f"{value:.{digits}g}"


def _save(axes, out_dir: Path, name: str) -> str:
    fig = np.ravel(axes)[0].figure
    fig.savefig(out_dir / name, dpi=110)
    return f"![{name}]({name})"


def _grid_table(da: xr.DataArray, columns: str = "diaphragm", scale: float = 1.0,
                digits: int = 3) -> list[str]:
    """Walls as rows (with slenderness), ``columns`` as columns."""
    header = ["wall", "h/t"] + [str(c) for c in da[columns].values]
    rows = []
    for w in da["wall"].values:
        row = da.sel(wall=w)
        rows.append([str(w), _fmt(row["slenderness"], 3)]
                    + [_fmt(float(row.sel({columns: c})) * scale, digits)
                       for c in da[columns].values])
    return table(header, rows) + [""]


def _section(lines: list[str], title: str, body) -> None:
    lines += [f"## {title}", ""]
    try:
        body(lines)
    except A.MissingDataError as exc:
        lines += [f"_Not available: {exc}._", ""]


def write_report(archives, out_dir: str | os.PathLike) -> Path:
    """Write the figures (PNG) and ``REPORT.md`` into ``out_dir``; returns the
    ``REPORT.md`` path.

    Parameters
    ----------
    archives : path, Dataset, or a list of them
        Study archives (``paper-single-storey``, ``paper-multi-storey``,
        ``verification``); any may be missing.
    out_dir : path
        Created if needed; existing figures of the same names are replaced.
    """
    from . import __version__

    if isinstance(archives, (str, os.PathLike, xr.Dataset)):
        archives = [archives]
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    studies, notes = classify(archives)
    single, multi, verif = (studies.get(k) for k in ("single", "multi", "verification"))
    lines = ["# urmx report: the paper's Figs. 5-10 and Table VI, regenerated", "",
             f"Generated by `urmx report` (urmx {__version__}).", ""]
    rows = []
    for ds in studies.values():
        dims = ", ".join(f"{d} {n}" for d, n in ds.sizes.items())
        rows.append([study_kind(ds), dims,
                     str(ds.attrs.get("history", "")).splitlines()[-1:][0]
                     if ds.attrs.get("history") else ""])
    lines += table(["study", "dimensions", "history (last line)"], rows) + [""]
    for kind, label in (("single", "paper-single-storey"), ("multi", "paper-multi-storey"),
                        ("verification", "verification")):
        if kind not in studies:
            notes.append(f"no {label} archive was given: its figures and tables are missing")
    lines += [f"- {n}" for n in notes] + ([""] if notes else [])
    lines += [f"Selection: COR {A.PAPER_COR} (the paper's value for the parametric study); "
              "ids matched case-insensitively; extra dimensions (scale, impact, ...) at "
              "their first value.", ""]

    def need(ds, kind):
        if ds is None:
            raise A.MissingDataError(f"no {kind} archive was given")
        return ds

    def peaks(quantity, fig, png):
        def body(lines):
            pk = A.peak_profiles(need(single, "paper-single-storey"), quantity)
            lines.append(_save(P.plot_peak_profiles(pk), out, png))
            lines.append("")
            lines.append(f"Record `{pk.attrs['record']}`"
                         + (f"; {pk.attrs['selection']}" if "selection" in pk.attrs else ""))
            lines.append("")
            for name in pk.data_vars:
                unit = pk[name].attrs.get("units", "")
                lines += [f"{pk[name].attrs.get('long_name', name)} [{unit}]:", ""]
                lines += _grid_table(pk[name])
                rho = A.stiffness_trend(pk[name])
                lines += ["Spearman rho with diaphragm stiffness, per wall: "
                          + ", ".join(f"{w} {_fmt(v, 2)}" for w, v in
                                      zip(rho["wall"].values, rho.values, strict=True)), ""]
        _section(lines, fig, body)

    peaks("acceleration", "Fig. 6: absolute maximum accelerations (wall top, crack height)",
          "fig6_peak_acceleration.png")
    peaks("displacement", "Fig. 7: absolute maximum displacements (wall top, crack height)",
          "fig7_peak_displacement.png")

    def fig8(lines):
        hist = A.displacement_histories(need(single, "paper-single-storey"))
        lines.append(_save(P.plot_histories(hist, hue="diaphragm",
                                            variables=["top_displacement",
                                                       "crack_displacement"]),
                           out, "fig8_histories.png"))
        lines += ["", f"Wall `{hist.attrs['wall']}` (h = {hist.attrs['height']:.3g} m), "
                  f"record `{hist.attrs['record']}`, COR {hist.attrs['cor']:g}; "
                  f"diaphragms {', '.join(map(str, hist['diaphragm'].values))}.", ""]
    _section(lines, "Fig. 8: displacement histories of the 4140 mm wall, D1 and D5", fig8)

    def table6(lines):
        tab = A.stability_table(need(single, "paper-single-storey"))
        header = ["case", "source"] + [h for _, h, _ in TABLE_VI_COLUMNS] + [
            "time share 11/12", "lower case"]
        rows = []
        for d in tab["diaphragm"].values:
            key = str(d).upper()
            paper = A.PAPER_TABLE_VI.get(key, {})
            rows.append([d, "paper"] + [_fmt(paper[v], 3) if v in paper else "-"
                                        for v, _, _ in TABLE_VI_COLUMNS]
                        + [A.PAPER_UNFAVOURABLE.get(key, "-"), "3" if key == "D1" else "2"])
            cell = tab.sel(diaphragm=d)
            rows.append([d, "urmx"] + [_fmt(float(cell[v]) * s, 3)
                                       for v, _, s in TABLE_VI_COLUMNS]
                        + [_fmt(cell["unfavourable_fraction"], 3), _fmt(cell["lower_case"])])
        lines += [f"Wall `{tab.attrs['wall']}` (h = {tab.attrs['height']:.3g} m), record "
                  f"`{tab.attrs['record']}`, COR {tab.attrs['cor']:g}.", ""]
        lines += table(header, rows) + [""]
        lines += ["Column (2) is the peak lower-segment drift a1*theta1 (crack height "
                  "relative to the base), (3) the peak upper drift a2*theta2. Ratios (6)-(8) "
                  "are the kernel's continuous-time ratios max_t |theta|/theta0 (MODEL.md "
                  "section 10), not (2)/(5) and (3)/(4). Delta_ins from "
                  f"{tab.attrs['instability_displacement_source']}; the lower one is that "
                  "of the case (2: patterns 21/22, 3: patterns 11/12) in which the governing "
                  "lower ratio was reached. The paper's Delta_ins imply building masses it "
                  "does not state (MODEL.md section 9).", ""]
        ds = single
        rigid = [str(d) for d in tab["diaphragm"].values
                 if "stiffness" in ds.variables
                 and np.isinf(float(ds["stiffness"].sel(diaphragm=d)))]
        if rigid:
            lines += [f"{', '.join(rigid)} is a rigid top support here (a constraint, MODEL.md "
                      "section 6): the top does not move, so the differential (3) equals the "
                      "crack displacement (2). The paper's 33 and 47 mm for D5 cannot both be "
                      "segment drifts of a wall whose top is (nearly) fixed, as its 1e9 N/m "
                      "D5 is; the paper does not say how column (3) was measured.",
                      ""]
    _section(lines, "Table VI: stability of the wall segments", table6)

    def stability(ds_kind, png):
        def body(lines):
            ds, kind = ds_kind
            ratio = A.governing_instability(need(ds, kind))
            lines.append(_save(P.plot_stability(ratio), out, png))
            lines.append("")
            for r in ratio["record"].values:
                lines += [f"<details><summary>{r}: governing instability ratio</summary>", ""]
                lines += _grid_table(ratio.sel(record=r))
                lines += ["</details>", ""]
        return body

    _section(lines, "Fig. 9: stability of single-storey walls vs slenderness",
             stability((single, "paper-single-storey"), "fig9_stability_single.png"))
    _section(lines, "Fig. 10: stability of higher-storey walls vs slenderness",
             stability((multi, "paper-multi-storey"), "fig10_stability_multi.png"))

    def resonance_view(lines):
        for ds, kind, png in ((multi, "paper-multi-storey", "resonance_multi.png"),
                              (single, "paper-single-storey", "resonance_single.png")):
            if ds is None:
                lines += [f"_No {kind} archive._", ""]
                continue
            res = A.resonance(ds)
            lines += [f"### {kind}", "", _save(P.plot_resonance(res), out, png), ""]
            header = ["diaphragm", "frequency [Hz]"] + [
                f"{r} ({_fmt(res['frequency_low'].sel(record=r))}-"
                f"{_fmt(res['frequency_high'].sel(record=r))} Hz)"
                for r in res["record"].values]
            rows = []
            for d in res["diaphragm"].values:
                cells = []
                for r in res["record"].values:
                    c = res.sel(diaphragm=d, record=r)
                    flag = "in range" if bool(c["in_range"]) else "outside"
                    coll = f", {int(c['collapses'])} collapsed" if "collapses" in c else ""
                    cells.append(f"{flag}; mean ratio {_fmt(c['mean_instability_ratio'], 2)} "
                                 f"({float(c['stability_change']):+.2f}){coll}")
                rows.append([d, _fmt(res["frequency"].sel(diaphragm=d))] + cells)
            lines += table(header, rows) + [""]
            lines += [f"Change in brackets: mean governing instability ratio over walls minus "
                      f"that of the stiffest diaphragm ({res.attrs['reference_diaphragm']}); "
                      "positive = less stable. Ranges from "
                      f"{res.attrs['frequency_range_source']}.", ""]
    _section(lines, "Resonance: diaphragm frequency vs record significant frequency range",
             resonance_view)

    def verification(lines):
        ds = need(verif, "verification")
        match = A.cor_matches(ds)
        rows = []
        for w in match["wall"].values:
            m = match.sel(wall=w)
            target = (f"{m['target_variable'].item()} = {_fmt(m['target_value'])}"
                      if m["target_variable"].item() else "none stated")
            paper_cor = float(m["paper_best_cor"])
            for r in match["record"].values:
                if not bool(np.isfinite(ds["peak_crack_displacement"].sel(wall=w, record=r))
                            .any()):
                    continue  # a cell the study's pairs leave out
                cell = A.select(ds.sel(wall=w, record=r), cor=paper_cor)
                if "diaphragm" in cell.dims:
                    cell = cell.isel(diaphragm=0)
                peak = cell["peak_crack_displacement"]
                coll = cell["collapse_time"] if "collapse_time" in cell else None
                rows.append([w, r, _fmt(paper_cor), target,
                             _fmt(m["best_cor"].sel(record=r)),
                             _fmt(m["misfit"].sel(record=r), 2),
                             _fmt(float(peak) * 1e3),
                             _fmt(coll) if coll is not None else "-"])
        lines += table(["wall", "record", "paper's best COR", "target", "best COR",
                        "misfit", "peak crack displacement at paper's COR (nearest on grid) [mm]",
                        "collapse time there [s]"], rows) + [""]
        lines += ["Best COR: the grid value whose response is nearest the target "
                  "(\\|response - target\\| / \\|target\\|; '-' when no COR gives a finite "
                  "response, e.g. no collapse). Targets: `measured_<variable>(wall)` in the "
                  "archive, else the only value the paper's text states (West wall "
                  "instability at 5.3 s under 67 % Big Bear). The paper's Wall 12 and C9 "
                  "values are read from its Fig. 5 only, so no target is stated for them; "
                  "where a record stands in for the paper's (see the study's catalog file) "
                  "the match is indicative. Only cells the study ran are listed.", ""]
        walls = [str(w) for w in match["wall"].values]
        axes = P.panels(None, len(walls))
        for ax, w in zip(axes, walls, strict=True):
            m = match.sel(wall=w)
            var = m["target_variable"].item() or "peak_crack_displacement"
            da = A.select(ds[var].sel(wall=w), keep=("record", "cor"))
            if "diaphragm" in da.dims:
                da = da.squeeze("diaphragm", drop=True)
            da = da.reset_coords(drop=True)
            da.attrs = registry_attrs(var)
            P.plot_cor_match(da, float(m["target_value"]), float(m["paper_best_cor"]), ax=ax)
            ax.set_title(w)
        lines += [_save(axes, out, "verification_cor.png"), ""]
        if "history" not in ds.dims:
            lines += ["_No time histories stored in the verification archive: Fig. 5 "
                      "not drawn._", ""]
            return
        for w in walls:
            try:
                hist = A.verification_histories(ds, w)
            except A.MissingDataError as exc:
                lines += [f"_Fig. 5, {w}: {exc}._", ""]
                continue
            lines += [f"Fig. 5, `{w}` (COR {hist.attrs['cor']:g}):", "",
                      _save(P.plot_histories(hist, hue="record"), out, f"fig5_{w}.png"), ""]
    _section(lines, "Verification (Section 5): best-matching COR and Fig. 5 histories",
             verification)

    def findings(lines):
        rows = []
        for f in A.findings(single, multi):
            verdict = {True: "yes", False: "**no**", None: "n/a"}[f["agree"]]
            rows.append([f["finding"], f["paper"], f["measure"], f["computed"], verdict,
                         f["note"]])
        lines += table(["finding (paper)", "paper states", "measure and criterion",
                        "urmx computes", "agree", "why not, if known"],
                       [[str(c).replace("|", "\\|") for c in r] for r in rows]) + [""]
    _section(lines, "Findings of Sections 6-7 against this project's results", findings)

    path = out / "REPORT.md"
    path.write_text("\n".join(lines).rstrip() + "\n", encoding="utf-8")
    return path
