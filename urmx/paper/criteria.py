"""The paper's statements of Sections 6-7, each with a criterion that can fail
(:func:`statements`), and :func:`findings`: every statement measured on the archives, with
the verdict and, where urmx disagrees, the measured cause (a re-run of the criterion with
the other D5 model or another record) or "not known".

The criteria's thresholds below are urmx's choices, not the paper's numbers.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
import xarray as xr

from ..analysis import grid as A
from .numbers import Paper, load_paper, records_manifest, significant_frequency
from .shake_table import intensity, verification
from .tables import table6

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
    manifest = records_manifest() if manifest is None else manifest
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

