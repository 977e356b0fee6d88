"""The model against the paper's shake-table tests (Section 5.2): per test wall, the
paper's best COR against the verification sweep (:func:`verification`) and the intensity
at which each wall's stand-in record first collapses it (:func:`intensity`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr

from ..analysis import grid as A
from ..model import PAPER_G
from .numbers import Paper, load_paper, records_manifest


def verification(ds: xr.Dataset, paper: Paper | None = None,
                 manifest: dict | None = None) -> list[dict[str, Any]]:
    """Per (wall, record run) of a verification archive: the paper's best COR against the
    sweep, the stand-in record's intensity and what the source says about the table input.

    Each row: ``wall``, ``record``, ``paper_cor``, ``target`` (text, "" when the paper states
    none), ``best_cor`` (NaN when no COR reproduces the target or there is none),
    ``misfit``, ``cor_step``, ``scaled_pga_g``, ``stated_pga_g`` (NaN when no source states
    it), ``source``, ``collapsed`` (COR values at which the wall collapsed), ``peak_crack``
    [m] at the paper's COR (nearest on grid), ``collapse_time`` there [s] and ``cor_spread``
    (max/min of the peak crack displacement over the sweep, uncollapsed cells).
    """
    paper = paper or load_paper()
    manifest = records_manifest() if manifest is None else manifest
    ds = A.valid_cells(ds)  # cells not run or stopped at the event limit: NaN
    ver = paper["verification"]
    targets = {w: ("collapse_time", float(v["collapse_time"])) for w, v in ver.items()
               if isinstance(v, dict) and "collapse_time" in v}
    match = A.cor_matches(ds, targets)
    cors = np.asarray(ds["cor"].values, float)
    step = float(np.min(np.diff(cors))) if cors.size > 1 else 0.0
    rows = []
    for w in match["wall"].values:
        spec = ver.get(str(w), {})
        paper_cor = float(spec.get("best_cor", math.nan))
        m = match.sel(wall=w)
        for r in match["record"].values:
            cell = ds.sel(wall=w, record=r)
            if "diaphragm" in cell.dims:
                cell = cell.isel(diaphragm=0)
            if not bool(np.isfinite(cell["peak_crack_displacement"]).any()):
                continue  # a cell the study's pairs leave out
            at = A.select(cell, cor=paper_cor if math.isfinite(paper_cor) else None)
            entry = manifest.get(str(r), {})
            pga = float(cell["scaled_pga"]) / PAPER_G if "scaled_pga" in cell.coords else math.nan
            coll = cell["collapsed"] if "collapsed" in cell else None
            collapsed = [float(c) for c, v in zip(cell["cor"].values, coll.values, strict=True)
                         if v == 1] if coll is not None else []
            peak = cell["peak_crack_displacement"]
            if coll is not None:
                peak = peak.where(coll != 1)
            pk = np.asarray(peak.values, dtype=float).ravel()
            pk = pk[np.isfinite(pk)]
            var = m["target_variable"].item()
            rows.append(dict(
                wall=str(w), record=str(r), paper_cor=paper_cor, figure=spec.get("figure", ""),
                paper_input=spec.get("input", ""),
                target=f"{var} = {float(m['target_value']):g}" if var else "",
                best_cor=float(m["best_cor"].sel(record=r)),
                misfit=float(m["misfit"].sel(record=r)), cor_step=step, scaled_pga_g=pga,
                stated_pga_g=float(entry.get("shake_table_pga_g", math.nan)),
                source=entry.get("shake_table_source", "not stated in the records manifest"),
                collapsed=collapsed, cors=cors.tolist(),
                peak_crack=float(at["peak_crack_displacement"]),
                collapse_time=float(at["collapse_time"]) if "collapse_time" in at else math.nan,
                cor_spread=float(pk.max() / pk.min()) if pk.size and pk.min() > 0 else math.nan))
    return rows


def intensity(ds: xr.Dataset, paper: Paper | None = None) -> list[dict[str, Any]]:
    """From a ``verification-intensity`` archive (a ``scale`` dimension on each wall's
    stand-in at the paper's best COR): per wall, the scaled PGA [g] at which the wall first
    collapses, and for a wall whose target is a collapse time, the scale whose collapse time
    is nearest it."""
    paper = paper or load_paper()
    ver = paper["verification"]
    if "scale" not in ds.dims:
        raise A.MissingDataError("the intensity archive has no scale dimension")
    ds = A.valid_cells(ds)  # cells not run or stopped at the event limit: NaN
    rows = []
    for w in ds["wall"].values:
        spec = ver.get(str(w), {})
        cor = float(spec.get("best_cor", ds["cor"].values[0]))
        for r in ds["record"].values:
            cell = ds.sel(wall=w, record=r)
            if "diaphragm" in cell.dims:
                cell = cell.isel(diaphragm=0)
            if not bool(np.isfinite(cell["peak_crack_displacement"]).any()):
                continue
            cell = cell.sel(cor=cor, method="nearest")
            g = (float(cell["scaled_pga"]) / PAPER_G) * np.asarray(cell["scale"].values, float)
            flags = np.asarray(cell["collapsed"].values, float)  # NaN: no valid result
            coll = flags == 1
            ct = np.asarray(cell["collapse_time"].values, float)
            i = int(np.argmax(coll))
            first = float(g[i]) if coll.any() else math.nan
            below = float(g[i - 1]) if coll.any() and i > 0 and flags[i - 1] == 0 \
                else math.nan
            row = dict(wall=str(w), record=str(r), cor=float(cell["cor"]), pga_g=g.tolist(),
                       collapsed=coll.tolist(), collapse_time=ct.tolist(),
                       first_collapse_g=first, last_standing_g=below,
                       base_g=float(cell["scaled_pga"]) / PAPER_G)
            if "collapse_time" in spec and np.isfinite(ct).any():
                i = int(np.nanargmin(np.abs(ct - float(spec["collapse_time"]))))
                row["nearest_collapse"] = (float(g[i]), float(ct[i]))
            rows.append(row)
    return rows
