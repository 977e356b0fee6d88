"""Figures of one analysis: a simulation's histories (``urmx simulate --plot``) and one cell of
an archive computed again (``urmx show``)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..model import Wall
from . import (
    display_scale,
    label,
    panels,
)


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


# ---- collapse fragility (IDA archives, `urmx.analysis.ida`) ---------------------------------


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
