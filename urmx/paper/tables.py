"""The paper's tables beside urmx's: Table III (the walls' trilinear data, :func:`table3`)
and Table VI (the stability of the paper's wall from a single-storey archive,
:func:`table6`). Table IV, the calibration's target, is :func:`urmx.paper.calibration.table4`."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr

from ..analysis import grid as A
from ..catalog import Catalog, load_catalog
from ..variables import attrs as registry_attrs
from .numbers import Paper, load_paper

# ---- Table III -------------------------------------------------------------------------------

TABLE3_QUANTITIES = (  # (paper key, Segment field, scale to the paper's unit, label)
    ("M0", "M0", 1e-3, "M0 [kN m]"),
    ("theta0", "theta0", 1.0, "theta0 [rad]"),
    ("Mi", "Mi", 1e-3, "Mi [kN m]"),
    ("theta1", "theta_a", 1.0, "theta1 [rad]"),
    ("theta2", "theta_b", 1.0, "theta2 [rad]"),
)


def table3(catalog: Catalog | None = None, paper: Paper | None = None) -> list[dict[str, Any]]:
    """Table III beside urmx.Wall's trilinear data of the Table II walls.

    One row per (wall, case, quantity): 3 walls x 3 cases x 5 quantities = 45 numbers.
    Each row: ``wall``, ``case``, ``quantity`` (label with unit), ``paper``, ``urmx``,
    ``difference`` (urmx - paper) and ``relative`` (difference / paper), in the paper's units.
    """
    cat = catalog or load_catalog()
    paper = paper or load_paper()
    rows = []
    for wid, entry in paper["table3"].items():
        wall = cat.walls[wid].wall
        for case in (1, 2, 3):
            seg = wall.segment(case)
            for key, attr, scale, lab in TABLE3_QUANTITIES:
                p = float(entry[f"case{case}"][key])
                u = getattr(seg, attr) * scale
                rows.append(dict(wall=wid, case=case, quantity=lab, paper=p, urmx=u,
                                 difference=u - p, relative=(u - p) / p, pmr=entry["pmr"]))
    return rows


# ---- Table VI ----------------------------------------------------------------------------------

FAMILY1 = (11, 12)  # the unfavourable patterns


def table6(single: xr.Dataset, paper: Paper | None = None, record: str | None = None,
           diaphragms: Sequence[str] | None = None) -> xr.Dataset:
    """Table VI from a single-storey archive: :func:`urmx.analysis.stability_table` for the
    paper's wall, record and COR, with the like-for-like column (2) for walls that rock in
    patterns 11/12: ``peak_lower_drift_family1``, the peak lower-segment drift while in
    those patterns: the kernel's continuous-time output where the archive has it, else read
    from the stored history on the record grid (NaN without one, or never in them).

    ``diaphragms`` default: the paper's D5, the pinned top (when in the study) and D1.
    """
    paper = paper or load_paper()
    record = record or paper.record
    if diaphragms is None:
        ids = [str(d) for d in single["diaphragm"].values]
        diaphragms = [d for d in (paper.stiff, paper.pinned, "D1") if d in ids]
    tab = A.stability_table(single, paper.height, diaphragms, record, cor=paper.cor)
    if "peak_lower_drift_family1" in tab:  # the kernel's continuous-time peak
        tab.attrs["family1_source"] = "kernel (continuous time)"
        return tab
    fam1 = np.full(tab.sizes["diaphragm"], np.nan)
    try:
        hist = A.displacement_histories(single, paper.height, list(tab["diaphragm"].values),
                                        record, cor=paper.cor,
                                        variables=("crack_displacement", "base_displacement"))
        peak = A.peak_in_patterns(hist, "lower_drift", FAMILY1)
        for i, d in enumerate(tab["diaphragm"].values):
            if d in peak["diaphragm"].values:
                fam1[i] = float(peak.sel(diaphragm=d))
        source = "history (record grid)"
    except A.MissingDataError as exc:
        source = f"not available: {exc}"
    tab["peak_lower_drift_family1"] = ("diaphragm", fam1,
                                       registry_attrs("peak_lower_drift_family1"))
    tab.attrs["family1_source"] = source
    return tab

