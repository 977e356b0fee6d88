"""Matplotlib figures, one module per study kind (`urmx.plot.grid`: the paper's Figs. 5-10;
`urmx.plot.ida`: the collapse fragility; `urmx.plot.simulation`: one analysis), one
function per figure; this module holds what they share (display units, panels, labels).

Each function takes the labelled objects of :mod:`urmx.analysis`, draws on ``ax=`` (or
``axes=``) when given and otherwise on a new :class:`matplotlib.figure.Figure` (no
pyplot state, so any backend works; files are written with Agg), labels axes from attrs
as ``long_name [units]`` and returns the axes it drew on.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..errors import InputError
from ..model import PAPER_G

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


def say_if_empty(ax, text: str) -> None:
    """Write `text` in the middle of a panel on which no data was drawn, so a panel says
    why it is empty rather than showing bare axes."""
    if not drawn(ax):
        ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center",
                fontsize="small", color="0.35", wrap=True)


# the figures of each kind, also by their old names `urmx.plot.<name>` (the module it was)
from .grid import (  # noqa: E402, F401
    plot_cor_match,
    plot_histories,
    plot_peak_profiles,
    plot_resonance,
    plot_stability,
    plot_vs_slenderness,
)
from .ida import (  # noqa: E402, F401
    plot_capacity_resonance,
    plot_collapse_risk,
    plot_efficiency,
    plot_fragility_curves,
    plot_ida_curves,
    plot_median,
    plot_stiffening,
)
from .simulation import (  # noqa: E402, F401
    instability_history,
    plot_cell,
    plot_simulation,
    wall_of,
)
