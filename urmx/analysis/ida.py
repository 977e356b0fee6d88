"""Reductions of IDA archives (`urmx.study.kinds.ida`): supports groups, the resonance of
capacities with the diaphragm's frequency, the effect of stiffening a diaphragm, the rank
correlation of collapse intensities with slenderness, and, from the capacities in every
intensity measure that one run holds, the efficiency and sufficiency of each measure and the
collapse risk at a site (drawn by `urmx.plot`, reported by `urmx.reports.ida` and
`urmx risk`)."""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from .. import records as rec
from ..config import records_dir as folder
from ..config import shipped_records
from ..errors import InputError, UrmxError
from ..fragility import (
    IM_ATTRS,
    RESAMPLES,
    SA_AVG_PERIODS,
    collapse_rate,
    design_sa,
    fit_lognormal,
    read_hazard,
    read_spectrum,
)
from ..fragility.fits import function_interval, resample_weights
from ..fragility.intensity import DAMPING
from ..fragility.risk import BAND_PERIODS, DesignSpectrum, HazardCurve, measure, rates
from ..records.measures import geometric_mean_psa, pseudo_spectral_acceleration
from ..records.record import as_record
from .grid import spearman

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


# ---- every measure from one run: efficiency, sufficiency, confidence, risk --------------------

#: the measures compared (`urmx.fragility.RECORD_IMS`)
MEASURES = ("pga", "pgv", "sa_wall", "sa_diaphragm", "sa_avg")


def require_measures(ds: xr.Dataset) -> None:
    """Refuse an IDA archive written before it held the scale factor at collapse and each
    record's intensity in every measure."""
    missing = [n for n in ("collapse_scale", *(f"record_{im}" for im in MEASURES))
               if n not in ds]
    if missing:
        raise InputError(f"the IDA archive lacks {', '.join(missing)} (written by an older "
                         "urmx): run the study again with `urmx run` to write them")


def record_groups(ds: xr.Dataset, records_dir=None) -> np.ndarray | None:
    """The group (station or event) of each record of an archive: its ``group`` coordinate
    when it has one, else the record manifest's ``group`` field (a record without one is a
    group of its own); None when no record has a group (records then resample one by one)."""
    ids = [str(r) for r in ds.record.values]
    if "group" in ds.coords:
        return np.array([str(g) for g in ds.group.values], dtype=object)
    try:
        man = rec.manifest(records_dir)
    except (UrmxError, OSError):
        return None
    groups = [man.get(r, {}).get("group") for r in ids]
    if all(g is None for g in groups):
        return None
    return np.array([g if g is not None else f"record {r}" for g, r in zip(groups, ids,
                                                                          strict=True)],
                    dtype=object)


def grouping_sentence(groups) -> str:
    """How the bootstraps resample: ``"whole stations (20 groups of the manifest's `group`)"``
    or ``"records one by one"``."""
    if groups is None:
        return "the records one by one (no record carries a `group`)"
    n = len(set(groups))
    return (f"whole groups of records ({n} groups of {len(groups)} records, the record "
            "manifest's `group`: for the FEMA P695 set its 20 stations of two components "
            "each), not records one by one")


def capacities(ds: xr.Dataset, im: str, records_dir=None) -> xr.DataArray:
    """Collapse capacities in measure `im`: the scale factor at collapse times each
    record's intensity in `im` (no new analyses), with the units and name of the measure.
    ``sa(T)`` (Sa at a fixed period, `urmx.fragility.risk.measure`) is computed from the
    records, read again from `records_dir`."""
    require_measures(ds)
    if im.startswith("sa("):
        return _capacities_at_period(ds, im, records_dir)
    if im not in MEASURES:
        raise InputError(f"im={im!r}: use one of {', '.join(MEASURES)}")
    cap = ds.collapse_scale * ds[f"record_{im}"]
    units, name = IM_ATTRS[im]
    return cap.rename(f"collapse_{im}").assign_attrs(units=units,
                                                     long_name=f"collapse intensity ({name})")


def _capacities_at_period(ds: xr.Dataset, im: str, records_dir=None) -> xr.DataArray:
    """Capacities in ``sa(T)``: the scale factor at collapse times each record's 5 %-damped
    Sa at T (as analysed: times its scale factor), the records read again."""
    period = float(measure(im)[3:-1])
    try:
        recs = [as_record(str(r), records_dir) for r in ds.record.values]
    except (UrmxError, OSError) as exc:
        raise InputError(f"capacities in {im} need the records' spectra and the records "
                         f"cannot be read ({exc}); set URMX_RECORDS") from None
    sa = np.array([float(pseudo_spectral_acceleration(r.acceleration * float(sf), r.dt,
                                                      np.array([period]), DAMPING)[0])
                   for r, sf in zip(recs, ds.scale_factor.values, strict=True)])
    unit = xr.DataArray(sa, dims="record", coords={"record": ds.record})
    return (ds.collapse_scale * unit).rename("collapse_sa").assign_attrs(
        units="m s-2", long_name=f"collapse intensity (Sa({period:g} s), 5 % damped)")


#: the variables `fit_cells` returns, in `urmx.fragility.fit_lognormal`'s order
FIT_NAMES = ("median_collapse_intensity", "median_collapse_intensity_lower",
             "median_collapse_intensity_upper", "dispersion", "dispersion_lower",
             "dispersion_upper")


def fit_cells(cap: np.ndarray, cen: np.ndarray, groups=None,
              resamples: int | None = None) -> dict[str, np.ndarray]:
    """`urmx.fragility.fit_lognormal` of each (wall, diaphragm) row of capacities `cap`
    (shape (wall, diaphragm, record), NaN where a record did not run) with their censored
    flags `cen`: `FIT_NAMES` -> arrays of shape (wall, diaphragm), NaN where no fit."""
    out = {n: np.full(cap.shape[:2], np.nan) for n in FIT_NAMES}
    for iw, idp in np.ndindex(cap.shape[:2]):
        ran = np.isfinite(cap[iw, idp])
        try:
            f = fit_lognormal(cap[iw, idp, ran], cen[iw, idp, ran],
                              resamples=RESAMPLES if resamples is None else resamples,
                              groups=None if groups is None else np.asarray(groups)[ran])
        except ValueError:
            continue
        for n, v in zip(FIT_NAMES, (f.median, *f.median_ci, f.dispersion, *f.dispersion_ci),
                        strict=True):
            out[n][iw, idp] = v
    return out


def fits_in(ds: xr.Dataset, im: str, resamples: int | None = None,
            groups=None) -> xr.Dataset:
    """Lognormal fits (with studentized bootstrap intervals, whole `groups` of records
    resampled when given: `record_groups`) of the capacities in `im` per (wall, diaphragm)
    at the first COR: ``median_collapse_intensity``, ``dispersion`` and their ``_lower`` /
    ``_upper`` bounds. [units of `im`], [1]"""
    d = first_cor(ds)
    out = fit_cells(capacities(d, im).transpose("wall", "diaphragm", "record").values,
                    d.censored.transpose("wall", "diaphragm", "record").values, groups,
                    resamples)
    return xr.Dataset({n: (("wall", "diaphragm"), v) for n, v in out.items()},
                      coords={"wall": d.wall, "diaphragm": d.diaphragm})


def efficiency(ds: xr.Dataset, groups=None) -> xr.Dataset:
    """The dispersion of the capacities in every measure (`MEASURES`) per (wall,
    diaphragm) with its bootstrap interval, and per diaphragm the measure with the lowest
    median dispersion over the walls (``best``): one IDA run, no new analyses."""
    fits = xr.concat([fits_in(ds, im, groups=groups) for im in MEASURES], dim="measure")
    fits = fits.assign_coords(measure=list(MEASURES))
    typical = fits.dispersion.median("wall")
    best = typical.idxmin("measure")
    return fits.assign(typical_dispersion=typical, best=best)


def record_magnitude_distance(ds: xr.Dataset, records_dir=None) -> tuple[np.ndarray,
                                                                           np.ndarray]:
    """Moment magnitude and rupture distance [km] of each record of an archive: the
    archive's ``magnitude`` / ``distance`` coordinates when it has them, else the record
    manifest's ``magnitude`` and the ``rrup_km`` of the record library's catalog
    (``library/catalog.tsv`` of the records folder, matched on the manifest's file); NaN
    where neither knows."""
    ids = [str(r) for r in ds.record.values]
    if "magnitude" in ds.coords and "distance" in ds.coords:
        return ds.magnitude.values.astype(float), ds.distance.values.astype(float)
    man = rec.manifest(records_dir)
    mag = np.array([float(man.get(r, {}).get("magnitude", np.nan)) for r in ids])
    rrup = {}
    lines = []
    for where in (folder(records_dir), shipped_records()):  # the user's, else the shipped
        try:
            lines = (where / "library" / "catalog.tsv").read_text().splitlines()
            break
        except OSError:
            continue
    if lines:
        head = lines[0].split("\t")
        for line in lines[1:]:
            row = dict(zip(head, line.split("\t"), strict=False))
            rrup["library/" + row.get("path", "")] = float(row.get("rrup_km") or np.nan)
    dist = np.array([rrup.get(man.get(r, {}).get("file", ""), np.nan) for r in ids])
    return mag, dist


def _slopes(x: np.ndarray, y: np.ndarray, w: np.ndarray, onehot: np.ndarray):
    """Weighted least-squares slopes of rows of weights `w` (B, n) and their cluster-robust
    standard errors (scores summed over each group of `onehot` (n, G), a group counted as
    often as it is drawn)."""
    sw = w.sum(1, keepdims=True)
    xc = x[None, :] - (w @ x)[:, None] / sw
    yc = y[None, :] - (w @ y)[:, None] / sw
    sxx = np.sum(w * xc * xc, 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        slope = np.sum(w * xc * yc, 1) / sxx
        score = (xc * (yc - slope[:, None] * xc)) @ onehot
        count = (w @ onehot) / onehot.sum(0)
        se = np.sqrt(np.sum(count * score * score, 1)) / sxx
    return slope, se


def group_slope_p(x: np.ndarray, y: np.ndarray, groups, resamples: int = 1000,
                  seed: int = 0) -> float:
    """Two-sided p-value of a least-squares slope of `y` on `x` by the cluster bootstrap-t
    (whole groups resampled, each resample's slope studentized by its cluster-robust
    standard error; Cameron, Gelbach & Miller 2008, Rev. Econ. Stat. 90(3), Section
    III.B): the share of resamples with ``|b* - b| / se* >= |b| / se``."""
    codes = np.unique(np.asarray(groups, dtype=str), return_inverse=True)[1].ravel()
    onehot = (codes[:, None] == np.arange(int(codes.max()) + 1)[None, :]).astype(float)
    b0, se0 = _slopes(x, y, np.ones((1, x.size)), onehot)
    w = resample_weights(codes, resamples, np.random.default_rng(seed))
    b, se = _slopes(x, y, w, onehot)
    ok = np.isfinite(b) & np.isfinite(se) & (se > 0)
    if not ok.any() or not (np.isfinite(se0[0]) and se0[0] > 0):
        return math.nan
    t0 = abs(b0[0]) / se0[0]
    return float(max(np.mean(np.abs(b[ok] - b0[0]) / se[ok] >= t0), 1.0 / resamples))


def sufficiency(ds: xr.Dataset, magnitude, distance, groups=None) -> xr.Dataset:
    """Is a measure sufficient (Luco & Cornell 2007, Earthquake Spectra 23(2))? Per measure,
    wall and diaphragm (first COR), the least-squares slope of the residuals
    ``ln(capacity) - mean`` over the uncensored records on the records' magnitude and on
    ``ln(distance)``, with its two-sided p-value (``slope_magnitude``, ``p_magnitude``,
    ``slope_distance``, ``p_distance``). A measure is sufficient when the residuals do not
    depend on them (large p-values). With `groups` (`record_groups`: the two components of
    a station share its magnitude and distance) the p-value is the cluster bootstrap's
    (`group_slope_p`), not the t-test's, which would count 20 stations as 40 records."""
    from scipy.stats import linregress

    d = first_cor(ds)
    mag, ldist = np.asarray(magnitude, float), np.log(np.asarray(distance, float))
    names = ("slope_magnitude", "p_magnitude", "slope_distance", "p_distance")
    out = {n: np.full((len(MEASURES), d.wall.size, d.diaphragm.size), np.nan) for n in names}
    cen = d.censored.transpose("wall", "diaphragm", "record").values
    for k, im in enumerate(MEASURES):
        lc = np.log(capacities(d, im).transpose("wall", "diaphragm", "record").values)
        for iw, idp in np.ndindex(lc.shape[:2]):
            for x, (s_name, p_name) in ((mag, names[:2]), (ldist, names[2:])):
                ok = np.isfinite(lc[iw, idp]) & (cen[iw, idp] == 0) & np.isfinite(x)
                if ok.sum() < 5 or np.ptp(x[ok]) == 0:
                    continue
                res = lc[iw, idp, ok] - lc[iw, idp, ok].mean()
                fit = linregress(x[ok], res)
                out[s_name][k, iw, idp], out[p_name][k, iw, idp] = fit.slope, fit.pvalue
                if groups is not None:
                    out[p_name][k, iw, idp] = group_slope_p(x[ok], res,
                                                            np.asarray(groups)[ok])
    dims = ("measure", "wall", "diaphragm")
    return xr.Dataset({n: (dims, v) for n, v in out.items()},
                      coords={"measure": list(MEASURES), "wall": d.wall,
                              "diaphragm": d.diaphragm}).assign_attrs(
        grouped=int(groups is not None))


def collapse_risk(ds: xr.Dataset, hazard, years: float = 50.0,
                  resamples: int | None = None, groups=None, records_dir=None) -> xr.Dataset:
    """Mean annual frequency (``rate`` [1/yr], with its studentized bootstrap bounds
    ``rate_lower`` / ``rate_upper``, whole `groups` of records resampled when given) and
    probability in `years` (``probability``) of collapse per (wall, diaphragm) at the first
    COR, from the fits in the hazard curve's measure (`urmx.fragility.collapse_rate`; no
    new analyses), with the share of each rate from capacities beyond the curve
    (``tail_share``), from ground motions beyond the intensities the file marks as computed
    (``extrapolated_share``) and from each band of return periods (``band_share``, with
    the bands' intensities ``band_low`` / ``band_high``)."""
    curve = hazard if isinstance(hazard, HazardCurve) else read_hazard(hazard)
    d = first_cor(ds)
    cap = capacities(d, curve.im, records_dir).transpose("wall", "diaphragm", "record").values
    cen = d.censored.transpose("wall", "diaphragm", "record").values
    names = ("rate", "probability", "tail_share", "rate_lower", "rate_upper",
             "extrapolated_share", "median_collapse_intensity", "dispersion")
    out = {n: np.full(cap.shape[:2], np.nan) for n in names}
    nb = len(BAND_PERIODS) + 1
    band = {n: np.full(cap.shape[:2] + (nb,), np.nan) for n in ("band_low", "band_high",
                                                                 "band_share")}

    for iw, idp in np.ndindex(cap.shape[:2]):
        ran = np.isfinite(cap[iw, idp])
        grp = None if groups is None else np.asarray(groups)[ran]
        try:
            fit = fit_lognormal(cap[iw, idp, ran], cen[iw, idp, ran], resamples=0)
        except ValueError:
            continue
        r = collapse_rate(_Fit(fit.median, fit.dispersion, curve.im, curve.units), curve,
                          years)
        out["median_collapse_intensity"][iw, idp] = fit.median
        out["dispersion"][iw, idp] = fit.dispersion
        out["rate"][iw, idp], out["probability"][iw, idp] = r.rate, r.probability
        out["tail_share"][iw, idp] = r.tail_share
        out["extrapolated_share"][iw, idp] = r.extrapolated_share
        for k, (lo, hi, share) in enumerate(r.bands):
            band["band_low"][iw, idp, k], band["band_high"][iw, idp, k] = lo, hi
            band["band_share"][iw, idp, k] = share
        out["rate_lower"][iw, idp], out["rate_upper"][iw, idp] = function_interval(
            cap[iw, idp, ran], cen[iw, idp, ran],
            lambda m, b: rates(curve, m, b, points=801)[0], groups=grp,
            resamples=RESAMPLES if resamples is None else resamples)
    res = xr.Dataset({n: (("wall", "diaphragm"), v) for n, v in out.items()},
                     coords={"wall": d.wall, "diaphragm": d.diaphragm})
    for n, v in band.items():
        res[n] = (("wall", "diaphragm", "band"), v)
    return res.assign_attrs(im=curve.im, units=curve.units, hazard=curve.source,
                            years=float(years), grouped=int(groups is not None),
                            computed_to=np.nan if curve.computed_to is None
                            else curve.computed_to)


class _Fit:
    """A fragility's median, dispersion, measure and units (what `collapse_rate` reads)."""

    def __init__(self, median: float, dispersion: float, im: str, units: str):
        self.median, self.dispersion, self.im, self.units = median, dispersion, im, units


def risk_change(risk: xr.Dataset, soft: str = STIFFEN[0], stiff: str = STIFFEN[1]) -> dict:
    """Per supports group with both diaphragms: the collapse rates of the as-built and the
    stiffened diaphragm per wall and their ratio (stiff / soft) (`collapse_risk`)."""
    out = {}
    groups = supports_groups(risk) if "supports" in risk.coords else {
        "top": [str(x) for x in risk.diaphragm.values]}
    for g, labels in groups.items():
        pick = {base_label(lab): lab for lab in labels}
        if soft in pick and stiff in pick:
            a, b = risk.rate.sel(diaphragm=pick[soft]), risk.rate.sel(diaphragm=pick[stiff])
            out[g] = {"soft": pick[soft], "stiff": pick[stiff], "rate_soft": a,
                      "rate_stiff": b, "ratio": b / a}
    return out


def margins(ds: xr.Dataset, spectrum) -> xr.Dataset:
    """The median collapse capacity in ``sa_wall`` over the design spectrum's Sa at the
    wall's rocking period, per (wall, diaphragm) at the first COR (``margin`` [1], with
    ``median_sa_wall`` and ``design_sa`` [m s-2] and ``rocking_period`` [s])."""
    spec = spectrum if isinstance(spectrum, DesignSpectrum) else read_spectrum(spectrum)
    fits = fits_in(ds, "sa_wall", resamples=0)
    period = first_cor(ds).rocking_period
    demand = xr.DataArray(design_sa(spec, period.values), dims=period.dims,
                          coords=period.coords)
    med = fits.median_collapse_intensity
    return xr.Dataset({"margin": med / demand, "median_sa_wall": med,
                       "design_sa": demand}).assign_attrs(spectrum=spec.source)


#: other period ranges of sa_avg the report compares with the default (T_r: the wall's
#: rocking period, T_d: its top diaphragm's; 0.02 s stands in for a rigid top's 0)
SA_AVG_RANGES = {
    "between T_d and T_r": lambda tr, td: (np.maximum(np.minimum(td, tr), 0.02),
                                           np.maximum(td, tr)),
    "0.2 T_r to 3 T_r (Eads et al. 2015)": lambda tr, td: (0.2 * tr, 3.0 * tr),
}


def sa_avg_alternatives(ds: xr.Dataset, records_dir=None) -> dict[str, xr.DataArray]:
    """The dispersion of the capacities per (wall, diaphragm) at the first COR in
    ``sa_avg`` over each period range of `SA_AVG_RANGES` (10 log-spaced periods), from the
    scale factors at collapse and the records' spectra (the records are read again: no
    new analyses). Empty when the records cannot be read."""
    require_measures(ds)
    d = first_cor(ds)
    tr = d.rocking_period.transpose("wall", "diaphragm").values
    td = 1.0 / d.cell_frequency.transpose("wall", "diaphragm").values
    try:
        recs = [as_record(str(r), records_dir) for r in d.record.values]
    except (UrmxError, OSError):
        return {}
    scale = d.collapse_scale.transpose("wall", "diaphragm", "record").values
    cen = d.censored.transpose("wall", "diaphragm", "record").values
    out = {}
    for name, rule in SA_AVG_RANGES.items():
        lo, hi = rule(tr, td)
        periods = np.geomspace(lo, hi, SA_AVG_PERIODS, axis=-1)
        sa = np.stack([geometric_mean_psa(r.acceleration * float(sf), r.dt, periods)
                       for r, sf in zip(recs, d.scale_factor.values, strict=True)], axis=-1)
        disp = np.full(tr.shape, np.nan)
        for iw, idp in np.ndindex(tr.shape):
            ran = np.isfinite(scale[iw, idp])
            try:
                disp[iw, idp] = fit_lognormal(scale[iw, idp, ran] * sa[iw, idp, ran],
                                              cen[iw, idp, ran], resamples=0).dispersion
            except ValueError:
                continue
        out[name] = xr.DataArray(disp, dims=("wall", "diaphragm"),
                                 coords={"wall": d.wall, "diaphragm": d.diaphragm})
    return out
