"""``reports/fragility/``: figures and tables of an IDA archive (`urmx ida`).

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
- ``stiffening.png``: the effect of stiffening a diaphragm from D1 to D4 on the median.

Acceleration measures are shown in g (stored in m s-2).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import xarray as xr

from . import plot as P
from .analysis import spearman
from .errors import InputError, MissingFileError
from .markdown import number as _fmt
from .markdown import table
from .model import PAPER_G

GROUPS = {"top": "single storey (diaphragm on top, ground below)",
          "both": "higher storey (between two diaphragms alike)"}
STIFFEN = ("D1", "D4")  # the stiffening the report measures


def open_ida(archive) -> xr.Dataset:
    """An IDA archive (path or Dataset), loaded; a clear error for any other archive."""
    if isinstance(archive, xr.Dataset):
        ds = archive
    else:
        path = Path(archive)
        if not path.is_file():
            raise MissingFileError(f"no IDA archive {str(path)!r}")
        from .study import open_study

        try:
            ds = open_study(path).load()
        except (OSError, ValueError) as exc:  # not netCDF, or damaged
            raise InputError(f"{str(path)!r} is not a readable IDA archive: {exc}") from None
    if "collapse_intensity" not in ds:
        raise InputError(f"{archive if not isinstance(archive, xr.Dataset) else 'Dataset'}: "
                         "not an IDA archive (no collapse_intensity); write one with "
                         "`urmx ida STUDY --out FILE.nc`")
    return ds


def _in_g(ds: xr.Dataset) -> tuple[float, str]:
    """Factor and unit label to show the study's intensity measure in."""
    units = ds.collapse_intensity.attrs.get("units", "")
    return (1.0 / PAPER_G, "g") if units == "m s-2" else (1.0, units)


def _groups(ds: xr.Dataset) -> dict[str, list[str]]:
    """Diaphragm labels by supports (single storey first)."""
    if "supports" not in ds.coords:
        return {"top": [str(d) for d in ds.diaphragm.values]}
    out: dict[str, list[str]] = {}
    for d, s in zip(ds.diaphragm.values, ds.supports.values, strict=True):
        out.setdefault(str(s), []).append(str(d))
    return dict(sorted(out.items(), key=lambda kv: list(GROUPS).index(kv[0])
                       if kv[0] in GROUPS else 9))


def _base(label: str) -> str:
    return label.split("/")[0]


def _fname(label: str) -> str:
    return label.replace("/", "-")


def _cor(ds: xr.Dataset) -> xr.Dataset:
    """The archive at its first COR (the report shows one)."""
    return ds.isel(cor=0)


# ---- figures ------------------------------------------------------------------------------

def plot_ida_curves(ds: xr.Dataset, diaphragm: str, axes=None) -> list:
    """IDA curves (instability ratio against intensity) of every record, one panel per
    wall, for one diaphragm and the first COR."""
    f, unit = _in_g(ds)
    d = _cor(ds).sel(diaphragm=diaphragm)
    walls = list(d.wall.values)
    axes = P.panels(axes, len(walls), ncols=3)
    for ax, w in zip(axes, walls, strict=True):
        c = d.sel(wall=w)
        for r in c.record.values:
            cell = c.sel(record=r)
            x = cell.instability_ratio.values
            y = cell.intensity.values * f
            ok = np.isfinite(x)
            ax.plot(x[ok], y[ok], color="0.55", lw=0.6, alpha=0.7)
            cap = float(cell.collapse_intensity) * f
            if float(cell.censored) == 0:  # a collapse (1: censored; NaN: not run)
                ax.plot([1.0], [cap], "o", ms=2.5, color="C3")
        med = float(c.median_collapse_intensity) * f
        if np.isfinite(med):
            ax.axhline(med, color="C0", ls="--", lw=1.2, label=f"median {med:.3g} {unit}")
            ax.legend(fontsize="x-small", loc="upper left")
        ax.set_title(f"{w} (h/t {float(c.slenderness):.0f}) on {diaphragm}", fontsize=9)
        ax.set_xlim(0, 1.05)
        ax.set_xlabel("instability ratio [1]")
        ax.set_ylabel(f"{ds.attrs.get('intensity_measure', 'intensity')} [{unit}]")
        ax.grid(True, alpha=0.3)
    return axes


def plot_fragility_curves(ds: xr.Dataset, axes=None) -> list:
    """Fitted collapse fragility of each wall (colour by slenderness), one panel per
    diaphragm, with the records' capacities as empirical distributions (dots)."""
    from scipy.stats import norm

    f, unit = _in_g(ds)
    d = _cor(ds)
    labels = [str(x) for x in d.diaphragm.values]
    axes = P.panels(axes, len(labels), ncols=3)
    top = float(np.nanmax(d.collapse_intensity.where(d.censored == 0))) * f * 1.2
    x = np.linspace(1e-3, top, 300)
    cmap = _colors(d)
    for ax, lab in zip(axes, labels, strict=True):
        for w in d.wall.values:
            c = d.sel(diaphragm=lab, wall=w)
            med, beta = float(c.median_collapse_intensity) * f, float(c.dispersion)
            col = cmap[str(w)]
            if np.isfinite(med):
                ax.plot(x, norm.cdf(np.log(x / med) / beta), color=col, lw=1.2,
                        label=f"{w}")
            cap = np.sort(c.collapse_intensity.where(c.censored == 0).values * f)
            cap = cap[np.isfinite(cap)]
            n = c.record.size
            ax.plot(cap, (np.arange(cap.size) + 0.5) / n, ".", ms=2, color=col, alpha=0.6)
        ax.set_title(lab, fontsize=9)
        ax.set_xlabel(f"{ds.attrs.get('intensity_measure', 'intensity')} [{unit}]")
        ax.set_ylabel("probability of collapse [1]")
        ax.set_ylim(0, 1)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize="x-small", ncol=2, title="wall")
    return axes


def _log_x(ax) -> None:
    """A log x-axis labelled at 1, 2 and 5 times the powers of ten, as plain numbers."""
    from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

    ax.set_xscale("log")
    ax.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
    ax.xaxis.set_minor_formatter(NullFormatter())


def _colors(ds) -> dict[str, tuple]:
    from matplotlib import colormaps

    cmap = colormaps["viridis"]
    s = ds.slenderness.values
    span = max(float(np.ptp(s)), 1e-9)
    return {str(w): cmap(0.9 * (float(v) - s.min()) / span)
            for w, v in zip(ds.wall.values, s, strict=True)}


def plot_median(ds: xr.Dataset, against: str = "slenderness", axes=None) -> list:
    """Median collapse intensity against ``slenderness`` (one line per diaphragm) or
    against the diaphragm's ``frequency`` (one line per wall; rigid supports left out),
    one panel per supports group."""
    f, unit = _in_g(ds)
    d = _cor(ds)
    groups = _groups(d)
    axes = P.panels(axes, len(groups), ncols=2)
    cmap = _colors(d)
    for ax, (g, labels) in zip(axes, groups.items(), strict=True):
        med = d.median_collapse_intensity.sel(diaphragm=labels) * f
        if against == "slenderness":
            for lab in labels:
                ax.plot(d.slenderness, med.sel(diaphragm=lab), "o-", ms=3, label=lab)
            ax.set_xlabel("slenderness h/t [1]")
            ax.legend(fontsize="x-small", title="diaphragm")
        else:
            freq = d.cell_frequency.sel(diaphragm=labels)
            for w in d.wall.values:
                fx = freq.sel(wall=w).values
                ok = np.isfinite(fx)
                ax.plot(fx[ok], med.sel(wall=w).values[ok], "o-", ms=3, color=cmap[str(w)],
                        label=str(w))
            _log_x(ax)
            ax.set_xlabel("diaphragm frequency (Table IV SDOF) [Hz]")
            ax.legend(fontsize="x-small", ncol=3, title="wall", loc="best")
        ax.set_ylabel(f"median collapse {ds.attrs.get('intensity_measure', '')} [{unit}]")
        ax.set_title(GROUPS.get(g, g), fontsize=9)
        ax.grid(True, alpha=0.3)
    return axes


def resonance_table(ds: xr.Dataset) -> xr.Dataset:
    """Each capacity against the same wall and record on the other flexible diaphragms of
    its supports group: ``log_ratio = ln(capacity / geometric mean over those diaphragms)``
    and ``frequency_ratio = predominant_frequency(record) / cell_frequency``, flattened
    over the (wall, flexible diaphragm, record) cells with a collapse on every diaphragm
    of the group."""
    d = _cor(ds)
    rows = {"group": [], "frequency_ratio": [], "log_ratio": [], "wall": [], "diaphragm": []}
    for g, labels in _groups(d).items():
        flex = [lab for lab in labels if np.all(np.isfinite(d.cell_frequency.sel(
            diaphragm=lab)))]
        if len(flex) < 2:
            continue
        sub = d.sel(diaphragm=flex)
        cap = sub.collapse_intensity.where(sub.censored == 0)
        lc = np.log(cap)
        rel = lc - lc.mean("diaphragm", skipna=False)
        ratio = sub.predominant_frequency / sub.cell_frequency
        rel, ratio = xr.broadcast(rel, ratio)
        ok = np.isfinite(rel.values)
        rows["group"] += [g] * int(ok.sum())
        rows["frequency_ratio"] += list(ratio.values[ok])
        rows["log_ratio"] += list(rel.values[ok])
        w, dd, _ = np.meshgrid(rel.wall.values, rel.diaphragm.values, rel.record.values,
                               indexing="ij")
        order = [rel.dims.index(k) for k in ("wall", "diaphragm", "record")]
        rows["wall"] += list(np.transpose(w, np.argsort(order))[ok])
        rows["diaphragm"] += list(np.transpose(dd, np.argsort(order))[ok])
    return xr.Dataset({k: ("cell", np.asarray(v)) for k, v in rows.items()})


BINS = np.array([0.0, 0.25, 0.5, 0.8, 1.25, 2.0, 4.0, np.inf])


def _binned(t: xr.Dataset, group: str):
    sel = t.group.values == group
    x, y = t.frequency_ratio.values[sel], t.log_ratio.values[sel]
    out = []
    for lo, hi in zip(BINS[:-1], BINS[1:], strict=True):
        m = (x >= lo) & (x < hi)
        out.append((lo, hi, int(m.sum()), float(np.median(y[m])) if m.any() else math.nan))
    return out


def plot_resonance(t: xr.Dataset, axes=None) -> list:
    groups = [g for g in GROUPS if g in set(t.group.values)]
    axes = P.panels(axes, max(1, len(groups)), ncols=2)
    for ax, g in zip(axes, groups, strict=False):
        sel = t.group.values == g
        x, y = t.frequency_ratio.values[sel], np.exp(t.log_ratio.values[sel])
        ax.plot(x, y, ".", ms=2, alpha=0.35, color="0.4")
        b = _binned(t, g)
        xs = [math.sqrt(lo * hi) if np.isfinite(hi) and lo > 0 else (hi / 2 if lo == 0 else
              lo * 2) for lo, hi, _, _ in b]
        ax.plot(xs, [math.exp(m) for *_, m in b], "o-", color="C3", label="binned median")
        ax.axvline(1.0, color="k", lw=0.8, ls=":")
        ax.axhline(1.0, color="k", lw=0.8)
        _log_x(ax)
        ax.set_xlabel("record predominant frequency / diaphragm frequency [1]")
        ax.set_ylabel("relative collapse intensity [1]")
        ax.set_title(GROUPS.get(g, g), fontsize=9)
        ax.legend(fontsize="x-small")
        ax.grid(True, alpha=0.3, which="both")
    return axes


def stiffening(ds: xr.Dataset, soft: str = STIFFEN[0], stiff: str = STIFFEN[1]) -> dict:
    """Per supports group with both diaphragms: the ratio of median collapse intensities
    stiff/soft per wall, and the share of records whose capacity rises."""
    d = _cor(ds)
    out = {}
    for g, labels in _groups(d).items():
        pick = {_base(lab): lab for lab in labels}
        if soft not in pick or stiff not in pick:
            continue
        a, b = d.sel(diaphragm=pick[soft]), d.sel(diaphragm=pick[stiff])
        ratio = b.median_collapse_intensity / a.median_collapse_intensity
        ok = (a.censored == 0) & (b.censored == 0)  # both collapsed (NaN: not run)
        up = ((b.collapse_intensity > a.collapse_intensity) & ok).sum("record") \
            / ok.sum("record")
        out[g] = {"ratio": ratio, "share_up": up, "soft": pick[soft], "stiff": pick[stiff]}
    return out


def plot_stiffening(st: dict, ds: xr.Dataset, ax=None):
    ax = ax if ax is not None else P.panels(None, 1)[0]
    for g, v in st.items():
        ax.plot(ds.slenderness, v["ratio"], "o-", ms=3,
                label=f"{GROUPS.get(g, g).split(' (')[0]}: {v['stiff']} / {v['soft']}")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xlabel("slenderness h/t [1]")
    ax.set_ylabel("median ratio, stiffened / as built [1]")
    ax.legend(fontsize="x-small")
    ax.grid(True, alpha=0.3)
    return ax


# ---- the report ---------------------------------------------------------------------------

def _save(axes, out: Path, name: str) -> str:
    """Write the figure as a palette PNG (256 colours: a third of the size of RGBA)."""
    import io

    from PIL import Image

    fig = np.ravel(axes)[0].figure
    buf = io.BytesIO()
    fig.savefig(buf, dpi=90, format="png")
    buf.seek(0)
    with Image.open(buf) as im:
        im.convert("RGB").quantize(256).save(out / name, optimize=True)
    return f"![{name}]({name})"


def write_report(archive, out_dir: str | os.PathLike) -> Path:
    """Write the figures and ``REPORT.md`` of an IDA archive into `out_dir`.

    Parameters
    ----------
    archive : path or Dataset
        An archive written by ``urmx ida`` (`urmx.run_study` of a study with
        ``[study.ida]``).
    out_dir : path
        Created if needed; figures of the same names are replaced.

    Returns
    -------
    Path
        ``REPORT.md``.
    """
    ds = open_ida(archive)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    f, unit = _in_g(ds)
    im = ds.attrs.get("intensity_measure", "intensity")
    d = _cor(ds)
    groups = _groups(d)
    ran = ds.analyses >= 0
    n_cells = int(ran.sum())
    lines = [
        "# Collapse fragility",
        "",
        f"{ds.attrs.get('title', ds.attrs.get('study_name', ''))}.",
        "",
        "Generated by `urmx fragility-report` (`urmx.fragility_report.write_report`) from the "
        f"archive of study `{ds.attrs.get('study_name', '?')}` ({ds.attrs.get('history', '')}); "
        "do not edit by hand.",
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

    findings_at = len(lines)
    lines += ["## Median collapse intensity and dispersion", ""]
    for g, labels in groups.items():
        lines += [f"{GROUPS.get(g, g).capitalize()}: median [{unit}] (dispersion beta)", ""]
        rows = []
        for w in d.wall.values:
            c = d.sel(wall=w)
            rows.append([str(w), f"{float(c.slenderness):.0f}"] + [
                f"{_fmt(float(c.median_collapse_intensity.sel(diaphragm=lab)) * f)} "
                f"({_fmt(float(c.dispersion.sel(diaphragm=lab)), 2)})" for lab in labels])
        lines += table(["wall", "h/t", *labels], rows) + [""]

    lines += ["## IDA curves per wall and diaphragm", "",
              "Instability ratio (1.0 = collapse) against intensity for every record; red "
              "dots: capacities; dashed: the fitted median.", ""]
    for lab in [str(x) for x in d.diaphragm.values]:
        lines.append(_save(plot_ida_curves(ds, lab), out, f"ida_{_fname(lab)}.png"))
    lines += ["", "## Fragility curves per diaphragm", "",
              "Lognormal fits per wall (lines) and the records' capacities (dots, plotted at "
              "(i - 0.5)/n; censored records are not dotted).", "",
              _save(plot_fragility_curves(ds), out, "fragility_curves.png"), ""]

    # ---- does h/t predict stability?
    rho = spearman(d.median_collapse_intensity.transpose("diaphragm", "wall").values,
                    np.broadcast_to(d.slenderness.values, (d.diaphragm.size, d.wall.size)))
    cap = d.collapse_intensity.where(d.censored == 0).transpose("diaphragm", "record", "wall")
    rho_rec = spearman(cap.values, np.broadcast_to(d.slenderness.values, cap.shape))
    lo_w, hi_w = d.wall.values[np.argmin(d.slenderness.values)], \
        d.wall.values[np.argmax(d.slenderness.values)]
    rows = []
    for i, lab in enumerate(str(x) for x in d.diaphragm.values):
        m = d.median_collapse_intensity.sel(diaphragm=lab)
        rr = rho_rec[i]
        rows.append([lab, _fmt(rho[i], 3), _fmt(np.nanmedian(rr), 3),
                     f"{int(np.sum(rr < 0))}/{int(np.sum(np.isfinite(rr)))}",
                     _fmt(float(m.sel(wall=lo_w) / m.sel(wall=hi_w)), 3)])
    lines += ["## Does slenderness predict stability?", "",
              "Spearman rank correlation of the median collapse intensity with h/t over the "
              "walls; the same per record (median over records, and the records for which "
              "it is negative); and the ratio of the stockiest wall's median to the most "
              f"slender's ({lo_w} / {hi_w}).", "",
              *table(["diaphragm", "rho (medians)", "rho per record (median)",
                      "records with rho < 0", f"median {lo_w} / {hi_w}"], rows), "",
              _save(plot_median(ds, "slenderness"), out, "median_vs_slenderness.png"), ""]

    # ---- resonance
    t = resonance_table(ds)
    lines += ["## Are walls worst when the record's dominant frequency is near the "
              "diaphragm's?", "",
              "Median collapse intensity against the diaphragm's Table IV SDOF frequency "
              "(rigid supports left out):", "",
              _save(plot_median(ds, "frequency"), out, "median_vs_frequency.png"), "",
              "Per record: each capacity over the geometric mean of the same wall and record "
              "on the group's flexible diaphragms, against the record's predominant frequency "
              "(peak of the smoothed Fourier spectrum) over the diaphragm's. Resonance would "
              "show as binned medians below 1 near a frequency ratio of 1.", ""]
    if t.cell.size:
        rows = []
        for g in [g for g in GROUPS if g in set(t.group.values)]:
            for lo, hi, n, m in _binned(t, g):
                rows.append([GROUPS[g].split(" (")[0], f"{lo:g}-{hi:g}", n,
                             _fmt(math.exp(m), 3) if np.isfinite(m) else "-"])
        lines += table(["walls", "frequency ratio", "cells", "median relative capacity"],
                       rows) + [""]
        lines += [_save(plot_resonance(t), out, "resonance.png"), ""]
    else:
        lines += ["_Not available: fewer than two flexible diaphragms in every group._", ""]

    # ---- stiffening
    stf = stiffening(ds)
    lines += [f"## Stiffening the diaphragm: {STIFFEN[0]} -> {STIFFEN[1]}", ""]
    if stf:
        rows = []
        for w in d.wall.values:
            row = [str(w), f"{float(d.slenderness.sel(wall=w)):.0f}"]
            for v in stf.values():
                row += [_fmt(float(v["ratio"].sel(wall=w)), 3),
                        f"{100 * float(v['share_up'].sel(wall=w)):.0f} %"]
            rows.append(row)
        head = ["wall", "h/t"]
        for g, v in stf.items():
            name = GROUPS.get(g, g).split(" (")[0]
            head += [f"{name}: median {v['stiff']} / {v['soft']}",
                     f"{name}: records whose capacity rises"]
        lines += ["Ratio of the median collapse intensity with the stiffened diaphragm to "
                  "the as-built one, and the share of records (both uncensored) for which "
                  "the wall's capacity rises.", "", *table(head, rows), "",
                  _save(plot_stiffening(stf, d), out, "stiffening.png"), ""]
    else:
        lines += [f"_Not available: the archive lacks {STIFFEN[0]} or {STIFFEN[1]}._", ""]
    lines[findings_at:findings_at] = _findings(d, rho, lo_w, hi_w, t, stf)
    path = out / "REPORT.md"
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def _findings(d: xr.Dataset, rho, lo_w: str, hi_w: str, t: xr.Dataset, stf: dict) -> list:
    """The answers in numbers, computed (so they stay true when the report is regenerated)."""
    med = d.median_collapse_intensity
    span = (med.sel(wall=lo_w) / med.sel(wall=hi_w)).values
    ok = np.isfinite(rho)
    lines = ["## Findings", "",
             f"- **Slenderness.** The median collapse intensity falls with h/t on "
             f"{int(np.sum(rho[ok] < 0))} of {int(ok.sum())} diaphragms (Spearman rho "
             f"{_fmt(np.min(rho[ok]), 2)} to {_fmt(np.max(rho[ok]), 2)}); the stockiest "
             f"wall's median is {_fmt(np.nanmin(span), 3)} to {_fmt(np.nanmax(span), 3)} "
             f"times the most slender's."]
    for g in [g for g in GROUPS if t.cell.size and g in set(t.group.values)]:
        b = _binned(t, g)
        near = next(m for lo, hi, n, m in b if lo <= 1.0 < hi)
        low = min(b, key=lambda x: x[3] if np.isfinite(x[3]) else np.inf)
        near_text = (f"a capacity is a median {_fmt(math.exp(near), 3)} times the same wall "
                     "and record's geometric mean over the flexible diaphragms"
                     if np.isfinite(near) else "there are no cells")
        lines.append(
            f"- **Resonance, {GROUPS[g].split(' (')[0]} walls.** Where the record's "
            f"predominant frequency is within 0.8-1.25 of the diaphragm's, {near_text}; the "
            f"lowest binned median is {_fmt(math.exp(low[3]), 3)}, at frequency ratios "
            f"{low[0]:g}-{low[1]:g}.")
    for g, v in stf.items():
        r = v["ratio"]
        up = [str(w) for w in r.wall.values if float(r.sel(wall=w)) > 1.0]
        lines.append(
            f"- **Stiffening {v['soft']} -> {v['stiff']}, {GROUPS[g].split(' (')[0]} "
            f"walls.** The median changes by a factor {_fmt(float(r.min()), 3)} to "
            f"{_fmt(float(r.max()), 3)}; it rises for "
            + (f"{len(up)} of {r.wall.size} walls ({', '.join(up)})" if up else "no wall")
            + ".")
    return lines + [""]
