"""The building calibration: the parametric building fitted to Table IV's frequencies and
Table VI's instability displacement (:func:`calibrate`), Table IV beside the fit
(:func:`table4`) and the ``calibration.md`` report (:func:`calibration_report`)."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..catalog import Catalog, load_catalog
from ..markdown import table
from ..model import RIGID
from .numbers import Paper, load_paper


@dataclass
class Calibration:
    """Result of :func:`calibrate`: the fitted building and every target with its residual."""

    building: Any
    frequencies: list[dict[str, Any]]  # diaphragm, bound, height, target, model, residual
    instability: dict[str, Any]  # wall, height, target, model, residual, upper_case1, ...
    rms: float


def _table4_targets(cat: Catalog, paper: Paper):
    """(diaphragm id, Table IV stiffness [N m-1], range [Hz]) and the parametric heights."""
    tw = [w.wall for w in cat.walls.values() if w.parametric]
    hmin, hmax = min(w.height for w in tw), max(w.height for w in tw)
    rows = [(d, 1e3 * float(v["stiffness"]), tuple(float(x) for x in v["frequency_range"]))
            for d, v in paper["table4"].items()]
    return rows, hmin, hmax, tw[0].thickness


def sdof_frequency(stiffness: float, wall_mass: float, diaphragm_mass: float) -> float:
    """Table IV footnote: an SDOF of ``stiffness`` over half the walls' effective mass plus
    the diaphragm's. [Hz]"""
    return math.sqrt(stiffness / (0.5 * wall_mass + diaphragm_mass)) / (2.0 * math.pi)


def _evaluate(cat: Catalog, paper: Paper, building) -> Calibration:
    rows, hmin, hmax, t = _table4_targets(cat, paper)
    md = building.diaphragm_mass
    freqs = []
    for d, k, (lo, hi) in rows:
        # the stiffest frequency belongs to the shortest wall
        for bound, h, target in (("low", hmax, lo), ("high", hmin, hi)):
            f = sdof_frequency(k, building.wall_mass(t, h), md)
            freqs.append(dict(diaphragm=d, bound=bound, height=h, target=target, model=f,
                              residual=f / target - 1.0, stiffness=k))
    spec = cat.walls[cat.calibration.get("instability_wall", "s18")]
    w = spec.wall.replace(mass=building.wall_mass(spec.wall.thickness, spec.wall.height),
                          top_mass=md, top_stiffness=RIGID)
    row = paper["table6"]["D1"]
    target = 1e-3 * float(row["ins_lower"])
    lower = w.a1 * w.segment(3).theta0  # Delta_ins lower in patterns 11/12 (Case 3)
    upper0 = w.replace(top_mass=0.0)
    inst = dict(wall=spec.id, height=w.height, target=target, model=lower,
                residual=lower / target - 1.0, upper_case1=w.a2 * w.segment(1).theta0,
                upper_case1_no_diaphragm=upper0.a2 * upper0.segment(1).theta0,
                lower_case2=w.a1 * w.segment(2).theta0, diaphragm_mass=md, wall_mass=w.mass,
                table_upper=1e-3 * float(row["ins_upper"]),
                table_lower_case2=1e-3 * float(paper["table6"]["D5"]["ins_lower"]))
    res = [f["residual"] for f in freqs] + [inst["residual"]]
    return Calibration(building, freqs, inst, float(np.sqrt(np.mean(np.square(res)))))


def calibrate(catalog: Catalog | None = None, paper: Paper | None = None) -> Calibration:
    """Least-squares fit of the wall length and diaphragm weight (density held).

    Targets (relative residuals): both ends of each Table IV frequency range (the upper end
    for the shortest parametric wall, the lower end for the tallest) and Table VI's Delta_ins
    of the lower segment in patterns 11/12 for the calibration wall, weighted by
    ``calibration.instability_weight`` of ``building.toml``. Only density*wall_length enters
    the masses, so the density stays as chosen.
    """
    from scipy.optimize import least_squares

    cat = catalog or load_catalog()
    paper = paper or load_paper()
    weight = float(cat.calibration.get("instability_weight", 1.0))

    def residuals(p):
        c = _evaluate(cat, paper, cat.building.replace(wall_length=p[0], diaphragm_weight=p[1]))
        return [f["residual"] for f in c.frequencies] + [weight * c.instability["residual"]]

    b = cat.building
    fit = least_squares(residuals, [b.wall_length, b.diaphragm_weight], bounds=([0.1, 0], np.inf))
    return _evaluate(cat, paper, b.replace(wall_length=float(fit.x[0]),
                                           diaphragm_weight=float(fit.x[1])))


def table4(catalog: Catalog | None = None, paper: Paper | None = None) -> list[dict[str, Any]]:
    """Table IV's frequency ranges beside the catalog building's (the stored, rounded fit).

    Each row: ``diaphragm``, ``paper_stiffness`` and ``stiffness`` (analysed; inf when rigid)
    [N m-1], ``paper_range`` and ``range`` (tallest to shortest parametric wall) [Hz],
    ``fitted`` (True: the calibration fits this range).
    """
    cat = catalog or load_catalog()
    paper = paper or load_paper()
    stored = _evaluate(cat, paper, cat.building)
    out = []
    for d, k, rng in _table4_targets(cat, paper)[0]:
        f = {x["bound"]: x["model"] for x in stored.frequencies if x["diaphragm"] == d}
        analysed = cat.diaphragms[d].stiffness_value if d in cat.diaphragms else math.nan
        out.append(dict(diaphragm=d, paper_stiffness=k, stiffness=analysed, paper_range=rng,
                        range=(f["low"], f["high"]), fitted=True))
    return out


def calibration_report(out_dir: str | os.PathLike | None = None,
                       catalog: Catalog | None = None, paper: Paper | None = None) -> Path:
    """Write ``calibration.md`` and ``calibration/frequencies.png`` into ``out_dir``
    (default ``reports/`` of the current folder).

    The table shows the catalog's building (as stored, rounded) against Table IV and
    Table VI, and the unrounded least-squares optimum beside it.
    """
    cat = catalog or load_catalog()
    paper = paper or load_paper()
    out = Path(out_dir) if out_dir is not None else Path("reports")
    (out / "calibration").mkdir(parents=True, exist_ok=True)
    stored = _evaluate(cat, paper, cat.building)
    lines = (_calibration_result(cat, stored, calibrate(cat, paper))
             + _calibration_instability(stored.instability))
    (out / "calibration.md").write_text("\n".join(lines), encoding="utf-8")
    _calibration_figure(cat, paper, out / "calibration" / "frequencies.png")
    return out / "calibration.md"


def _calibration_result(cat: Catalog, stored: Calibration, best: Calibration) -> list[str]:
    """The report's head, the fitted building against the optimum, and Table IV."""
    b = cat.building
    return [
        "# Calibration of the parametric building",
        "",
        "Generated by `urmx calibrate` (`urmx.paper.calibration_report`) from "
        "`catalog/building.toml` and the paper's numbers in `catalog/paper.toml`; do not "
        "edit by hand.",
        "",
        "The paper (Section 6) gives the plan but not the masonry density, the diaphragm "
        "seismic weight or the out-of-plane wall length. They set the effective masses (Eq. 7: "
        "8/15 of the nominal masses; the nominal wall mass is both out-of-plane walls, the "
        "nominal diaphragm mass its weight over the plan divided by g), and so Table IV's "
        "indicative frequencies (SDOF: stiffness over half the walls' effective mass plus the "
        "diaphragm's) and Table VI's instability displacement of the lower segment in "
        "patterns 11/12 (Case 3, which depends on m_dt/m). Only density x wall length enters "
        "the masses, so the density is chosen and the wall length and diaphragm weight are "
        "fitted by least squares on relative residuals (the displacement target weighted by "
        "`calibration.instability_weight`).",
        "",
        "## Result",
        "",
        *table(["quantity", "catalog (rounded)", "least-squares optimum"], [
            ["masonry density [kg m-3]", f"{b.density:g} (chosen)", f"{best.building.density:g}"],
            ["out-of-plane wall length [m]", f"{b.wall_length:g}",
             f"{best.building.wall_length:.4f}"],
            ["diaphragm seismic weight [kPa]", f"{b.diaphragm_weight:g}",
             f"{best.building.diaphragm_weight:.4f}"],
            ["diaphragm effective mass [kg]", f"{b.diaphragm_mass:.0f}",
             f"{best.building.diaphragm_mass:.0f}"],
            ["RMS relative residual", f"{stored.rms:.4f}", f"{best.rms:.4f}"]]),
        "",
        "## Table IV: indicative frequencies",
        "",
        "The low end of a range belongs to the tallest parametric wall, the high end to the "
        "shortest. Every diaphragm is analysed as the spring Table IV gives it (D5 included, "
        "with the diaphragm mass); the catalog's `D5-pinned` is a pinned top instead.",
        "",
        *table(["diaphragm", "stiffness [N m-1]", "bound", "wall height [m]", "Table IV [Hz]",
                "model [Hz]", "residual"],
               [[f["diaphragm"], f"{f['stiffness']:.4g}", f["bound"], f"{f['height']:.2f}",
                 f"{f['target']:g}", f"{f['model']:.3f}", f"{f['residual']:+.3f}"]
                for f in stored.frequencies]),
    ]


def _calibration_instability(inst: dict) -> list[str]:
    """Table VI's instability displacements against the calibrated building's."""
    up, lo2 = inst["table_upper"], inst["table_lower_case2"]
    return [
        "",
        f"## Table VI: instability displacements of the {1e3 * inst['height']:.0f} mm wall",
        "",
        *table(["segment, case", "Table VI [mm]", "model [mm]", "residual"], [
            ["lower, patterns 11/12 (Case 3)", f"{1e3 * inst['target']:.0f}",
             f"{1e3 * inst['model']:.1f}", f"{inst['residual']:+.3f}"],
            ["lower, patterns 21/22 (Case 2)", f"{1e3 * lo2:.0f}",
             f"{1e3 * inst['lower_case2']:.1f}", f"{inst['lower_case2'] / lo2 - 1:+.3f}"],
            ["upper (Case 1), diaphragm weight on the wall", f"{1e3 * up:.0f}",
             f"{1e3 * inst['upper_case1']:.1f}", f"{inst['upper_case1'] / up - 1:+.3f}"],
            ["upper (Case 1), m_dt = 0", f"{1e3 * up:.0f}",
             f"{1e3 * inst['upper_case1_no_diaphragm']:.1f}",
             f"{inst['upper_case1_no_diaphragm'] / up - 1:+.3f}"]]),
        "",
        "Table VI's upper-segment Delta_ins equals b, Case 1's Delta_ins = a2*theta0 = "
        "b/2 (m2 + m_dt)/(0.5 m2 + m_dt), which equals b only when no diaphragm weight bears "
        "on the wall (m_dt = 0). With the calibrated diaphragm the upper segment's Delta_ins "
        f"is {1e3 * inst['upper_case1']:.0f} mm; urmx uses it (MODEL.md section 3).",
        f"Masses of that wall: effective wall mass m = {inst['wall_mass']:.0f} kg, "
        f"effective diaphragm mass m_dt = {inst['diaphragm_mass']:.0f} kg.",
        "",
        "![Table IV frequency ranges against the calibrated building]"
        "(calibration/frequencies.png)",
        "",
    ]


def _calibration_figure(cat: Catalog, paper: Paper, path: Path) -> None:
    """Table IV's frequency ranges against the calibrated building, as a PNG at `path`."""
    from matplotlib.figure import Figure

    b = cat.building
    fig = Figure(figsize=(6.5, 4.0))
    ax = fig.subplots()
    rows, hmin, hmax, t = _table4_targets(cat, paper)
    hs = np.linspace(hmin, hmax, 50)
    for i, (d, k, (lo, hi)) in enumerate(rows):
        color = f"C{i}"
        f = [sdof_frequency(k, b.wall_mass(t, h), b.diaphragm_mass) for h in hs]
        ax.plot(hs / t, f, color=color, label=f"{d} model")
        ax.fill_between([hmin / t, hmax / t], lo, hi, color=color, alpha=0.15)
        ax.plot([hmax / t, hmin / t], [lo, hi], "o", color=color, mfc="none")
    ax.set_yscale("log")
    ax.set_xlabel("wall slenderness h/b [1]")
    ax.set_ylabel("diaphragm frequency [Hz]")
    ax.set_title("Table IV ranges (bands, circles) and the calibrated building (lines)",
                 fontsize=9)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
