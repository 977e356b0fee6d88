"""The paper's layer: its numbers, the building fitted to them, its tables beside urmx's and
every finding of its Sections 6-7 as a criterion that can fail.

The paper's numbers live in one data file, ``catalog/paper.toml`` (:func:`load_paper`); the
significant frequency range of each record (Table V) is the records manifest's
``paper_frequency_range_hz``. Nothing here types a paper number: texts are generated from
those files and from the archives.

- :func:`calibrate`, :func:`calibration_report`: the parametric building fitted to Table IV's
  frequencies and Table VI's instability displacement;
- :func:`table3`, :func:`table4`, :func:`table6`: the paper's tables beside urmx's;
- :func:`findings`: one row per statement of Sections 6-7, with its criterion, the measured
  value, the verdict and, where urmx disagrees, the measured cause (a re-run of the criterion
  with the other D5 model or another record) or "not known";
- :func:`verification`: per test wall, the paper's best COR against the sweep, with the
  stand-in record's intensity and what the source says about the table input.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import lru_cache, partial
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..analysis import grid as A
from ..catalog import Catalog, CatalogError, catalog_dir, load_catalog
from ..config import records_dir
from ..errors import MissingFileError
from ..kernel import warm_up
from ..markdown import table
from ..model import PAPER_G, RIGID
from ..study.clients import get_client, owning
from ..study.engine import run_study
from ..variables import attrs as registry_attrs

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib
from .. import records

# ---- criteria thresholds (urmx's choices, not the paper's numbers) ----------------------------
#: a magnitude the paper states as "nearly X" agrees within this absolute band [1]
MAGNITUDE_BAND = 0.2
#: a ratio the paper prints agrees within this factor (records are stand-ins) [1]
RATIO_FACTOR = 2.0
#: |Spearman rho| below this is "no (clear) relation", above its complement "consistent" [1]
NO_RELATION = 0.5
#: |Spearman rho| below this over the grid counts as "irregular" [1]
IRREGULAR = 0.8
#: relative spread (max - min)/mean over slenderness below this is "almost constant" [1]
ALMOST_CONSTANT = 0.5
#: a fall of the instability ratio by more than this share is "significant" [1]
SIGNIFICANT_FALL = 0.25
#: "many situations": at least this share of the cases [1]
MANY = 0.10
#: a share of the duration "only" a little: at most this [1]
SMALL_SHARE = 0.05
FAMILY1 = (11, 12)  # the unfavourable patterns
#: the catalog studies of the paper, in the order `urmx paper` runs them (`urmx.report`
#: reads their archives)
STUDIES = ("paper-single-storey", "paper-multi-storey", "verification",
           "verification-intensity")


def run_paper(out: str | os.PathLike = "results", scheduler: Any = None,
              wrap: Callable[[Path, Callable[[], Any]], Any] | None = None,
              say: Callable[[str], Any] | None = None, **options: Any) -> list[Path]:
    """Run the paper's studies (:data:`STUDIES`) into ``<out>/<study>.nc`` on one cluster
    (``urmx paper``); returns the archives' paths, which `urmx.reports.paper.write_report`
    makes the paper's report of.

    Parameters
    ----------
    out : path
        Folder of the archives (created if needed); a study whose archive is complete is
        not run again (`urmx.run_study` resumes).
    scheduler : optional
        As for `urmx.run_study`; one client serves all four studies (``"serial"``: none).
    wrap : callable, optional
        ``wrap(path, run)`` calls ``run()``, the run of the study writing `path` (the
        command line says there what an interrupted run keeps); default: ``run()``.
    say : callable, optional
        Told the study about to run (``name -> path``).
    **options
        Any other keyword of `urmx.run_study` (progress, batch_size, records_dir, command,
        force, max_cells, max_gb).
    """
    out = Path(out)
    records_dir(options.get("records_dir"))  # a missing folder is said before a cluster
    archives = []
    client = get_client(scheduler, warm_up) if scheduler != "serial" else (None, False)
    with owning(*client) as client:
        for name in STUDIES:
            path = out / f"{name}.nc"
            if say is not None:
                say(f"{name} -> {path}")
            run = partial(run_study, name, out=path,
                          scheduler=client if client else "serial", **options)
            (wrap or (lambda _, run: run()))(path, run)
            archives.append(path)
    return archives


# ---- the paper's numbers ----------------------------------------------------------------------

@dataclass(frozen=True)
class Paper:
    """The contents of ``catalog/paper.toml`` (see that file for every key and unit)."""

    data: dict
    path: Path | None = None

    def __getitem__(self, key: str) -> Any:
        return self.data[key]

    @property
    def cor(self) -> float:
        return float(self.data["parametric"]["cor"])

    @property
    def record(self) -> str:
        """The record of Figs. 6-8 and Table VI."""
        return str(self.data["parametric"]["response_record"])

    @property
    def height(self) -> float:
        """Height of the wall of Fig. 8 and Table VI. [m]"""
        return float(self.data["parametric"]["fig8_height"])

    @property
    def panel_records(self) -> list[str]:
        return list(self.data["parametric"]["panel_records"])

    @property
    def timber(self) -> list[str]:
        return list(self.data["parametric"]["timber"])

    @property
    def stiff(self) -> str:
        return str(self.data["parametric"]["stiff"])

    @property
    def pinned(self) -> str:
        return str(self.data["parametric"]["pinned"])


def load_paper(path: str | os.PathLike | None = None) -> Paper:
    """Read ``catalog/paper.toml`` (or ``path``)."""
    return _load_paper(str(path) if path is not None else str(catalog_dir() / "paper.toml"))


@lru_cache(maxsize=4)
def _load_paper(path: str) -> Paper:
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise MissingFileError(f"{path}: no such file (the paper's numbers)") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CatalogError(f"{path}: cannot be read as a TOML file "
                           f"({getattr(exc, 'strerror', None) or exc})") from None
    try:
        return Paper(tomllib.loads(text), Path(path))
    except tomllib.TOMLDecodeError as exc:
        raise CatalogError(f"{path}: not valid TOML: {exc}") from None


def significant_frequency(manifest: dict | None = None) -> dict[str, tuple[float, float]]:
    """Table V's significant frequency range of every paper record, from the records
    manifest's ``paper_frequency_range_hz`` (``{record id: (low, high)}`` [Hz])."""
    if manifest is None:
        manifest = records.manifest()
    out = {}
    for rid, entry in manifest.items():
        text = entry.get("paper_frequency_range_hz")
        if text:
            lo, hi = (float(x) for x in str(text).split("-"))
            out[rid] = (lo, hi)
    return out


def _manifest() -> dict:
    try:
        return records.manifest()
    except (FileNotFoundError, ValueError):
        return {}


# ---- the building calibration (Table IV frequencies, Table VI Delta_ins) ---------------------

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


# ---- findings -----------------------------------------------------------------------------------

@dataclass
class Context:
    """What a criterion reads: the archives, the paper, and the choices a variant changes."""

    single: xr.Dataset | None
    multi: xr.Dataset | None
    verification: xr.Dataset | None
    paper: Paper
    record: str  # the record of Figs. 6-8 and Table VI
    stiff: str  # the diaphragm taken as the paper's D5
    ranges: dict = field(default_factory=dict)  # significant frequency ranges by record
    intensity: xr.Dataset | None = None  # a verification-intensity archive

    def need(self, kind: str) -> xr.Dataset:
        ds = getattr(self, kind)
        if ds is None:
            raise A.MissingDataError(f"no {kind} archive was given")
        return ds

    def diaphragms(self, ds: xr.Dataset, stiff: bool = True) -> list[str]:
        """The paper's diaphragms present in ``ds`` (timber, then this context's D5)."""
        ids = [str(d) for d in ds["diaphragm"].values]
        want = self.paper.timber + ([self.stiff] if stiff else [])
        out = [d for d in want if d in ids]
        if len(out) < 2:
            raise A.MissingDataError(f"too few of the paper's diaphragms ({', '.join(want)}) "
                                     "in the study")
        return out

    def ratio(self, kind: str, stiff: bool = True) -> xr.DataArray:
        ds = self.need(kind)
        r = A.governing_instability(ds, cor=self.paper.cor)
        return r.sel(diaphragm=self.diaphragms(ds, stiff))

    def peaks(self, quantity: str) -> xr.Dataset:
        ds = self.need("single")
        pk = A.peak_profiles(ds, quantity, self.record, cor=self.paper.cor)
        return pk.sel(diaphragm=self.diaphragms(ds))


@dataclass(frozen=True)
class Finding:
    """One statement of the paper and its criterion.

    ``check(ctx)`` returns (measured text, agree). ``varies`` names what a disagreement is
    re-measured with: ``"stiff"`` (the other D5 model) and/or ``"record"`` (the other
    records, for a statement on one record).
    """

    key: str
    section: str
    statement: str
    criterion: str
    check: Callable[[Context], tuple[str, bool]]
    varies: tuple[str, ...] = ()
    about: str = "all"  # records it rests on: "all", "response", "verification" or an id
    explain: Callable[[Context], str] | None = None  # a measured cause beyond the variants


def _finite(values) -> np.ndarray:
    v = np.asarray(values, dtype=float).ravel()
    return v[np.isfinite(v)]


def _rho(da: xr.DataArray, coord: str, dim: str) -> np.ndarray:
    vals = _finite(A.rank_correlation(da, coord, dim).values)
    if vals.size == 0:
        raise A.MissingDataError("no finite rank correlations (too few walls or diaphragms)")
    return vals


def _majority(vals: np.ndarray, sign: int, what: str) -> tuple[str, bool]:
    k = int((np.sign(vals) == sign).sum())
    med = float(np.median(vals))
    text = (f"median rho {med:+.2f}; rho {'>' if sign > 0 else '<'} 0 for {k} of {vals.size} "
            f"{what}")
    return text, bool(np.sign(med) == sign and k > vals.size / 2)


def _pct(x: float) -> str:
    return f"{100 * x:.3g} %"


def _timber(p: Paper) -> tuple[str, str, str, str]:
    """The paper's four timber diaphragms, most flexible first (D1, D2, D3, D4)."""
    t = p.timber
    return t[0], t[1], t[2], t[-1]


def _wall_name(p: Paper) -> str:
    return f"the {1e3 * p.height:.0f} mm wall"


# ---- the checks: each returns (measured text, agree) from a Context -----------------------------

def _check_trend(quantity: str, where: str, sign: int) -> Callable[[Context], tuple]:
    """Peak `where` `quantity` rises (sign +1) or falls (-1) with stiffness, per wall."""
    def run(ctx):
        pk = ctx.peaks(quantity)
        return _majority(_rho(pk[f"peak_{where}_{quantity}"], "stiffness", "diaphragm"),
                         sign, "walls")
    return run


def _increase(ctx: Context, where: str) -> xr.DataArray:
    """Relative increase of the peak `where` acceleration from D1 to D4, by slenderness."""
    d1, _, _, d4 = _timber(ctx.paper)
    pk = ctx.peaks("acceleration")[f"peak_{where}_acceleration"]
    return (pk.sel(diaphragm=d4) / pk.sel(diaphragm=d1) - 1.0).sortby("slenderness")


def _check_crack_magnitude(ctx: Context) -> tuple[str, bool]:
    d1, _, _, d4 = _timber(ctx.paper)
    inc = _increase(ctx, "crack")
    i = int(np.nanargmax(inc.values))
    big = float(inc.values[i])
    ok = abs(big - float(ctx.paper["section6"]["crack_acceleration_increase"])) \
        <= MAGNITUDE_BAND
    return (f"largest {d1} to {d4} increase {big:+.0%} (h/t "
            f"{float(inc['slenderness'].values[i]):g})", ok)


def _check_crack_where(ctx: Context) -> tuple[str, bool]:
    inc = _increase(ctx, "crack")
    i = int(np.nanargmax(inc.values))
    hts = inc["slenderness"].values
    ok = float(hts[i]) == float(ctx.paper["section6"]["crack_acceleration_slenderness"])
    return (f"largest at h/t {float(hts[i]):g} ({float(inc.values[i]):+.0%}); at h/t "
            f"{float(hts[0]):g}: {float(inc.values[0]):+.0%}", ok)


def _check_top_particularly(ctx: Context) -> tuple[str, bool]:
    d1, _, _, d4 = _timber(ctx.paper)
    top = float(np.nanmedian(_increase(ctx, "top").values))
    crack = float(np.nanmedian(_increase(ctx, "crack").values))
    return (f"median {d1} to {d4} increase: top {top:+.0%}, crack height {crack:+.0%}",
            top > crack)


def _check_stiffening(ctx: Context) -> tuple[str, bool]:
    _, d2, _, d4 = _timber(ctx.paper)
    pk = ctx.peaks("acceleration")["peak_top_acceleration"]
    more = (pk.sel(diaphragm=d4) > pk.sel(diaphragm=d2)).values
    rel = float(np.nanmedian((pk.sel(diaphragm=d4) / pk.sel(diaphragm=d2) - 1).values))
    return (f"top acceleration {d4} > {d2} for {int(more.sum())} of {more.size} walls "
            f"(median {rel:+.0%})", bool(more.sum() > more.size / 2))


def _check_top_constant(ctx: Context) -> tuple[str, bool]:
    pk = ctx.peaks("displacement")["peak_top_displacement"]
    parts, ok = [], 0
    ids = [d for d in ctx.paper.timber if d in pk["diaphragm"].values]
    for d in ids:
        v = pk.sel(diaphragm=d).values
        spread = float((np.nanmax(v) - np.nanmin(v)) / np.nanmean(v))
        ok += spread < ALMOST_CONSTANT
        parts.append(f"{d} {spread:.2f}")
    return (f"relative spread over slenderness: {', '.join(parts)}", ok > len(ids) / 2)


def _check_crack_irregular(ctx: Context) -> tuple[str, bool]:
    pk = ctx.peaks("displacement")["peak_crack_displacement"]
    by_k = float(np.median(np.abs(_rho(pk, "stiffness", "diaphragm"))))
    by_s = float(np.median(np.abs(_rho(pk, "slenderness", "wall"))))
    return (f"median |rho| with stiffness (per wall) {by_k:.2f}, with slenderness (per "
            f"diaphragm) {by_s:.2f}", min(by_k, by_s) < IRREGULAR)


def _table6_of(ctx: Context, ids: list[str]) -> xr.Dataset:
    return table6(ctx.need("single"), ctx.paper, ctx.record, diaphragms=ids)


def _check_share_small(ctx: Context) -> tuple[str, bool]:
    v = float(_table6_of(ctx, [ctx.stiff])["unfavourable_fraction"].values[0])
    return f"{ctx.stiff}: {_pct(v)}", 0.0 < v <= SMALL_SHARE


def _check_share_large(ctx: Context) -> tuple[str, bool]:
    d1 = _timber(ctx.paper)[0]
    v = float(_table6_of(ctx, [d1])["unfavourable_fraction"].values[0])
    return f"{d1}: {_pct(v)}", v > float(ctx.paper["unfavourable"]["D1_more_than"])


def _check_d5_lower(ctx: Context) -> tuple[str, bool]:
    v = float(_table6_of(ctx, [ctx.stiff])["instability_ratio_lower"].values[0])
    target = float(ctx.paper["table6"]["D5"]["ratio_lower"])
    return (f"{ctx.stiff}: {v:.3f}", target / RATIO_FACTOR <= v <= target * RATIO_FACTOR)


def _check_d1_smaller(ctx: Context) -> tuple[str, bool]:
    d1 = _timber(ctx.paper)[0]
    t = _table6_of(ctx, [d1, ctx.stiff])
    fam1 = float(t["peak_lower_drift_family1"].sel(diaphragm=d1))
    other = float(t["peak_lower_drift"].sel(diaphragm=ctx.stiff))
    if not math.isfinite(fam1):
        raise A.MissingDataError(f"no {d1} history in patterns 11/12 "
                                 f"({t.attrs['family1_source']})")
    return (f"{d1} in patterns 11/12 {1e3 * fam1:.1f} mm, {ctx.stiff} {1e3 * other:.1f} mm",
            fam1 < other)


def _check_order(name: str) -> Callable[[Context], tuple]:
    """Table VI's `name` is larger with D1 than with the context's D5."""
    def run(ctx):
        d1 = _timber(ctx.paper)[0]
        t = _table6_of(ctx, [d1, ctx.stiff])
        a, b = (float(t[name].sel(diaphragm=d)) for d in (d1, ctx.stiff))
        return f"{d1} {a:.3f}, {ctx.stiff} {b:.3f}", a > b
    return run


def _check_destabilise(ctx: Context) -> tuple[str, bool]:
    return _majority(_rho(ctx.ratio("single"), "stiffness", "diaphragm"), -1,
                     "(wall, record)")


def _check_improves(ctx: Context) -> tuple[str, bool]:
    r = ctx.ratio("single").transpose("diaphragm", ...)
    v = r.values  # diaphragms from flexible to stiff
    falls = (v[:-1] < (1 - SIGNIFICANT_FALL) * v[1:])
    n, k = falls.size, int(np.nansum(falls))
    return (f"{k} of {n} steps to the next more flexible diaphragm lower the ratio by more "
            f"than {SIGNIFICANT_FALL:.0%}", k >= MANY * n)


def _check_nahanni(ctx: Context) -> tuple[str, bool]:
    p = ctx.paper
    _, d2, d3, _ = _timber(p)
    r = ctx.ratio("single").sel(record=A.match_id(ctx.need("single"), "record",
                                                  p.panel_records[0]))
    above = r.where(r["slenderness"] > float(p["section6"]["nahanni_d3_to_d2_above"]),
                    drop=True)
    if above.sizes["wall"] == 0:
        raise A.MissingDataError("no walls above that slenderness")
    a, b = above.sel(diaphragm=d2).values, above.sel(diaphragm=d3).values
    parts = [f"h/t {float(h):g}: {x:.2f} vs {y:.2f}"
             for h, x, y in zip(above["slenderness"].values, a, b, strict=True)]
    return f"{d2} vs {d3}: {'; '.join(parts)}", bool(np.all(a < b))


def _check_slender(kind: str, ids, records, test, describe) -> Callable[[Context], tuple]:
    """The rank correlations of the ratio with slenderness (per record and diaphragm) of a
    study, on the diaphragms ``ids(ctx)`` and the `records` (None: all), pass `test`."""
    def run(ctx):
        r = ctx.ratio(kind)
        if ids is not None:
            r = r.sel(diaphragm=[d for d in r["diaphragm"].values if d in ids(ctx)])
        if records is not None:
            r = r.sel(record=[A.match_id(ctx.need(kind), "record", x) for x in records])
        vals = _rho(r, "slenderness", "wall")
        return describe(vals), test(vals)
    return run


def _med_abs(vals: np.ndarray) -> str:
    return f"median |rho| {float(np.median(np.abs(vals))):.2f} over {vals.size} curves"


def _med(vals: np.ndarray) -> str:
    return f"median rho {float(np.median(vals)):+.2f} over {vals.size} curves"


def _check_converges(ctx: Context) -> tuple[str, bool]:
    timber = ctx.paper.timber
    r = ctx.ratio("single")
    ref = r.sel(diaphragm=ctx.stiff)
    meds = [float(np.nanmedian(np.abs(r.sel(diaphragm=d) - ref).values))
            for d in timber if d in r["diaphragm"].values]
    ok = all(a > b for a, b in zip(meds, meds[1:], strict=False))
    return (f"median |ratio - ratio({ctx.stiff})|: "
            + ", ".join(f"{d} {m:.3f}" for d, m in zip(timber, meds, strict=False)), ok)


def _check_both_effects(ctx: Context) -> tuple[str, bool]:
    vals = _rho(ctx.ratio("multi"), "stiffness", "diaphragm")
    up, down = float(np.mean(vals > 0)), float(np.mean(vals < 0))
    return (f"stability falls with flexibility for {down:.0%}, rises for {up:.0%} of "
            "(wall, record)", min(up, down) >= MANY)


def _check_multi_record(index: int, sign: int) -> Callable[[Context], tuple]:
    """Higher storey, the paper's panel record `index`: the ratio rises (+1) or falls (-1)
    with stiffness for most walls."""
    def run(ctx):
        ds = ctx.need("multi")
        r = ctx.ratio("multi").sel(record=A.match_id(ds, "record",
                                                     ctx.paper.panel_records[index]))
        return _majority(_rho(r, "stiffness", "diaphragm"), sign, "walls (rho with "
                         "stiffness)")
    return run


def _check_multi_none(ctx: Context) -> tuple[str, bool]:
    ds = ctx.need("multi")
    r = ctx.ratio("multi").sel(record=A.match_id(ds, "record", ctx.paper.panel_records[2]))
    vals = _rho(r, "stiffness", "diaphragm")
    m = float(np.median(np.abs(vals)))
    return f"median |rho| with stiffness {m:.2f} over {vals.size} walls", m < NO_RELATION


def _check_resonant(ctx: Context) -> tuple[str, bool]:
    ds = ctx.need("multi")
    res = A.resonance(ds.sel(diaphragm=ctx.diaphragms(ds, stiff=False)), cor=ctx.paper.cor,
                      ranges=ctx.ranges)
    parts, verdicts = [], []
    for r in res["record"].values:
        sub = res.sel(record=r)
        dist = sub["range_distance"].values
        if np.allclose(dist, dist[0]):
            parts.append(f"{r}: all diaphragms equally near, not decidable")
            continue
        worst = str(sub["mean_instability_ratio"].idxmax("diaphragm").values)
        verdicts.append(bool(sub["range_distance"].sel(diaphragm=worst) <= dist.min() + 1e-12))
        nearest = [str(d) for d, x in zip(sub["diaphragm"].values, dist, strict=True)
                   if x <= dist.min() + 1e-12]
        parts.append(f"{r}: worst {worst} ({float(sub['frequency'].sel(diaphragm=worst)):.2g}"
                     f" Hz), nearest the range {', '.join(nearest)}")
    if not verdicts:
        raise A.MissingDataError("no record separates the diaphragms by frequency")
    return "; ".join(parts), all(verdicts)


def _check_motion_dependent(ctx: Context) -> tuple[str, bool]:
    parts, ok = [], True
    for kind in ("single", "multi"):
        r = ctx.ratio(kind)
        signs = []
        for rec_id in r["record"].values:
            vals = _rho(r.sel(record=rec_id), "stiffness", "diaphragm")
            m = float(np.median(vals))
            signs.append(np.sign(m))
            parts.append(f"{kind} {rec_id} {m:+.2f}")
        ok &= (1 in signs) and (-1 in signs)
    return "median rho with stiffness: " + ", ".join(parts), bool(ok)


def _check_slenderness_overall(ctx: Context) -> tuple[str, bool]:
    vals = np.concatenate([_rho(ctx.ratio(k), "slenderness", "wall")
                           for k in ("single", "multi")])
    m = float(np.median(np.abs(vals)))
    return f"median |rho| with slenderness {m:.2f} over {vals.size} curves", m < NO_RELATION


def _check_verified(ctx: Context) -> tuple[str, bool]:
    rows = verification(ctx.need("verification"), ctx.paper)
    lo, hi = (float(x) for x in ctx.paper["verification"]["cor_range"])
    parts, oks = [], []
    for row in rows:
        if not row["target"]:
            continue
        best = row["best_cor"]
        oks.append(math.isfinite(best) and lo - row["cor_step"] <= best <= hi + row["cor_step"])
        parts.append(f"{row['wall']}: best COR {best:.2f}" if math.isfinite(best) else
                     f"{row['wall']}: no COR reproduces {row['target']}")
    if not oks:
        raise A.MissingDataError("no verification wall has a stated target")
    return "; ".join(parts), all(oks)


def _explain_verified(ctx: Context) -> str:
    """Where the verification disagrees: what the intensity sweep of the stand-ins found."""
    if ctx.intensity is None:
        return ""
    parts = []
    for row in intensity(ctx.intensity, ctx.paper):
        if not math.isfinite(row["first_collapse_g"]):
            parts.append(f"{row['wall']} does not collapse up to {max(row['pga_g']):.2g} g")
            continue
        text = (f"{row['wall']} under its stand-in ({row['record']}, {row['base_g']:.2g} g "
                f"in the sweep) first collapses at {row['first_collapse_g']:.2g} g (stands "
                f"at {row['last_standing_g']:.2g} g)")
        if "nearest_collapse" in row:
            g, t = row["nearest_collapse"]
            text += f", collapse time nearest the target: {t:.3g} s at {g:.2g} g"
        parts.append(text)
    return "intensity sweep at the paper's COR: " + "; ".join(parts)


# ---- the statements, one function per section of the paper, texts from paper.toml -------------

def _accelerations(p: Paper) -> list[Finding]:
    """Section 6.1 (Fig. 6) and its conclusion in Section 7."""
    s6 = p["section6"]
    d1, d2, _, d4 = _timber(p)
    rec, stiff = p.record, p.stiff
    return [
        Finding("top-acceleration-rises", "6.1, Fig. 6a",
                "A_max,abs at the wall top generally increased with increasing diaphragm "
                "stiffness",
                f"Spearman rho of the peak top acceleration with stiffness over {d1}-{stiff}, "
                f"per wall, {rec}: median > 0 and rho > 0 for most walls",
                _check_trend("acceleration", "top", +1), ("stiff", "record"), "response"),
        Finding("crack-acceleration-rises", "6.1, Fig. 6b",
                "the acceleration at the crack height also slightly increased with the "
                "diaphragm stiffness",
                "as above, peak crack-height acceleration",
                _check_trend("acceleration", "crack", +1), ("stiff", "record"), "response"),
        Finding("crack-acceleration-magnitude", "6.1, Fig. 6b",
                f"the increase from {d1} to {d4} being nearly "
                f"{_pct(s6['crack_acceleration_increase'])} for the most dramatic case",
                f"largest increase of the crack-height acceleration from {d1} to {d4} over "
                f"walls within {_pct(s6['crack_acceleration_increase'])} +- "
                f"{_pct(MAGNITUDE_BAND)}",
                _check_crack_magnitude, ("record",), "response"),
        Finding("crack-acceleration-where", "6.1, Fig. 6b",
                "the most dramatic case is the wall with the lowest slenderness ratio "
                f"({s6['crack_acceleration_slenderness']})",
                f"the largest {d1}-to-{d4} increase is at h/t "
                f"{s6['crack_acceleration_slenderness']}",
                _check_crack_where, ("record",), "response"),
        Finding("top-acceleration-particularly", "6.1",
                "the increase in the imposed accelerations is particularly at the wall top",
                f"median {d1}-to-{d4} increase of the top acceleration > that of the "
                "crack-height acceleration",
                _check_top_particularly, ("record",), "response"),
        Finding("stiffening-connections", "7",
                "walls are subject to greater accelerations, particularly at the wall-"
                "diaphragm connections, when common timber diaphragm stiffening is employed",
                f"top acceleration with {d4} ({d2} with a plywood overlay) > with {d2} for most "
                "walls",
                _check_stiffening, ("record",), "response"),
    ]


def _displacements(p: Paper) -> list[Finding]:
    """Section 6.2 (Fig. 7)."""
    d1 = _timber(p)[0]
    return [
        Finding("top-displacement-falls", "6.2, Fig. 7a",
                "Delta_max,abs at the wall top generally reduced with increased stiffness of "
                "the top diaphragm",
                f"Spearman rho of the peak top displacement with stiffness over {d1}-"
                f"{p.stiff}, per wall: median < 0 and rho < 0 for most walls",
                _check_trend("displacement", "top", -1), ("stiff", "record"), "response"),
        Finding("top-displacement-constant", "6.2, Fig. 7a",
                "Delta_max,abs at the wall top remained almost constant for the entire range "
                "of slenderness ratios",
                f"(max - min)/mean over slenderness < {ALMOST_CONSTANT:g} for most of "
                f"{', '.join(p.timber)}",
                _check_top_constant, ("record",), "response"),
        Finding("crack-displacement-irregular", "6.2, Fig. 7b",
                "the change in Delta_max,abs at the crack height is irregular with respect to "
                "the diaphragm stiffness and/or the slenderness ratio",
                f"median |rho| with stiffness (per wall) or with slenderness (per diaphragm) "
                f"< {IRREGULAR:g}",
                _check_crack_irregular, ("stiff", "record"), "response"),
    ]


def _table6_statements(p: Paper) -> list[Finding]:
    """Section 6.3.1 on Table VI: the 4140 mm wall with D1 and with D5."""
    t6, un = p["table6"], p["unfavourable"]
    t6d5, t6d1 = t6["D5"], t6["D1"]
    d1 = _timber(p)[0]
    rec, stiff = p.record, p.stiff
    return [
        Finding("d5-unfavourable-share", "6.3.1",
                f"{_wall_name(p)} with {stiff} responded in patterns 11/12 for only "
                f"{_pct(un['D5'])} of the duration",
                f"share in patterns 11/12, {stiff}, {rec}: > 0 and <= {_pct(SMALL_SHARE)}",
                _check_share_small, ("stiff", "record"), "response"),
        Finding("d5-lower-ratio", "6.3.1, Table VI (7)",
                f"the lower segment's Delta_max,abs ({t6d5['crack']} mm at crack height) "
                f"remained within {_pct(t6d5['ratio_lower'])} of its instability displacement",
                f"lower instability ratio, {stiff}, {rec}: within a factor {RATIO_FACTOR:g} of "
                f"{t6d5['ratio_lower']}",
                _check_d5_lower, ("stiff", "record"), "response"),
        Finding("d1-unfavourable-share", "6.3.1",
                f"with {d1} the wall responded in patterns 11/12 for more than "
                f"{_pct(un['D1_more_than'])} of the duration",
                f"share in patterns 11/12, {d1}, {rec} > {un['D1_more_than']}",
                _check_share_large, ("record",), "response"),
        Finding("d1-crack-smaller", "6.3.1, Table VI (2)",
                f"with {d1} the Delta_max,abs at crack height in patterns 11/12 "
                f"({t6d1['crack']} mm) is smaller than with {stiff} ({t6d5['crack']} mm)",
                f"peak lower drift of {d1} while in patterns 11/12 (history) < peak lower drift "
                f"of {stiff}",
                _check_d1_smaller, ("stiff", "record"), "response"),
        Finding("d1-lower-less-stable", "6.3.1, Table VI (7)",
                f"despite that, the lower segment is less stable with {d1}: ratio "
                f"{t6d1['ratio_lower']} against {t6d5['ratio_lower']}",
                f"lower instability ratio {d1} > {stiff}",
                _check_order("instability_ratio_lower"), ("stiff", "record"), "response"),
        Finding("d1-less-stable", "6.3.1, Table VI (8)",
                f"judged on the greater ratio, the wall is less stable with {d1} "
                f"({t6d1['ratio']}) than with {stiff} ({t6d5['ratio']})",
                f"governing instability ratio {d1} > {stiff}",
                _check_order("instability_ratio"), ("stiff", "record"), "response"),
    ]


def _single_storey_stability(p: Paper) -> list[Finding]:
    """Section 6.3.1 on Fig. 9: single-storey walls against diaphragm flexibility and
    slenderness."""
    d1, d2, d3, d4 = _timber(p)
    stiff = p.stiff
    flex_records = p.panel_records[1:]  # Figs. 9b and 9c
    fig9 = {r: "abc"[i] for i, r in enumerate(p.panel_records)}
    s6 = p["section6"]
    return [
        Finding("destabilises-with-flexibility", "6.3.1, Fig. 9",
                "for most wall and diaphragm configurations the instability ratio increases "
                "with diaphragm flexibility",
                f"Spearman rho of the governing ratio with stiffness over {d1}-{stiff}, per "
                "(wall, record): median < 0 and rho < 0 for most",
                _check_destabilise, ("stiff",)),
        Finding("stabilises-often", "6.3.1, Fig. 9",
                "there are many situations where the stability significantly improves with "
                "diaphragm flexibility",
                f"at least {MANY:.0%} of the steps from a diaphragm to the next more flexible "
                f"lower the ratio by more than {SIGNIFICANT_FALL:.0%}",
                _check_improves, ("stiff",)),
        Finding("nahanni-d3-to-d2", f"6.3.1, Fig. 9{fig9[p.panel_records[0]]}",
                f"under {p.panel_records[0]}, walls with slenderness greater than "
                f"{s6['nahanni_d3_to_d2_above']} become more stable from {d3} to {d2}",
                f"ratio({d2}) < ratio({d3}) for every wall with h/t > "
                f"{s6['nahanni_d3_to_d2_above']}",
                _check_nahanni, (), p.panel_records[0]),
        Finding("stiff-rises-with-slenderness", "6.3.1, Fig. 9",
                f"the ratio generally increases consistently with slenderness for {d3} or "
                "stiffer diaphragms",
                f"Spearman rho with slenderness per (record, {d3}-{stiff}): median > "
                f"{1 - NO_RELATION:g}",
                _check_slender("single", lambda c: [d3, d4, c.stiff], None,
                               lambda v: float(np.median(v)) > 1 - NO_RELATION, _med),
                ("stiff",)),
        Finding("flexible-chaotic", "6.3.1, Figs. 9"
                + "".join(fig9[r] for r in flex_records),
                f"for {d1} or {d2} the ratio is chaotic and does not correlate with slenderness",
                f"Spearman rho with slenderness per (record, {d1}/{d2}) for "
                f"{', '.join(flex_records)}: median |rho| < {NO_RELATION:g}",
                _check_slender("single", lambda c: [d1, d2], flex_records,
                               lambda v: float(np.median(np.abs(v))) < NO_RELATION, _med_abs),
                (), ",".join(flex_records)),
        Finding("converges-to-pinned", "6.3.1, Fig. 9",
                "as the diaphragm stiffness increases, the instability ratio converges to that "
                "of the pinned top support",
                f"median over (wall, record) of |ratio - ratio({stiff})| falls strictly from "
                f"{d1} to {d4}",
                _check_converges, ("stiff",)),
    ]


def _higher_storey_stability(p: Paper) -> list[Finding]:
    """Section 6.3.2 (Fig. 10): walls between two flexible diaphragms."""
    r0, r1, r2 = p.panel_records[:3]
    return [
        Finding("multi-both-effects", "6.3.2, Fig. 10",
                "both stabilising and destabilising effects of diaphragm flexibility are seen "
                "for higher-storey walls",
                f"rho of the ratio with stiffness, per (wall, record): at least {MANY:.0%} "
                "positive and at least as many negative",
                _check_both_effects),
        Finding("multi-nahanni-stiffer-worse", "6.3.2, Fig. 10a",
                f"{r0} (high-frequency) made walls between stiffer diaphragms "
                "less stable than between more flexible ones",
                f"{r0}, higher storey: rho of the ratio with stiffness > 0 for "
                "most walls, median > 0",
                _check_multi_record(0, +1), (), r0),
        Finding("multi-christchurch-flexible-worse", "6.3.2, Fig. 10b",
                f"for the low-frequency {r1} record the stability reduced with "
                "diaphragm flexibility",
                f"{r1}, higher storey: rho of the ratio with stiffness < 0 for "
                "most walls, median < 0",
                _check_multi_record(1, -1), (), r1),
        Finding("multi-elcentro-no-relation", "6.3.2, Fig. 10c",
                f"for {r2} (broad frequencies) there is no clear relation "
                "between diaphragm flexibility and stability",
                f"{r2}, higher storey: median |rho| with stiffness < "
                f"{NO_RELATION:g}",
                _check_multi_none, (), r2),
        Finding("multi-slenderness-none", "6.3.2, Fig. 10",
                "the stability of walls between two flexible diaphragms has no obvious relation "
                "with slenderness",
                f"Spearman rho with slenderness per (record, diaphragm), higher storey: median "
                f"|rho| < {NO_RELATION:g}",
                _check_slender("multi", None, None,
                               lambda v: float(np.median(np.abs(v))) < NO_RELATION, _med_abs)),
        Finding("resonance", "6.3.2 and 7",
                "walls between two flexible diaphragms are worst affected by records whose "
                "dominant frequency is comparable to the diaphragms'",
                "per record (higher storey), the diaphragm with the largest mean ratio over "
                "walls is one nearest (log scale) the record's significant range (Table V); "
                "records all diaphragms are equally near are not decidable",
                _check_resonant),
    ]


def _conclusions(p: Paper) -> list[Finding]:
    """Section 7 (and the verification of Section 5.2 it concludes on)."""
    ver = p["verification"]
    return [
        Finding("ground-motion-dependent", "7",
                "the effect of diaphragm flexibility on wall stability depends on the ground "
                "motion",
                "per record, the median rho of the ratio with stiffness takes both signs, in "
                "each study",
                _check_motion_dependent, ("stiff",)),
        Finding("slenderness-not-a-criterion", "7",
                "wall stability did not correlate well with the slenderness ratio for the "
                "records used",
                f"Spearman rho with slenderness per (record, diaphragm), both studies: median "
                f"|rho| < {NO_RELATION:g}",
                _check_slenderness_overall, ("stiff",)),
        Finding("verification-cor", "5.2 and 7",
                "the model predicted the tests' response reasonably accurately with a COR of "
                f"{ver['cor_range'][0]} to {ver['cor_range'][1]}",
                "for each wall with a target the paper states, the COR whose response is "
                "nearest lies in that range (within one grid step)",
                _check_verified, (), "verification", _explain_verified),
    ]


def statements(p: Paper) -> list[Finding]:
    """Every statement of Sections 6-7, its texts filled from the paper's numbers, in the
    report's order."""
    return [*_accelerations(p), *_displacements(p), *_table6_statements(p),
            *_single_storey_stability(p), *_higher_storey_stability(p), *_conclusions(p)]


def _variants(ctx: Context, finding: Finding) -> list[tuple[str, Context]]:
    out = []
    if "stiff" in finding.varies and ctx.single is not None:
        other = ctx.paper.pinned if ctx.stiff == ctx.paper.stiff else ctx.paper.stiff
        if other in [str(d) for d in ctx.single["diaphragm"].values]:
            out.append((f"with {other} in place of {ctx.stiff}", replace(ctx, stiff=other)))
    if "record" in finding.varies and ctx.single is not None:
        for r in ctx.single["record"].values:
            if str(r) != ctx.record:
                out.append((f"under {r}", replace(ctx, record=str(r))))
    return out


def _about(f: Finding, ctx: Context) -> list[str]:
    """The record ids a finding rests on (for the stand-in notes)."""
    if f.about == "all":
        return ctx.paper.panel_records
    if f.about == "response":
        return [ctx.record]
    if f.about == "verification":
        ds = ctx.verification
        return [str(r) for r in ds["record"].values] if ds is not None else []
    return f.about.split(",")


def _stand_in(record: str, manifest: dict) -> str:
    entry = manifest.get(record, {})
    if not entry.get("substitute"):
        return ""
    return (f"{record} is a stand-in ({entry.get('event', '')} {entry.get('date', '')}) for "
            f"{entry.get('substitute_for', 'the paper record')}")


def findings(single: xr.Dataset | None = None, multi: xr.Dataset | None = None,
             verification_ds: xr.Dataset | None = None, paper: Paper | None = None,
             ranges: dict | None = None, manifest: dict | None = None,
             intensity_ds: xr.Dataset | None = None) -> list[dict]:
    """Every statement of the paper's Sections 6-7 against the archives.

    Parameters
    ----------
    single, multi, verification_ds : Dataset, optional
        The single-storey, higher-storey and verification study archives.
    paper : Paper, optional
        Default :func:`load_paper`.
    ranges : dict, optional
        Significant frequency range by record id [Hz]; default Table V from the records
        manifest (:func:`significant_frequency`).
    manifest : dict, optional
        Records manifest entries (for stand-in notes); default the repository's.
    intensity_ds : Dataset, optional
        A ``verification-intensity`` archive (measures why a verification disagrees).

    Returns
    -------
    list of dict
        One per statement: ``key``, ``section``, ``statement``, ``criterion``, ``measured``,
        ``agree`` (True/False; None when not computable), ``cause`` (where it disagrees:
        the criterion re-measured with the other D5 model or the other records, and what
        holds then, else "not known"; stand-in records are named).
    """
    paper = paper or load_paper()
    manifest = _manifest() if manifest is None else manifest
    if ranges is None:
        ranges = significant_frequency(manifest) if manifest else {}
    ctx = Context(single, multi, verification_ds, paper, paper.record, paper.stiff, ranges,
                  intensity_ds)
    rows = []
    for f in statements(paper):
        try:
            measured, agree = f.check(ctx)
            agree = bool(agree)
        except A.MissingDataError as exc:
            measured, agree = f"not available: {exc}", None
        except KeyError as exc:  # a diaphragm, wall or record the archive lacks
            measured, agree = f"not available: the study lacks {exc.args[0]}", None
        cause = ""
        if agree is False:
            held, failed = [], []
            for label, other in _variants(ctx, f):
                try:
                    text, ok = f.check(other)
                except (A.MissingDataError, KeyError):
                    continue
                (held if ok else failed).append(f"{label}: {text}")
            if held:
                cause = "measured: the criterion holds " + "; ".join(held)
                if failed:
                    cause += " (fails " + "; ".join(failed) + ")"
            else:
                cause = "not known" + (" (it fails too " + "; ".join(failed) + ")"
                                       if failed else "")
            if f.explain is not None:
                extra = f.explain(ctx)
                if extra:
                    cause = extra if cause == "not known" else f"{cause}; {extra}"
            notes = {_stand_in(r, manifest) for r in _about(f, ctx)}
            notes.discard("")
            if notes:
                cause += "; " + "; ".join(sorted(notes))
        rows.append(dict(key=f.key, section=f.section, statement=f.statement,
                         criterion=f.criterion, measured=measured, agree=agree, cause=cause))
    return rows


# ---- verification -----------------------------------------------------------------------------

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
    manifest = _manifest() if manifest is None else manifest
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
            pk = _finite(peak.values)
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
