"""Figures of an IDA archive: IDA curves, fragility curves with their bands, medians against
slenderness and diaphragm frequency, the capacity against resonance, stiffening, the
efficiency of the measures and the collapse risk."""

from __future__ import annotations

import math
import warnings

import numpy as np
import xarray as xr

from ..analysis import ida as FA
from ..fragility import CONFIDENCE, bootstrap_lognormal
from . import (
    display_scale,
    marker_size,
    panels,
    say_if_empty,
)


def _im_scale(ds: xr.Dataset) -> tuple[float, str]:
    """Factor and unit label to show an IDA archive's intensity measure in."""
    return display_scale(ds.collapse_intensity.attrs.get("units", ""))


def plot_ida_curves(ds: xr.Dataset, diaphragm: str, axes=None) -> list:
    """IDA curves (instability ratio against intensity) of every record, one panel per
    wall, for one diaphragm and the first COR."""
    f, unit = _im_scale(ds)
    d = FA.first_cor(ds).sel(diaphragm=diaphragm)
    walls = list(d.wall.values)
    axes = panels(axes, len(walls), ncols=3)
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
                ax.plot([1.0], [cap], "o", ms=marker_size(c.record.size, 5, 2.5), color="C3")
        med = float(c.median_collapse_intensity) * f
        if np.isfinite(med):
            ax.axhline(med, color="C0", ls="--", lw=1.2, label=f"median {med:.3g} {unit}")
            ax.legend(fontsize="x-small", loc="upper left")
        say_if_empty(ax, "no analysis of this wall")
        ax.set_title(f"{w} (h/t {float(c.slenderness):.0f}) on {diaphragm}", fontsize=9)
        ax.set_xlim(0, 1.05)
        ax.set_xlabel("instability ratio [1]")
        ax.set_ylabel(f"{ds.attrs.get('intensity_measure', 'intensity')} [{unit}]")
        ax.grid(True, alpha=0.3)
    return axes


def _band(cap: np.ndarray, cen: np.ndarray, x: np.ndarray, groups=None) -> tuple | None:
    """Pointwise 5-95 % range of the fitted probability at `x` over the bootstrap
    resamples of the records (whole `groups` of them when given;
    `urmx.fragility.bootstrap_lognormal`), or None."""
    from scipy.special import ndtr


    ran = np.isfinite(cap)
    if ran.sum() < 5:
        return None
    try:
        med, beta = bootstrap_lognormal(cap[ran], cen[ran], resamples=200,
                                        groups=None if groups is None else groups[ran])
    except ValueError:
        return None
    ok = np.isfinite(med)
    if not ok.any():
        return None
    p = ndtr(np.log(x[None, :] / med[ok, None]) / beta[ok, None])
    a = (1.0 - CONFIDENCE) / 2.0
    return np.quantile(p, a, axis=0), np.quantile(p, 1.0 - a, axis=0)


def plot_fragility_curves(ds: xr.Dataset, axes=None, band: bool = True) -> list:
    """Fitted collapse fragility of each wall (colour by slenderness) with its bootstrap
    band (shaded: the pointwise 90 % range over 200 resamples of the records, whole
    groups of them where the records have groups: `urmx.analysis.ida.record_groups`),
    one panel per diaphragm, with the records' capacities as empirical distributions
    (dots)."""
    from scipy.stats import norm

    groups = FA.record_groups(ds) if band else None
    groups = None if groups is None else np.asarray(groups)
    f, unit = _im_scale(ds)
    d = FA.first_cor(ds)
    labels = [str(x) for x in d.diaphragm.values]
    axes = panels(axes, len(labels), ncols=3)
    collapsed = d.collapse_intensity.where(d.censored == 0).values
    top = (float(np.nanmax(collapsed)) if np.isfinite(collapsed).any() else
           float(ds.attrs.get("ida_max_intensity", 1.0))) * f * 1.2
    x = np.linspace(1e-3, top, 300)
    cmap = _slenderness_colors(d)
    for ax, lab in zip(axes, labels, strict=True):
        for w in d.wall.values:
            c = d.sel(diaphragm=lab, wall=w)
            med, beta = float(c.median_collapse_intensity) * f, float(c.dispersion)
            col = cmap[str(w)]
            if np.isfinite(med):
                ax.plot(x, norm.cdf(np.log(x / med) / beta), color=col, lw=1.2,
                        label=f"{w}")
                b = _band(c.collapse_intensity.values * f, c.censored.values, x, groups) \
                    if band else None
                if b is not None:
                    ax.fill_between(x, b[0], b[1], color=col, alpha=0.18, lw=0)
            cap = np.sort(c.collapse_intensity.where(c.censored == 0).values * f)
            cap = cap[np.isfinite(cap)]
            n = c.record.size
            ax.plot(cap, (np.arange(cap.size) + 0.5) / n, "o", color=col, alpha=0.6,
                    ms=marker_size(n * d.wall.size, 5, 1.5), mew=0)
        say_if_empty(ax, "no record collapsed a wall here: no fit")
        ax.set_title(lab, fontsize=9)
        ax.set_xlabel(f"{ds.attrs.get('intensity_measure', 'intensity')} [{unit}]")
        ax.set_ylabel("probability of collapse [1]")
        ax.set_ylim(0, 1)
        ax.grid(True, alpha=0.3)
    if axes[0].get_legend_handles_labels()[0]:  # no fitted wall: no legend to show
        axes[0].legend(fontsize="x-small", ncol=2, title="wall")
    return axes


def _log_x(ax) -> None:
    """A log x-axis labelled at 1, 2 and 5 times the powers of ten, as plain numbers."""
    from matplotlib.ticker import FormatStrFormatter, LogLocator, NullFormatter

    ax.set_xscale("log")
    ax.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
    ax.xaxis.set_minor_formatter(NullFormatter())


def _slenderness_colors(ds) -> dict[str, tuple]:
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
    f, unit = _im_scale(ds)
    d = FA.first_cor(ds)
    groups = FA.supports_groups(d)
    axes = panels(axes, len(groups), ncols=2)
    cmap = _slenderness_colors(d)
    for ax, (g, labels) in zip(axes, groups.items(), strict=True):
        med = d.median_collapse_intensity.sel(diaphragm=labels) * f
        if against == "slenderness":
            for lab in labels:
                ax.plot(d.slenderness, med.sel(diaphragm=lab), "o-", label=lab,
                        ms=marker_size(d.wall.size, 6, 3))
            ax.set_xlabel("slenderness h/t [1]")
            ax.legend(fontsize="x-small", title="diaphragm")
        else:
            freq = d.cell_frequency.sel(diaphragm=labels)
            for w in d.wall.values:
                fx = freq.sel(wall=w).values
                ok = np.isfinite(fx)
                ax.plot(fx[ok], med.sel(wall=w).values[ok], "o-", color=cmap[str(w)],
                        ms=marker_size(len(labels), 6, 3),
                        label=str(w))
            _log_x(ax)
            say_if_empty(ax, "no finite median or diaphragm frequency")
            ax.set_xlabel("diaphragm frequency (Table IV SDOF) [Hz]")
            ax.legend(fontsize="x-small", ncol=3, title="wall", loc="best")
        ax.set_ylabel(f"median collapse {ds.attrs.get('intensity_measure', '')} [{unit}]")
        ax.set_title(FA.GROUPS.get(g, g), fontsize=9)
        ax.grid(True, alpha=0.3)
    return axes


def plot_capacity_resonance(t: xr.Dataset, axes=None) -> list:
    """Each capacity relative to the same wall and record on the group's other flexible
    diaphragms against the ratio of the record's predominant frequency to the diaphragm's
    (`urmx.analysis.ida.resonance_table`), with the binned medians; one panel per
    supports group."""
    groups = [g for g in FA.GROUPS if g in set(t.group.values)]
    axes = panels(axes, max(1, len(groups)), ncols=2)
    for ax, g in zip(axes, groups, strict=False):
        sel = t.group.values == g
        x, y = t.frequency_ratio.values[sel], np.exp(t.log_ratio.values[sel])
        ax.plot(x, y, "o", ms=marker_size(x.size, 5, 1.5), mew=0, alpha=0.35, color="0.4")
        b = FA.binned(t, g)
        xs = [math.sqrt(lo * hi) if np.isfinite(hi) and lo > 0 else (hi / 2 if lo == 0 else
              lo * 2) for lo, hi, _, _ in b]
        ax.plot(xs, [math.exp(m) for *_, m in b], "o-", color="C3", label="binned median")
        ax.axvline(1.0, color="k", lw=0.8, ls=":")
        ax.axhline(1.0, color="k", lw=0.8)
        _log_x(ax)
        ax.set_xlabel("record predominant frequency / diaphragm frequency [1]")
        ax.set_ylabel("relative collapse intensity [1]")
        ax.set_title(FA.GROUPS.get(g, g), fontsize=9)
        ax.legend(fontsize="x-small")
        ax.grid(True, alpha=0.3, which="both")
    return axes


def plot_stiffening(st: dict, ds: xr.Dataset, ax=None):
    """The ratio of median collapse intensities, stiffened over as-built diaphragm, against
    slenderness (`urmx.analysis.ida.stiffening`), one line per supports group."""
    ax = ax if ax is not None else panels(None, 1)[0]
    for g, v in st.items():
        ax.plot(ds.slenderness, v["ratio"], "o-", ms=marker_size(ds.wall.size, 6, 3),
                label=f"{FA.GROUPS.get(g, g).split(' (')[0]}: {v['stiff']} / {v['soft']}")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xlabel("slenderness h/t [1]")
    ax.set_ylabel("median ratio, stiffened / as built [1]")
    ax.legend(fontsize="x-small")
    ax.grid(True, alpha=0.3)
    return ax


def plot_efficiency(eff: xr.Dataset, ax=None):
    """The dispersion of the collapse capacities in each intensity measure per diaphragm
    (`urmx.analysis.ida.efficiency`): one dot per wall, a bar at the median over the
    walls."""
    ax = ax if ax is not None else panels(None, 1, ncols=1)[0]
    if ax.figure.get_figwidth() < 8:
        ax.figure.set_size_inches(9.0, 3.8)
    labels = [str(x) for x in eff.diaphragm.values]
    measures = [str(m) for m in eff.measure.values]
    width = 0.8 / len(measures)
    for k, im in enumerate(measures):
        xs = np.arange(len(labels)) + (k - (len(measures) - 1) / 2) * width
        disp = eff.dispersion.sel(measure=im).transpose("diaphragm", "wall").values
        for i, x0 in enumerate(xs):
            ax.plot(np.full(disp.shape[1], x0), disp[i], "o", color=f"C{k}", alpha=0.5,
                    ms=marker_size(disp.shape[1], 5, 2), mew=0)
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN: no fit, said below
            typical = np.nanmedian(disp, axis=1)
        ax.plot(xs, typical, "_", ms=12, mew=2.5, color=f"C{k}",
                label=im)
    say_if_empty(ax, "no dispersion: a fit needs at least two records with a capacity")
    ax.set_xticks(np.arange(len(labels)), labels, fontsize=8)
    ax.set_ylabel("dispersion of the collapse capacity [1]")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize="x-small", ncol=len(measures), loc="upper center")
    ax.grid(True, axis="y", alpha=0.3)
    return ax


def plot_collapse_risk(risk: xr.Dataset, curve, axes=None) -> list:
    """The hazard curve (with the walls' median capacities marked) and the mean annual
    frequency of collapse against slenderness, one line per diaphragm, per supports group
    (`urmx.analysis.ida.collapse_risk`)."""
    groups = FA.supports_groups(risk) if "supports" in risk.coords else {
        "top": [str(x) for x in risk.diaphragm.values]}
    axes = panels(axes, 1 + len(groups), ncols=1 + len(groups))
    f, unit = display_scale(curve.units)
    ax = axes[0]
    ax.loglog(curve.intensity * f, curve.rate, "k-", lw=1.5)
    med = risk.median_collapse_intensity.values.ravel() * f
    at = np.exp(np.interp(np.log(med), np.log(curve.intensity * f), np.log(curve.rate)))
    ax.plot(med, at, "|", color="C3", ms=8, label="walls' medians")
    ax.set_xlabel(f"{curve.im} [{unit}]")
    ax.set_ylabel("mean annual frequency of exceedance [1/yr]")
    ax.set_title("hazard curve", fontsize=9)
    ax.legend(fontsize="x-small")
    ax.grid(True, which="both", alpha=0.3)
    slender = risk.slenderness if "slenderness" in risk.coords else np.arange(risk.wall.size)
    for ax, (g, labels) in zip(axes[1:], groups.items(), strict=True):
        for lab in labels:
            ax.semilogy(slender, risk.rate.sel(diaphragm=lab), "o-", label=lab,
                        ms=marker_size(risk.wall.size, 6, 3))
        say_if_empty(ax, "no rate: no wall has a fitted fragility")
        ax.set_xlabel("slenderness h/t [1]")
        ax.set_ylabel("mean annual frequency of collapse [1/yr]")
        ax.set_title(FA.GROUPS.get(g, g), fontsize=9)
        ax.legend(fontsize="x-small", title="diaphragm")
        ax.grid(True, which="both", alpha=0.3)
    return axes


# ---- one cell of a study, recomputed (``urmx show``) ----------------------------------------
