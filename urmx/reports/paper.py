"""``REPORT.md`` and PNG figures from study archives (the paper's Tables III, IV and VI,
Figs. 5-10 and the findings of its Sections 6-7, regenerated beside the paper's numbers).

``write_report(archives, out_dir)`` takes netCDF paths or Datasets of the kinds
``paper-single-storey``, ``paper-multi-storey``, ``verification`` and
``verification-intensity`` (global attr ``study``); a kind not given, or a piece an archive
lacks, is reported as missing. The paper's numbers come from :mod:`urmx.paper`.

`urmx.reports.write_reports` (``urmx report``) gives it the paper's archives.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .. import paper as PP
from .. import plot as P
from ..analysis import grid as A
from ..markdown import number as _fmt
from ..markdown import table
from ..paper import STUDIES
from ..variables import attrs as registry_attrs
from .common import history_line, made_from, open_archive, save_figure

#: the urmx version at the start of a history line (``urmx 0.2.0.post3+g1a2b3c4: ``)
_VERSION = re.compile(r"^urmx \S+: ")

#: the paper's studies (`urmx.paper.STUDIES`) by the short name this report uses
KINDS = dict(zip(STUDIES, ("single", "multi", "verification", "intensity"), strict=True))
TABLE_VI_COLUMNS = [  # (variable, header, scale to the paper's units)
    ("peak_lower_drift", "(2) crack height [mm]", 1e3),
    ("peak_upper_drift", "(3) differential top-crack [mm]", 1e3),
    ("instability_displacement_upper", "(4) Delta_ins upper [mm]", 1e3),
    ("instability_displacement_lower", "(5) Delta_ins lower [mm]", 1e3),
    ("instability_ratio_upper", "(6) ratio upper", 1.0),
    ("instability_ratio_lower", "(7) ratio lower", 1.0),
    ("instability_ratio", "(8) max (6, 7)", 1.0),
]


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
    except KeyError as exc:  # an id the paper names that the archive lacks
        lines += [f"_Not available: the archive lacks {exc.args[0]}._", ""]


def _record_titles(ds: xr.Dataset, paper) -> dict[str, str]:
    """Panel titles: the record id, its scale factor and the scaled PGA [g]."""
    out = {}
    for r in ds["record"].values:
        text = str(r)
        if "scale_factor" in ds.coords:
            text += f" x {float(ds['scale_factor'].sel(record=r)):.3g}"
        if "scaled_pga" in ds.coords:
            text += f" (PGA {float(ds['scaled_pga'].sel(record=r)) / P.PAPER_G:.3g} g)"
        out[str(r)] = text
    return out


def _paper_order(ds: xr.Dataset, paper) -> list[str]:
    """Record ids in the paper's panel order, then any others."""
    ids = [str(r) for r in ds["record"].values]
    first = [A.match_id(ds, "record", r) for r in paper.panel_records
             if any(r.lower() in i.lower() for i in ids)]
    return first + [i for i in ids if i not in first]


@dataclass
class _Report:
    """What every section reads: the archives by short name (`KINDS`), the paper's numbers
    and the output folder."""

    studies: dict[str, xr.Dataset]
    paper: Any
    out: Path

    def need(self, kind: str) -> xr.Dataset:
        """The archive of a short name, or `urmx.analysis.MissingDataError`."""
        ds = self.studies.get(kind)
        if ds is None:
            raise A.MissingDataError(f"no {_LABEL[kind]} archive was given")
        return ds

    def save(self, axes, name: str) -> str:
        """The figure as ``out/name`` (110 dpi) and its link."""
        return save_figure(axes, self.out, name)


_LABEL = {short: label for label, short in KINDS.items()}  # short name -> study name


def write_report(archives, out_dir: str | os.PathLike) -> Path:
    """Write the figures (PNG) and ``REPORT.md`` into ``out_dir``; returns the
    ``REPORT.md`` path.

    Parameters
    ----------
    archives : path, Dataset, or a list of them
        Study archives (``paper-single-storey``, ``paper-multi-storey``, ``verification``,
        ``verification-intensity``); any may be missing.
    out_dir : path
        Created if needed; existing figures of the same names are replaced.
    """
    if isinstance(archives, (str, os.PathLike, xr.Dataset)):
        archives = [archives]
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    studies, notes = classify(archives)
    rep = _Report(studies, PP.load_paper(), out)
    lines = _preamble(rep, notes)
    for title, body in _sections():
        _section(lines, title, lambda ls, body=body: body(rep, ls))
    path = out / "REPORT.md"
    path.write_text("\n".join(lines).rstrip() + "\n", encoding="utf-8")
    return path


def _sections() -> list[tuple[str, Callable]]:
    """(title, body(report, lines)) of every section, in the report's order."""
    return [
        ("Table III: trilinear wall data", _table3),
        ("Table IV: diaphragm stiffness and indicative frequency", _table4),
        ("Fig. 6: absolute maximum accelerations (wall top, crack height)",
         _peaks("acceleration", "fig6_peak_acceleration.png")),
        ("Fig. 7: absolute maximum displacements (wall top, crack height)",
         _peaks("displacement", "fig7_peak_displacement.png")),
        ("Fig. 8: displacement histories of the 4140 mm wall", _fig8),
        ("Table VI: stability of the wall segments", _table6),
        ("Fig. 9: stability of single-storey walls vs slenderness",
         _stability("single", "fig9_stability_single.png")),
        ("Fig. 10: stability of higher-storey walls vs slenderness",
         _stability("multi", "fig10_stability_multi.png")),
        ("D5 as the paper's spring and as a pinned top", _d5_models),
        ("Resonance: diaphragm frequency vs record significant frequency range",
         _resonance_view),
        ("Verification (Section 5): best COR, stand-in intensity and Fig. 5", _verification),
        ("Findings of Sections 6-7 against this project's results", _findings),
    ]


def _preamble(rep: _Report, notes: list[str]) -> list[str]:
    """Title, the archives given (or missing) and the selection the report makes."""
    paper = rep.paper
    # no urmx version here: it changes at every commit after a tag (0.2.0.post3+g1a2b3c4),
    # and `urmx paper` must leave a checkout's committed report unchanged; each archive
    # names the code that made it (`urmx_version`, `urmx info`)
    lines = ["# urmx report: the paper's Tables III, IV, VI, Figs. 5-10 and findings, "
             "regenerated", "",
             "Generated by `urmx report` from the study archives (each names the code that "
             "computed it in its `urmx_version` attribute: `urmx info ARCHIVE`) and the "
             "paper's numbers in `catalog/paper.toml`. Archives hold SI units; the figures and "
             "tables the paper prints show displacements in mm and accelerations in g.", ""]
    rows = []
    for ds in rep.studies.values():
        dims = ", ".join(f"{d} {n}" for d, n in ds.sizes.items())
        rows.append([study_kind(ds), dims, _VERSION.sub("", history_line(ds))])
    lines += table(["study", "dimensions", "command (the history's last line)"], rows) + [""]

    lines += [f"- `{study_kind(ds)}`: " + made_from(ds, commit=False)
              for ds in rep.studies.values()] + [""]
    for label, kind in KINDS.items():
        if kind not in rep.studies:
            notes.append(f"no {label} archive was given: its figures and tables are missing")
    lines += [f"- {n}" for n in notes] + ([""] if notes else [])
    return lines + [
        f"Selection: COR {paper.cor:g} (the paper's value for the parametric study), "
        f"record `{paper.record}` for Figs. 6-8 and Table VI; ids matched "
        "case-insensitively; extra dimensions (scale, impact, ...) at their first value. "
        f"`{paper.stiff}` is the paper's D5, a 1e9 N/m spring with the diaphragm mass; "
        f"`{paper.pinned}` is a pinned top (a constraint) shown beside it.", ""]


def _table3(rep: _Report, lines: list[str]) -> None:
    rows = PP.table3()
    lines += ["Trilinear data of the Table II walls (`urmx.Wall.segment`, MODEL.md section "
              "3) beside the paper's Table III: all 45 numbers. theta1 and theta2 are the "
              "ends of the initial branch and of the plateau (theta_a, theta_b).", ""]
    body = [[r["wall"], f"Case {r['case']}", r["quantity"], _fmt(r["paper"], 3),
             _fmt(r["urmx"], 3), f"{r['difference']:+.3g}", f"{100 * r['relative']:+.1f} %"]
            for r in rows]
    lines += table(["wall", "segment", "quantity", "paper", "urmx", "difference",
                    "relative"], body) + [""]
    rel = np.array([abs(r["relative"]) for r in rows])
    worst = rows[int(np.argmax(rel))]
    lines += [f"{int((rel <= 0.015).sum())} of {len(rows)} within 1.5 %; the largest "
              f"difference is {worst['wall']} Case {worst['case']} {worst['quantity']} "
              f"({_fmt(worst['paper'])} printed, {_fmt(worst['urmx'])} by the formula; "
              "MODEL.md section 9 lists it as a misprint).", ""]


def _table4(rep: _Report, lines: list[str]) -> None:
    body = []
    for r in PP.table4():
        k = r["stiffness"]
        body.append([r["diaphragm"], _fmt(r["paper_stiffness"]),
                     "rigid" if not np.isfinite(k) else _fmt(k),
                     f"{_fmt(r['paper_range'][0])}-{_fmt(r['paper_range'][1])}",
                     f"{r['range'][0]:.3g}-{r['range'][1]:.3g}",
                     "fitted" if r["fitted"] else "predicted"])
    lines += table(["diaphragm", "Table IV stiffness [N m-1]", "analysed stiffness "
                    "[N m-1]", "Table IV frequency [Hz]", "urmx frequency [Hz]", "status"],
                   body) + [""]
    lines += ["urmx frequency: Table IV's footnote SDOF (stiffness over half the walls' "
              "effective mass plus the diaphragm's) for the tallest and the shortest "
              "parametric wall of the catalog building. 'fitted': the building calibration "
              "(`urmx calibrate`, reports/calibration.md) fits the wall length and diaphragm "
              "weight to these ranges and to Table VI's Delta_ins, so their agreement is by "
              "construction, not a prediction.", ""]


def _peaks(quantity: str, png: str) -> Callable:
    """The section of Fig. 6 (accelerations) or Fig. 7 (displacements)."""
    def body(rep: _Report, lines: list[str]) -> None:
        paper = rep.paper
        pk = A.peak_profiles(rep.need("single"), quantity, paper.record, cor=paper.cor)
        shown = P.in_display_units(pk)
        lines.append(rep.save(P.plot_peak_profiles(shown), png))
        lines.append("")
        lines.append(f"Record `{pk.attrs['record']}`"
                     + (f"; {pk.attrs['selection']}" if "selection" in pk.attrs else ""))
        lines.append("")
        for name in shown.data_vars:
            unit = shown[name].attrs.get("units", "")
            lines += [f"{shown[name].attrs.get('long_name', name)} [{unit}]:", ""]
            lines += _grid_table(shown[name])
            ids = [d for d in (*paper.timber, paper.stiff) if d in pk["diaphragm"].values]
            rho = A.stiffness_trend(pk[name].sel(diaphragm=ids))
            lines += [f"Spearman rho with diaphragm stiffness over {', '.join(ids)}, per wall: "
                      + ", ".join(f"{w} {_fmt(v, 2)}" for w, v in
                                  zip(rho["wall"].values, rho.values, strict=True)), ""]
    return body


def _fig8(rep: _Report, lines: list[str]) -> None:
    paper = rep.paper
    ds = rep.need("single")
    ids = [str(d) for d in ds["diaphragm"].values]
    want = [d for d in ("D1", paper.stiff, paper.pinned) if d in ids]
    hist = A.displacement_histories(ds, paper.height, want, paper.record, cor=paper.cor)
    shown = P.in_display_units(hist)
    axes = P.plot_histories(shown, hue="diaphragm",
                            variables=["top_displacement", "crack_displacement"])
    slender = float(ds["slenderness"].sel(wall=hist.attrs["wall"]))
    axes[0].figure.suptitle(  # which wall and record the figure shows, on the figure
        f"wall {hist.attrs['wall']} (h {hist.attrs['height']:.3g} m, h/t {slender:.0f}), "
        f"record {hist.attrs['record']}, COR {hist.attrs['cor']:g}",
        fontsize="medium")
    lines.append(rep.save(axes, "fig8_histories.png"))
    lines += ["", f"Wall `{hist.attrs['wall']}` (h = {hist.attrs['height']:.3g} m), "
              f"record `{hist.attrs['record']}`, COR {hist.attrs['cor']:g}; "
              f"diaphragms {', '.join(map(str, hist['diaphragm'].values))}.", ""]


def _table6(rep: _Report, lines: list[str]) -> None:
    paper = rep.paper
    tab = PP.table6(rep.need("single"), paper)
    header = ["case", "source"] + [h for _, h, _ in TABLE_VI_COLUMNS] + [
        "(2) while in patterns 11/12 [mm]", "time share 11/12", "lower case"]
    rows = []
    for d in tab["diaphragm"].values:
        rows += _table6_rows(tab, str(d), paper)
    lines += [f"Wall `{tab.attrs['wall']}` (h = {tab.attrs['height']:.3g} m), record "
              f"`{tab.attrs['record']}`, COR {tab.attrs['cor']:g}.", ""]
    lines += table(header, rows) + [""]
    lines += ["Column (2) is the peak lower-segment drift a1*theta1 over the whole record, "
              "(3) the peak upper drift a2*theta2. The paper's (2) for D1 is 'the "
              "Delta_max,abs recorded at the crack height and in one of these two patterns' "
              "(11/12): its like-for-like value is the column '(2) while in patterns 11/12', "
              f"read from the stored history ({tab.attrs['family1_source']}; the kernel's "
              "continuous-time peaks are not split by pattern). Ratios (6)-(8) are the "
              "kernel's continuous-time ratios max_t |theta|/theta0 (MODEL.md section 10), "
              "not (2)/(5) and (3)/(4). Delta_ins from "
              f"{tab.attrs['instability_displacement_source']}; the lower one is that of "
              "the case (2: patterns 21/22, 3: patterns 11/12) in which the governing lower "
              "ratio was reached.", ""]


def _table6_rows(tab: xr.Dataset, key: str, paper) -> list[list]:
    """The paper's row of a diaphragm (where it prints one) and urmx's."""
    t6, share = paper["table6"], paper["unfavourable"]
    keys = ["crack", "differential", "ins_upper", "ins_lower", "ratio_upper", "ratio_lower",
            "ratio"]
    rows = []
    pkey = "D5" if key == paper.pinned else key
    if pkey in t6 and key != paper.pinned:
        row = t6[pkey]
        fam1 = _fmt(row["crack"]) if pkey == "D1" else "-"
        sh = (f"> {_fmt(share['D1_more_than'])}" if pkey == "D1"
              else _fmt(share.get(pkey, float("nan"))))
        rows.append([key, "paper"] + [_fmt(row[k], 3) for k in keys]
                    + [fam1, sh, "3" if pkey == "D1" else "2"])
    cell = tab.sel(diaphragm=key)
    rows.append([key, "urmx"] + [_fmt(float(cell[v]) * s, 3) for v, _, s in TABLE_VI_COLUMNS]
                + [_fmt(float(cell["peak_lower_drift_family1"]) * 1e3, 3),
                   _fmt(cell["unfavourable_fraction"], 3), _fmt(cell["lower_case"])])
    return rows


def _stability(kind: str, png: str) -> Callable:
    """The section of Fig. 9 (single storey) or Fig. 10 (higher storey)."""
    def body(rep: _Report, lines: list[str]) -> None:
        ds = rep.need(kind)
        ratio = A.governing_instability(ds, cor=rep.paper.cor)
        ratio = ratio.sel(record=_paper_order(ds, rep.paper))
        lines.append(rep.save(P.plot_stability(ratio, titles=_record_titles(ds, rep.paper)),
                              png))
        lines.append("")
        for r in ratio["record"].values:
            lines += [f"<details><summary>{r}: governing instability ratio</summary>", ""]
            lines += _grid_table(ratio.sel(record=r))
            lines += ["</details>", ""]
    return body


def _d5_models(rep: _Report, lines: list[str]) -> None:
    paper = rep.paper
    ds = rep.need("single")
    ids = [str(d) for d in ds["diaphragm"].values]
    if paper.stiff not in ids or paper.pinned not in ids:
        raise A.MissingDataError(f"the study lacks {paper.stiff} or {paper.pinned}")
    # cells without a valid result (not run, event limit) are NaN and left out
    sel = A.select(A.valid_cells(ds), keep=("wall", "diaphragm", "record"), cor=paper.cor)
    spring, pinned = sel.sel(diaphragm=paper.stiff), sel.sel(diaphragm=paper.pinned)
    f = float(ds["frequency"].sel(diaphragm=paper.stiff))

    def pair(name, scale, r):
        a, b = (float(np.nanmedian(x[name].sel(record=r))) * scale for x in (spring, pinned))
        return f"{a:.3g} / {b:.3g}"

    rows = []
    for r in _paper_order(ds, paper):
        a = spring["instability_ratio"].sel(record=r)
        b = pinned["instability_ratio"].sel(record=r)
        rel = ((a - b) / b).values
        rows.append([r, f"{float(np.nanmedian(rel)):+.0%}", f"{float(np.nanmin(rel)):+.0%} .. "
                     f"{float(np.nanmax(rel)):+.0%}",
                     f"{int(spring['collapsed'].sel(record=r).sum())} / "
                     f"{int(pinned['collapsed'].sel(record=r).sum())}",
                     pair("peak_top_acceleration", P.display_scale("m s-2")[0], r),
                     pair("peak_crack_displacement", 1e3, r)])
    lines += [f"`{paper.stiff}` (spring, {f:.3g} Hz for the median wall) against "
              f"`{paper.pinned}` (pinned), COR {paper.cor:g}, over the "
              f"{ds.sizes['wall']} walls:", ""]
    lines += table(["record", "governing ratio, spring vs pinned: median change",
                    "range over walls", "collapses spring / pinned",
                    "median top acceleration [g] spring / pinned",
                    "median crack displacement [mm] spring / pinned"], rows) + [""]


def _resonance_view(rep: _Report, lines: list[str]) -> None:
    ranges = PP.significant_frequency()
    for kind, png in (("multi", "resonance_multi.png"), ("single", "resonance_single.png")):
        ds = rep.studies.get(kind)
        if ds is None:
            lines += [f"_No {_LABEL[kind]} archive._", ""]
            continue
        res = A.resonance(ds, cor=rep.paper.cor, ranges=ranges)
        lines += [f"### {_LABEL[kind]}", "", rep.save(P.plot_resonance(res), png), ""]
        header = ["diaphragm", "frequency [Hz]"] + [
            f"{r} ({_fmt(res['frequency_low'].sel(record=r))}-"
            f"{_fmt(res['frequency_high'].sel(record=r))} Hz)"
            for r in res["record"].values]
        rows = [[d, _fmt(res["frequency"].sel(diaphragm=d))]
                + [_resonance_cell(res.sel(diaphragm=d, record=r))
                   for r in res["record"].values]
                for d in res["diaphragm"].values]
        lines += table(header, rows) + [""]
        lines += [f"Change in brackets: mean governing instability ratio over walls minus "
                  f"that of the stiffest diaphragm ({res.attrs['reference_diaphragm']}); "
                  "positive = less stable. Significant frequency ranges: Table V (records "
                  "manifest, `paper_frequency_range_hz`).", ""]


def _resonance_cell(c: xr.Dataset) -> str:
    flag = "in range" if bool(c["in_range"]) else "outside"
    coll = (f", {int(c['collapses'])} collapsed"
            if "collapses" in c and np.isfinite(c["collapses"]) else "")
    return (f"{flag}; mean ratio {_fmt(c['mean_instability_ratio'], 2)} "
            f"({float(c['stability_change']):+.2f}){coll}")


def _verification(rep: _Report, lines: list[str]) -> None:
    ds = rep.need("verification")
    inten = rep.studies.get("intensity")
    rows = PP.verification(ds, rep.paper)
    probe = {r["wall"]: r for r in PP.intensity(inten, rep.paper)} if inten is not None else {}
    for r in rows:
        lines += [" ".join(_verification_words(r, probe.get(r["wall"]))), ""]
    lines += ["In short: the paper's verification is not reproduced here; the test walls' "
              "table motions are not available and the stand-ins differ from them in "
              "intensity, content and timing (PROVENANCE.md, records/manifest.toml).", ""]
    lines += [rep.save(_cor_match_axes(ds, rows), "verification_cor.png"), ""]
    if "history" not in ds.dims:
        lines += ["_No time histories stored in the verification archive: Fig. 5 "
                  "not drawn._", ""]
        return
    for r in rows:
        w = r["wall"]
        try:
            hist = A.verification_histories(ds, w, cor=r["paper_cor"])
        except A.MissingDataError as exc:
            lines += [f"_Fig. 5, {w}: {exc}._", ""]
            continue
        shown = P.in_display_units(hist)
        lines += [f"Fig. 5, `{w}` (COR {hist.attrs['cor']:g}; displacements that move):",
                  "", rep.save(P.plot_histories(shown, hue="record"), f"fig5_{w}.png"), ""]


def _verification_words(r: dict, pr: dict | None) -> list[str]:
    """One wall of the verification in words: its stand-in, whether the paper's best COR is
    reproduced, its response at the paper's COR and what the intensity sweep found."""
    name = r["wall"]
    stated = (f"the source states {r['stated_pga_g']:.3g} g"
              if np.isfinite(r["stated_pga_g"]) else "no source states its intensity")
    words = [f"**{name}** (Fig. {r['figure']}, paper's input: {r['paper_input']}; paper's "
             f"best COR {r['paper_cor']:g}). Stand-in `{r['record']}` at "
             f"{r['scaled_pga_g']:.3g} g PGA; {stated} ({r['source']})."]
    words.append(_best_cor_words(r))
    words.append(f"At the paper's COR: peak crack displacement "
                 f"{1e3 * r['peak_crack']:.3g} mm"
                 + (f", collapse at {r['collapse_time']:.3g} s."
                    if np.isfinite(r["collapse_time"]) else ", no collapse."))
    if pr is not None:
        words.append(_sweep_words(pr))
    return words


def _best_cor_words(r: dict) -> str:
    n, ncoll = len(r["cors"]), len(r["collapsed"])
    if r["target"]:
        if np.isfinite(r["best_cor"]):
            ok = abs(r["best_cor"] - r["paper_cor"]) <= r["cor_step"] + 1e-9
            return (f"Target {r['target']}: best COR {r['best_cor']:.2f} (misfit "
                    f"{r['misfit']:.2g}); the paper's COR is "
                    f"{'reproduced' if ok else 'not reproduced'}.")
        return (f"Target {r['target']}: no COR of the sweep reproduces it "
                f"(collapse at {ncoll} of {n} COR values), so the paper's best "
                "COR is **not reproduced**.")
    text = ("The paper states no response value for this wall (only its "
            "Fig. 5 curves), so no best COR can be computed; ")
    if ncoll == n:
        return text + (f"the wall collapses at every COR ({n} of {n}), so the COR "
                       "sweep cannot single out the paper's COR: **not reproduced**.")
    if ncoll:
        return text + (f"it collapses at {ncoll} of {n} COR values: **not "
                       "reproduced** as a COR-independent response.")
    return text + (f"it stands at every COR, and its peak crack displacement "
                   f"varies by a factor {r['cor_spread']:.3g} over the sweep: the "
                   "response hardly depends on COR, so the paper's COR is **not "
                   "reproduced** (nothing singles it out).")


def _sweep_words(pr: dict) -> str:
    if not np.isfinite(pr["first_collapse_g"]):
        return (f"Intensity sweep (COR {pr['cor']:g}): no collapse up to "
                f"{max(pr['pga_g']):.3g} g.")
    text = (f"Intensity sweep (COR {pr['cor']:g}): it stands up to "
            f"{pr['last_standing_g']:.3g} g and collapses from "
            f"{pr['first_collapse_g']:.3g} g")
    if "nearest_collapse" in pr:
        g, t = pr["nearest_collapse"]
        text += (f"; its collapse time nearest the target is {t:.3g} s (at "
                 f"{g:.3g} g): the stand-in's strong motion comes at another "
                 "time than the table input's")
    return text + "."


def _cor_match_axes(ds: xr.Dataset, rows: list[dict]) -> list:
    """One panel per wall: its response against COR beside the paper's best COR."""
    axes = P.panels(None, len(rows))
    for ax, r in zip(axes, rows, strict=True):
        w = r["wall"]
        var = "collapse_time" if r["target"].startswith("collapse_time") and \
            np.isfinite(ds["collapse_time"].sel(wall=w)).any() else "peak_crack_displacement"
        da = A.select(ds[var].sel(wall=w, record=[r["record"]]), keep=("record", "cor"))
        if "diaphragm" in da.dims:
            da = da.squeeze("diaphragm", drop=True)
        da = da.reset_coords(drop=True)
        da.attrs = registry_attrs(var)
        target = float(r["target"].split("=")[1]) if r["target"] and var in r["target"] \
            else None
        P.plot_cor_match(P.in_display_units(da), target, r["paper_cor"], ax=ax)
        ax.set_title(f"{w} ({r['record']}, {r['scaled_pga_g']:.2g} g)")
    return axes


def _findings(rep: _Report, lines: list[str]) -> None:
    s = rep.studies
    fs = PP.findings(s.get("single"), s.get("multi"), s.get("verification"), rep.paper,
                     intensity_ds=s.get("intensity"))
    rows = []
    for f in fs:
        verdict = {True: "yes", False: "**no**", None: "n/a"}[f["agree"]]
        rows.append([f["section"], f["statement"], f["criterion"], f["measured"], verdict,
                     f["cause"]])
    lines += [f"{len(fs)} statements; agree {sum(f['agree'] is True for f in fs)}, "
              f"disagree {sum(f['agree'] is False for f in fs)}, not computable "
              f"{sum(f['agree'] is None for f in fs)}. Each criterion is tested to fail on "
              "data that violate it (tests/test_paper.py); thresholds are urmx's choices "
              "(`urmx.paper`: MAGNITUDE_BAND, RATIO_FACTOR, NO_RELATION, ...). Where urmx "
              "disagrees, the criterion is re-measured with the other D5 model and, for a "
              "statement on one record, under the other records.", ""]
    lines += table(["section", "the paper states", "criterion", "urmx measures", "agree",
                    "cause where it disagrees"],
                   [[str(c).replace("|", "\\|") for c in r] for r in rows]) + [""]
