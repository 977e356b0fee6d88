"""Reductions of IDA archives (`urmx.study.kinds.ida`): supports groups, the resonance of
capacities with the diaphragm's frequency, the effect of stiffening a diaphragm and the rank
correlation of collapse intensities with slenderness (drawn by `urmx.plot`, reported by
`urmx.fragility_report`)."""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from .analysis import spearman

GROUPS = {"top": "single storey (diaphragm on top, ground below)",
          "both": "higher storey (between two diaphragms alike)"}
STIFFEN = ("D1", "D4")  # the stiffening the report measures


def supports_groups(ds: xr.Dataset) -> dict[str, list[str]]:
    """Diaphragm labels by supports (single storey first)."""
    if "supports" not in ds.coords:
        return {"top": [str(d) for d in ds.diaphragm.values]}
    out: dict[str, list[str]] = {}
    for d, s in zip(ds.diaphragm.values, ds.supports.values, strict=True):
        out.setdefault(str(s), []).append(str(d))
    return dict(sorted(out.items(), key=lambda kv: list(GROUPS).index(kv[0])
                       if kv[0] in GROUPS else 9))


def base_label(label: str) -> str:
    """The catalog diaphragm of a label (``D1`` of ``D1/both``)."""
    return label.split("/")[0]


def first_cor(ds: xr.Dataset) -> xr.Dataset:
    """The archive at its first COR (the report shows one)."""
    return ds.isel(cor=0)


def resonance_table(ds: xr.Dataset) -> xr.Dataset:
    """Each capacity against the same wall and record on the other flexible diaphragms of
    its supports group: ``log_ratio = ln(capacity / geometric mean over those diaphragms)``
    and ``frequency_ratio = predominant_frequency(record) / cell_frequency``, flattened
    over the (wall, flexible diaphragm, record) cells with a collapse on every diaphragm
    of the group."""
    d = first_cor(ds)
    rows = {"group": [], "frequency_ratio": [], "log_ratio": [], "wall": [], "diaphragm": []}
    for g, labels in supports_groups(d).items():
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


def binned(t: xr.Dataset, group: str) -> list[tuple[float, float, int, float]]:
    """(low, high, cells, median log ratio) of each frequency-ratio bin (`BINS`) of a
    supports group of a `resonance_table`."""
    sel = t.group.values == group
    x, y = t.frequency_ratio.values[sel], t.log_ratio.values[sel]
    out = []
    for lo, hi in zip(BINS[:-1], BINS[1:], strict=True):
        m = (x >= lo) & (x < hi)
        out.append((lo, hi, int(m.sum()), float(np.median(y[m])) if m.any() else math.nan))
    return out


def stiffening(ds: xr.Dataset, soft: str = STIFFEN[0], stiff: str = STIFFEN[1]) -> dict:
    """Per supports group with both diaphragms: the ratio of median collapse intensities
    stiff/soft per wall, and the share of records whose capacity rises."""
    d = first_cor(ds)
    out = {}
    for g, labels in supports_groups(d).items():
        pick = {base_label(lab): lab for lab in labels}
        if soft not in pick or stiff not in pick:
            continue
        a, b = d.sel(diaphragm=pick[soft]), d.sel(diaphragm=pick[stiff])
        ratio = b.median_collapse_intensity / a.median_collapse_intensity
        ok = (a.censored == 0) & (b.censored == 0)  # both collapsed (NaN: not run)
        up = ((b.collapse_intensity > a.collapse_intensity) & ok).sum("record") \
            / ok.sum("record")
        out[g] = {"ratio": ratio, "share_up": up, "soft": pick[soft], "stiff": pick[stiff]}
    return out


def slenderness_ranks(d: xr.Dataset) -> dict:
    """How the collapse intensities of an archive at one COR rank with slenderness: the
    Spearman rho of the median with h/t over the walls per diaphragm (``rho``), the same per
    record and diaphragm over uncensored capacities (``rho_record``, (diaphragm, record)),
    and the stockiest and the most slender wall (``stocky``, ``slender``)."""
    rho = spearman(d.median_collapse_intensity.transpose("diaphragm", "wall").values,
                   np.broadcast_to(d.slenderness.values, (d.diaphragm.size, d.wall.size)))
    cap = d.collapse_intensity.where(d.censored == 0).transpose("diaphragm", "record", "wall")
    rho_rec = spearman(cap.values, np.broadcast_to(d.slenderness.values, cap.shape))
    return {"rho": rho, "rho_record": rho_rec,
            "stocky": d.wall.values[np.argmin(d.slenderness.values)],
            "slender": d.wall.values[np.argmax(d.slenderness.values)]}
