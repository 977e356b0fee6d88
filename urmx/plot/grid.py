"""Figures of a time-history grid (the paper's Figs. 5-10): peaks and instability against
slenderness, histories, resonance, the best-matching COR."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr
from matplotlib.axes import Axes

from . import (
    label,
    marker_size,
    moving,
    panels,
)


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
