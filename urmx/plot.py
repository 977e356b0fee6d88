"""Matplotlib figures of the paper (Figs. 5-10), of one analysis and of IDA archives (the
collapse fragility), one function per figure kind.

Each function takes the labelled objects of :mod:`urmx.analysis`, draws on ``ax=`` (or
``axes=``) when given and otherwise on a new :class:`matplotlib.figure.Figure` (no
pyplot state, so any backend works; files are written with Agg), labels axes from attrs
as ``long_name [units]`` and returns the axes it drew on.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from . import fragility_analysis as FA
from .errors import InputError
from .model import PAPER_G

PANEL = (5.0, 3.6)  # inches per panel
DISPLAY_UNITS = {"m": ("mm", 1e3), "m s-2": ("g", 1.0 / PAPER_G)}  # SI -> what engineers compare


def display_scale(units: str) -> tuple[float, str]:
    """(factor, units label) to show a quantity stored in `units` as engineers compare it
    (`DISPLAY_UNITS`: m s-2 in g, m in mm); other units as they are."""
    label, factor = DISPLAY_UNITS.get(units, (units, 1.0))
    return factor, label


def in_display_units(obj):
    """A copy of a DataArray or Dataset with lengths in mm and accelerations in g (attrs
    ``units`` changed accordingly); other variables unchanged. Archives stay SI."""
    if isinstance(obj, xr.Dataset):
        out = obj.copy()
        for name in out.data_vars:
            out[name] = in_display_units(out[name])
        return out
    units = obj.attrs.get("units")
    if units not in DISPLAY_UNITS:
        return obj
    new, factor = DISPLAY_UNITS[units]
    out = obj * factor
    out.attrs = {**obj.attrs, "units": new}
    out.name = obj.name
    return out


def moving(ds: xr.Dataset, variables: Sequence[str], rtol: float = 1e-6) -> list[str]:
    """The variables of ``ds`` that move: peak |value| above ``rtol`` times the largest
    peak among ``variables`` (a support fixed by a constraint stays exactly zero)."""
    peaks = {v: float(np.nanmax(np.abs(ds[v].values))) if ds[v].size else 0.0
             for v in variables if v in ds}
    top = max(peaks.values(), default=0.0)
    return [v for v, p in peaks.items() if top > 0 and p > rtol * top]


def label(da) -> str:
    """``long_name [units]`` from attrs (xarray's ``label_from_attrs``)."""
    name = da.attrs.get("long_name", da.name or "")
    units = da.attrs.get("units")
    return f"{name} [{units}]" if units else str(name)


def panels(axes, n: int, ncols: int | None = None) -> list[Axes]:
    """`n` axes: the first `n` of `axes` when given, else a new figure of `n` panels in
    rows of at most `ncols` (never more columns than panels, and no empty panel: the
    grid's spare places are removed, so a study of one wall or one diaphragm gets one
    panel, not one drawn and two empty)."""
    if axes is not None:
        axes = list(np.ravel(axes))
        if len(axes) < n:
            raise InputError(f"this figure needs {n} axes, {len(axes)} were given")
        return axes[:n]
    n = max(int(n), 1)
    ncols = min(ncols or n, n)
    nrows = -(-n // ncols)
    fig = Figure(figsize=(PANEL[0] * ncols, PANEL[1] * nrows), layout="constrained")
    grid = list(np.ravel(fig.subplots(nrows, ncols, squeeze=False)))
    for spare in grid[n:]:
        spare.remove()
    return grid[:n]


def marker_size(n: int, few: float = 6.0, many: float = 2.0, knee: int = 8) -> float:
    """A marker size [points] for a panel of `n` points: `few` up to `knee` points (a
    study of 3 records shows 3 dots one can see), falling as 1/sqrt(n) to `many` (40
    records x 9 walls stay apart)."""
    if n <= knee:
        return few
    return max(many, few * math.sqrt(knee / n))


def empty_axes(fig) -> list[Axes]:
    """The axes of `fig` on which nothing is drawn (no line, collection, patch, image or
    text of data): what a report must never save."""
    return [ax for ax in fig.axes if not (drawn(ax) or ax.images or ax.texts or ax.tables)]


def _finite_points(values) -> bool:
    try:
        return bool(np.isfinite(np.asarray(values, dtype=float)).any())
    except (TypeError, ValueError):  # categories, dates: points all the same
        return len(values) > 0


def drawn(ax) -> int:
    """How many data artists of `ax` show something: lines with at least one finite
    point, collections with paths or offsets, patches (an empty ``ax.plot([], [])`` does
    not count)."""
    lines = sum(1 for ln in ax.lines if _finite_points(ln.get_ydata()))
    shown = sum(1 for c in ax.collections if len(c.get_paths()) or len(c.get_offsets()))
    return lines + shown + len(ax.patches)


def _hue_label(da: xr.DataArray, hue: str, value) -> str:
    """``D3 (4.8 Hz)`` when the hue has a ``frequency`` coordinate, else the value."""
    if hue == "diaphragm" and "frequency" in da.coords and "diaphragm" in da["frequency"].dims:
        f = float(da["frequency"].sel(diaphragm=value))
        return f"{value} ({f:.2g} Hz)" if np.isfinite(f) else f"{value} (pinned)"
    return str(value)


def plot_vs_slenderness(da: xr.DataArray, hue: str = "diaphragm", ax: Axes | None = None,
                        title: str | None = None) -> Axes:
    """One line per ``hue`` value of ``da`` (over ``wall`` and ``hue``) against
    ``slenderness(wall)`` (one panel of Figs. 6, 7, 9, 10); a diaphragm's legend entry
    carries its frequency when ``da`` has the ``frequency`` coordinate."""
    ax = ax if ax is not None else panels(None, 1)[0]
    da = da.sortby("slenderness")
    x = da["slenderness"].values
    for value in da[hue].values:
        ax.plot(x, da.sel({hue: value}).values, marker="o", ms=marker_size(x.size, 5, 3),
                label=_hue_label(da, hue, value))
    ax.set_xlabel("slenderness h/t [1]")
    ax.set_ylabel(label(da))
    ax.legend(title=hue, fontsize="small")
    ax.grid(True, alpha=0.3)
    if title:
        ax.set_title(title)
    return ax


def plot_peak_profiles(ds: xr.Dataset, axes: Sequence[Axes] | None = None) -> list[Axes]:
    """Figs. 6 and 7: (a) wall top and (b) crack height, peak against slenderness, one
    line per diaphragm; ``ds`` from :func:`urmx.analysis.peak_profiles`."""
    names = list(ds.data_vars)
    axes = panels(axes, len(names))
    for letter, name, ax in zip("abcdef", names, axes, strict=False):
        plot_vs_slenderness(ds[name], ax=ax,
                            title=f"({letter}) {ds[name].attrs.get('long_name', name)}")
    return axes


def plot_stability(da: xr.DataArray, axes: Sequence[Axes] | None = None,
                   titles: dict | None = None) -> list[Axes]:
    """Figs. 9 and 10: one panel per record in the order of ``da``'s record dimension,
    governing instability ratio against slenderness, one line per diaphragm; ``da`` from
    :func:`urmx.analysis.governing_instability`; ``titles`` by record id (default the id)."""
    records = [str(r) for r in da["record"].values]
    axes = panels(axes, len(records))
    titles = titles or {}
    for letter, record, ax in zip("abcdefgh", records, axes, strict=False):
        plot_vs_slenderness(da.sel(record=record), ax=ax,
                            title=f"({letter}) {titles.get(record, record)}")
        ax.axhline(1.0, color="k", lw=0.8, ls="--")
    return axes


def plot_histories(ds: xr.Dataset, hue: str = "diaphragm",
                   variables: Sequence[str] | None = None,
                   axes: Sequence[Axes] | None = None) -> list[Axes]:
    """Figs. 5 and 8: one panel per variable, one line per ``hue`` value, against time;
    ``ds`` from :func:`urmx.analysis.displacement_histories` (hue ``diaphragm``) or
    :func:`urmx.analysis.verification_histories` (hue ``record``); by default the variables
    that move (:func:`moving`)."""
    if variables is None:
        variables = moving(ds, [v for v in ds.data_vars if v != "pattern"])
    axes = panels(axes, len(variables), ncols=1)
    for letter, name, ax in zip("abcdefgh", variables, axes, strict=False):
        da = ds[name]
        for value in da[hue].values:
            ax.plot(da["time"].values, da.sel({hue: value}).values, lw=0.8,
                    label=f"{hue} {value}")
        ax.set_xlabel(label(ds["time"]) if ds["time"].attrs else "time [s]")
        ax.set_ylabel(label(da))
        ax.set_title(f"({letter}) {da.attrs.get('long_name', name)}")
        ax.legend(fontsize="small")
        ax.grid(True, alpha=0.3)
    return axes


def plot_resonance(res: xr.Dataset, ax: Axes | None = None) -> Axes:
    """The resonance view: each record's significant frequency range as a band (one row
    per record), each diaphragm's frequency as a marker on every row, coloured by the
    change in mean instability ratio from the stiffest diaphragm; ``res`` from
    :func:`urmx.analysis.resonance`."""
    ax = ax if ax is not None else panels(None, 1)[0]
    records = [str(r) for r in res["record"].values]
    change = res["stability_change"]
    lim = float(np.nanmax(np.abs(change.values))) or 1.0
    freq = res["frequency"].values.astype(float)
    finite = freq[np.isfinite(freq)]
    top = max(float(res["frequency_high"].max()), *(finite if finite.size else [1.0])) * 2
    shown = np.where(np.isfinite(freq), freq, top)  # a rigid diaphragm sits at the right edge
    for row, record in enumerate(records):
        lo = float(res["frequency_low"].sel(record=record))
        hi = float(res["frequency_high"].sel(record=record))
        ax.broken_barh([(lo, hi - lo)], (row - 0.3, 0.6), color="0.85")
        points = ax.scatter(shown, np.full(shown.shape, row), c=change.sel(record=record),
                            cmap="coolwarm", vmin=-lim, vmax=lim, s=60, edgecolors="k",
                            zorder=3)
        for d, f in zip(res["diaphragm"].values, shown, strict=True):
            ax.annotate(str(d), (f, row), xytext=(0, 7), textcoords="offset points",
                        ha="center", fontsize="x-small")
    ax.set_xscale("log")
    if not np.all(np.isfinite(freq)):
        ax.annotate("pinned (rigid) at the right edge", (1.0, 0.0), xycoords="axes fraction",
                    ha="right", va="bottom", fontsize="x-small")
    ax.set_yticks(range(len(records)), records)
    ax.set_xlabel(label(res["frequency"]))
    ax.set_title("diaphragm frequency vs record significant range")
    ax.figure.colorbar(points, ax=ax, label=label(change))
    return ax


def plot_cor_match(da: xr.DataArray, target: float | None = None,
                   paper_cor: float | None = None, ax: Axes | None = None) -> Axes:
    """A response against COR, one line per record run (lines that are all NaN, cells a
    study did not run, are left out), with the target value (horizontal) and the paper's
    best COR (vertical) when given. A response flat to round-off is drawn flat: the y-range
    spans at least 1 % of its magnitude."""
    ax = ax if ax is not None else panels(None, 1)[0]
    others = [d for d in da.dims if d != "cor"]
    stacked = da.stack(line=others) if others else da.expand_dims(line=[0])
    shown = []
    for i in range(stacked.sizes["line"]):
        line = stacked.isel(line=i)
        if not np.isfinite(line.values).any():
            continue
        tag = ", ".join(str(line[d].values) for d in others) if others else str(da.name)
        ax.plot(da["cor"].values, line.values, marker="o", ms=3, label=tag)
        shown.append(line.values)
    values = np.concatenate(shown) if shown else np.array([])
    values = values[np.isfinite(values)]
    if values.size:
        lo, hi = float(values.min()), float(values.max())
        if target is not None and np.isfinite(target):
            lo, hi = min(lo, target), max(hi, target)
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        half = max(half, 0.005 * max(abs(mid), abs(lo), abs(hi)), 1e-300)
        ax.set_ylim(mid - 1.2 * half, mid + 1.2 * half)
        ax.ticklabel_format(axis="y", useOffset=False)
    else:
        ax.text(0.5, 0.5, "no finite response (e.g. no collapse at any COR)",
                transform=ax.transAxes, ha="center", fontsize="small")
    if target is not None and np.isfinite(target):
        ax.axhline(target, color="k", ls="--", lw=0.8, label="target")
    if paper_cor is not None and np.isfinite(paper_cor):
        ax.axvline(paper_cor, color="r", ls=":", lw=0.8, label="paper's COR")
    ax.set_xlabel("coefficient of restitution [1]")
    ax.set_ylabel(label(da))
    ax.legend(fontsize="small")
    ax.grid(True, alpha=0.3)
    return ax


def plot_simulation(ds: xr.Dataset, axes: Sequence[Axes] | None = None) -> list[Axes]:
    """One analysis over time (``urmx simulate --plot``): (a) wall top, crack and base
    displacement [mm]; (b) the rocking pattern (0 after a stop); a dashed line at the
    collapse. ``ds`` from :func:`urmx.simulate` with ``history=True``."""
    if axes is None:
        fig = Figure(figsize=(8, 5.5), layout="constrained")
        axes = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": (3, 1)})
    ax1, ax2 = panels(axes, 2)
    t = ds["time"].values
    for name, colour in (("top_displacement", "C0"), ("crack_displacement", "C1"),
                         ("base_displacement", "C2")):
        ax1.plot(t, 1e3 * ds[name].values, color=colour, lw=0.9,
                 label=ds[name].attrs["long_name"])
    ax1.set_ylabel("displacement relative to ground [mm]")
    ax1.legend(loc="upper right", fontsize="small")
    ax1.grid(alpha=0.3)
    levels = np.array([0, 11, 12, 21, 22])  # 0 after a stop
    ax2.step(t, np.searchsorted(levels, ds["pattern"].values), where="post", color="k", lw=0.9)
    ax2.set_yticks(range(levels.size), [str(v) for v in levels])
    ax2.set_ylabel(ds["pattern"].attrs["long_name"])
    ax2.set_xlabel(label(ds["time"]))
    ax2.grid(alpha=0.3)
    if int(ds["collapsed"]):
        for ax in (ax1, ax2):
            ax.axvline(float(ds["collapse_time"]), color="r", ls="--", lw=0.8)
    ax1.figure.suptitle(f"status {ds.attrs['status']}, scale {ds.attrs['scale']:g}, "
                        f"cor {ds.attrs['cor']:g}, peak u_t "
                        f"{1e3 * float(ds['peak_top_displacement']):.1f} mm")
    return [ax1, ax2]


# ---- collapse fragility (IDA archives, `urmx.fragility_analysis`) ---------------------------

def say_if_empty(ax, text: str) -> None:
    """Write `text` in the middle of a panel on which no data was drawn, so a panel says
    why it is empty rather than showing bare axes."""
    if not drawn(ax):
        ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center",
                fontsize="small", color="0.35", wrap=True)


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

    from .fragility import CONFIDENCE, bootstrap_lognormal

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
    groups of them where the records have groups: `urmx.fragility_analysis.record_groups`),
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
    (`urmx.fragility_analysis.resonance_table`), with the binned medians; one panel per
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
    slenderness (`urmx.fragility_analysis.stiffening`), one line per supports group."""
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
    (`urmx.fragility_analysis.efficiency`): one dot per wall, a bar at the median over the
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
    (`urmx.fragility_analysis.collapse_risk`)."""
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

def instability_history(ds: xr.Dataset, wall) -> xr.DataArray:
    """The governing instability ratio over time of one analysis with histories: the
    larger of |theta_lower| / theta0 (theta0 of the lower segment's case in the family of
    the pattern at that time: 11/12 case 3, 21/22 case 2) and |theta_upper| / theta0 of
    case 1, as the kernel defines the scalar (a running peak of it, on the record grid,
    approaches ``instability_ratio``; 1 at a collapse)."""
    theta0 = {case: wall.segment(case).theta0 for case in (1, 2, 3)}
    fam1 = np.isin(ds["pattern"].values, (11, 12))
    lower = np.abs(ds["theta_lower"].values) / np.where(fam1, theta0[3], theta0[2])
    upper = np.abs(ds["theta_upper"].values) / theta0[1]
    return xr.DataArray(np.maximum(lower, upper), dims="time", coords={"time": ds["time"]},
                        name="instability_ratio",
                        attrs={"long_name": "governing instability ratio", "units": "1"})


def wall_of(ds: xr.Dataset):
    """The `urmx.Wall` of an analysis Dataset, from its ``wall_<field>`` attributes."""
    from .model import Wall

    fields = {k[len("wall_"):]: v for k, v in ds.attrs.items() if k.startswith("wall_")}
    for k in ("allow_unusual",):
        if k in fields:
            fields[k] = bool(fields[k])
    return Wall(**fields)


def plot_cell(ds: xr.Dataset, title: str = "", axes=None) -> list[Axes]:
    """One cell over time (``urmx show``): (a) displacement at crack height and at the
    top [mm]; (b) the rocking pattern; (c) the ground acceleration beneath, as analysed
    [g]; (d) the governing instability ratio (`instability_history`) with its running
    peak and the exact peak the kernel tracks. A dashed red line at a collapse."""
    if axes is None:
        fig = Figure(figsize=(9, 8.5), layout="constrained")
        axes = fig.subplots(4, 1, sharex=True,
                            gridspec_kw={"height_ratios": (3, 1.2, 1.6, 1.8)})
    ax1, ax2, ax3, ax4 = panels(axes, 4)
    t = ds["time"].values
    for name, colour in (("top_displacement", "C0"), ("crack_displacement", "C1")):
        ax1.plot(t, 1e3 * ds[name].values, color=colour, lw=0.9,
                 label=ds[name].attrs["long_name"])
    ax1.set_ylabel("displacement relative\nto ground [mm]")
    ax1.legend(loc="upper right", fontsize="small")
    levels = np.array([0, 11, 12, 21, 22])  # 0 after a stop
    ax2.step(t, np.searchsorted(levels, ds["pattern"].values), where="post", color="k", lw=0.9)
    ax2.set_yticks(range(levels.size), [str(v) for v in levels])
    ax2.set_ylabel("rocking\npattern")
    f, unit = display_scale("m s-2")
    ax3.plot(t, f * ds["ground_acceleration"].values, color="0.3", lw=0.6)
    ax3.set_ylabel(f"ground\nacceleration [{unit}]")
    ratio = instability_history(ds, wall_of(ds)).values
    ax4.plot(t, ratio, color="C3", lw=0.7, label="instability ratio")
    ax4.plot(t, np.maximum.accumulate(ratio), color="C3", lw=1.2, ls=":", label="running peak")
    ax4.axhline(float(ds["instability_ratio"]), color="k", lw=0.8, ls="--",
                label=f"exact peak {float(ds['instability_ratio']):.3g}")
    ax4.set_ylabel("governing instability\nratio [1]")
    ax4.set_xlabel(label(ds["time"]))
    ax4.legend(loc="upper left", fontsize="small")
    for ax in (ax1, ax2, ax3, ax4):
        ax.grid(alpha=0.3)
        if int(ds["collapsed"]):
            ax.axvline(float(ds["collapse_time"]), color="r", ls="--", lw=0.8)
    ax1.set_title(title or f"status {ds.attrs['status']}", fontsize="medium")
    return [ax1, ax2, ax3, ax4]
