"""The parts of the fragility report made from every intensity measure an IDA archive holds
and from a site: which measure predicts collapse best (efficiency, sufficiency) and the
collapse risk (annual rate, probability, the change when the diaphragm is stiffened, the
margin over a design spectrum), and the tables ``urmx risk`` prints (`risk_lines`).

Nothing here runs an analysis: the capacities in every measure are the scale factors at
collapse times each record's measure (`urmx.analysis.ida.capacities`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr

from .. import plot as P
from ..analysis import ida as FA
from ..analysis.ida import GROUPS, MEASURES, STIFFEN
from ..errors import UrmxError
from ..fragility import SA_AVG_PERIODS, design_sa, read_hazard, read_spectrum
from ..fragility.fits import CONFIDENCE
from ..fragility.intensity import SA_AVG_FLOOR, SA_AVG_WIDEN
from ..fragility.risk import BAND_PERIODS, DesignSpectrum, HazardCurve, scaled_curve
from ..markdown import number as _fmt
from ..markdown import table
from .common import (
    DEGENERATE,
    DEGENERATE_NOTE,
    MIN_RECORDS,
    enough_records,
    interval,
    pct,
    records_per_cell,
    save_figure,
    too_few,
)
from .common import (
    ratio as _ratio,
)

LEVEL = f"{100 * CONFIDENCE:g} %"
MIN_RISK = 10**9  # an archive of risk numbers made without a record count: intervals kept
OLDER = ("_Not available: the archive lacks the scale factor at collapse and the records' "
         "measures (written by an older urmx); run `urmx run` again._")


def _save(axes, out: Path, name: str) -> str:
    return save_figure(axes, out, name, dpi=90, palette=True)


def _group_name(group: str) -> str:
    return GROUPS.get(group, group).split(" (")[0]


def _has_measures(ds: xr.Dataset) -> bool:
    try:
        FA.require_measures(ds)
    except UrmxError:
        return False
    return True


# ---- which measure predicts collapse best ----------------------------------------------------

def measure_numbers(ds: xr.Dataset, records_dir=None) -> dict | None:
    """Efficiency (`urmx.analysis.ida.efficiency`), sufficiency against the records'
    magnitude and distance (None when the records' catalog does not give them) and the
    dispersion in ``sa_avg`` over other period ranges (empty without the records); None
    for an archive without the measures."""
    if not _has_measures(ds):
        return None
    groups = FA.record_groups(ds, records_dir)
    eff = FA.efficiency(ds, groups)
    try:
        mag, dist = FA.record_magnitude_distance(ds, records_dir)
    except (UrmxError, OSError):
        mag = dist = np.full(ds.record.size, np.nan)
    known = np.isfinite(mag) & np.isfinite(dist)
    suff = FA.sufficiency(ds, mag, dist, groups) if known.sum() >= 5 else None
    return {"eff": eff, "suff": suff, "alt": FA.sa_avg_alternatives(ds, records_dir),
            "mag": mag, "dist": dist, "records": records_per_cell(ds), "groups": groups}


def _overall(eff: xr.Dataset) -> dict[str, float]:
    """Median dispersion over every (wall, diaphragm) per measure."""
    return {im: float(eff.dispersion.sel(measure=im).median()) for im in MEASURES}


def _recommended(m: dict) -> str:
    overall = _overall(m["eff"])
    return min(overall, key=overall.get)


def measure_findings(m: dict | None) -> list[str]:
    """The findings bullet: the dispersions and the measure urmx recommends."""
    if m is None:
        return []
    if not enough_records(m.get("records", 0)):
        return [f"- **Intensity measure.** Not ranked: "
                f"{too_few(m['records'], 'comparing the measures')} (the dispersions are "
                "listed in the section below, without a recommendation)."]
    overall = _overall(m["eff"])
    best = _recommended(m)
    others = sorted((v for k, v in overall.items() if k != best))
    wins = int((m["eff"].best == best).sum())
    n = m["eff"].diaphragm.size
    share = (overall[best] / others[-1]) ** 2
    between = m["alt"].get(next(iter(FA.SA_AVG_RANGES)))
    alone = "" if between is None or best != "sa_avg" else (
        f" (over the periods between the diaphragm's and the wall's alone, "
        f"{_fmt(float(between.median()), 2)})")
    return [f"- **Intensity measure.** The median record-to-record dispersion of the collapse "
            f"capacity over the walls and diaphragms is {_fmt(overall[best], 2)} in `{best}`"
            f"{alone} against {_fmt(others[0], 2)}-{_fmt(others[-1], 2)} in the other measures ("
            + ", ".join(f"`{k}` {_fmt(v, 2)}" for k, v in overall.items() if k != best)
            + f"); `{best}` is the most efficient on {wins} of {n} diaphragms. For the same "
            f"confidence in a median it needs about {pct(share)} of the records the "
            f"least efficient measure needs (the standard error goes as beta / sqrt(n)). "
            f"urmx recommends `{best}` (section \"Which intensity measure predicts collapse "
            "best?\")."]


def _efficiency_rows(eff: xr.Dataset, ranked: bool = True) -> list[list]:
    """A row per diaphragm (and ``all``); the `best` column only when `ranked` (enough
    records to rank the measures)."""
    rows = []
    for lab in [str(x) for x in eff.diaphragm.values]:
        e = eff.sel(diaphragm=lab)
        rows.append([lab] + [_fmt(float(e.typical_dispersion.sel(measure=im)), 2)
                             for im in MEASURES] + ([f"`{str(e.best.values)}`"] if ranked
                                                     else []))
    overall = _overall(eff)
    if eff.diaphragm.size == 1:
        return rows
    return rows + [["all"] + [_fmt(overall[im], 2) for im in MEASURES]
                   + ([f"`{min(overall, key=overall.get)}`"] if ranked else [])]


def measures_section(ds: xr.Dataset, m: dict | None, out: Path) -> list[str]:
    """Efficiency table and figure, the sa_avg ranges, sufficiency, the recommendation and
    the dispersion of every cell with its interval."""
    lines = ["## Which intensity measure predicts collapse best?", ""]
    if m is None:
        return lines + [OLDER, ""]
    eff = m["eff"]
    ranked = enough_records(m.get("records", 0))
    lines += [
        "One IDA run gives the capacities in every measure: the scale factor at collapse "
        "(`collapse_scale`) times each record's intensity in the measure (`record_pga`, "
        "..., `record_sa_avg`), so this section costs no analyses. `sa_avg` is the geometric "
        "mean of the 5 %-damped Sa at 10 log-spaced periods from max(min(T_d, T_r) / sqrt 2, "
        "T_r / 2) to sqrt 2 max(T_d, T_r) (T_r: the wall's effective rocking period, T_d: "
        "its top diaphragm's; `urmx.fragility.sa_avg_range`).", "",
        "Efficiency: the dispersion beta of the lognormal fit of the capacities in each "
        "measure, median over the walls of each diaphragm (and over every wall and "
        "diaphragm: `all`), and the measure with the lowest (`best`):", "",
        *table(["diaphragm", *MEASURES] + (["best"] if ranked else []),
               _efficiency_rows(eff, ranked)), "",
        *([] if ranked else
          [f"_No measure is ranked best: {too_few(m['records'], 'a ranking')}._", ""]),
        _save(P.plot_efficiency(eff), out, "efficiency.png"), ""]
    if m["alt"]:
        rows = [["default (above)", _fmt(_overall(eff)["sa_avg"], 2)]] + [
            [name, _fmt(float(v.median()), 2)] for name, v in m["alt"].items()]
        lines += ["The period range of `sa_avg` matters: median dispersion over every wall "
                  "and diaphragm with other ranges (10 log-spaced periods each; the records' "
                  "spectra computed again):", "", *table(["sa_avg range", "dispersion"],
                                                         rows), "",
                  "The default range was chosen while urmx was developed, on this study, "
                  "among these and a few other ranges (it gave the lowest dispersion on "
                  "either half of the records, split by record order or alternately); on "
                  "other walls or records it is a reasoned start, not a proven optimum.", ""]
    lines += _sufficiency(m)
    if not ranked:
        return lines + [f"**Recommendation.** None: "
                        f"{too_few(m['records'], 'a recommendation')}.", "",
                        *_measure_table(ds, eff, False)]
    return lines + _recommendation(m) + _measure_table(ds, eff)


def _trends(m: dict, im: str) -> tuple[int, int] | None:
    """Cases with p < 0.05 on magnitude and on distance of measure `im` (None: unknown)."""
    s = m["suff"]
    if s is None:
        return None
    r = s.sel(measure=im)
    return int((r.p_magnitude < 0.05).sum()), int((r.p_distance < 0.05).sum())


def _recommendation(m: dict) -> list[str]:
    """Which measure urmx recommends for walls on flexible diaphragms, and why, from the
    numbers above."""
    eff = m["eff"]
    overall = _overall(eff)
    best = _recommended(m)
    second = sorted(overall, key=overall.get)[1]
    wins = [str(d) for d, b in zip(eff.diaphragm.values, eff.best.values, strict=True)
            if str(b) == best]
    others = {str(d): str(b) for d, b in zip(eff.diaphragm.values, eff.best.values,
                                             strict=True) if str(b) != best}
    text = (f"**Recommendation.** For walls on flexible diaphragms urmx recommends `{best}`: "
            f"its capacities have the lowest median dispersion ({_fmt(overall[best], 2)}, "
            f"against {_fmt(overall[second], 2)} for the next, `{second}`) and the lowest "
            f"on {len(wins)} of {eff.diaphragm.size} diaphragm cases")
    if others:
        text += " (elsewhere " + ", ".join(f"`{b}` on {d}" for d, b in others.items()) + ")"
    text += (f"; the records needed for the same confidence in a median scale with beta "
             f"squared, so `{best}` needs about "
             f"{pct((overall[best] / overall[second]) ** 2)} of the records "
             f"`{second}` needs")
    trends = _trends(m, best)
    if trends is not None:
        n = int(np.isfinite(m["suff"].p_magnitude.sel(measure=best)).sum())
        text += (f", and its residuals trend with magnitude in {trends[0]} and with "
                 f"distance in {trends[1]} of {n} cases (p < 0.05)")
    def span(im: str) -> str:
        t = eff.typical_dispersion.sel(measure=im)
        lo, hi = str(t.idxmin("diaphragm").values), str(t.idxmax("diaphragm").values)
        if lo == hi:
            return f"is {_fmt(float(t.sel(diaphragm=lo)), 2)} on {lo}"
        return (f"runs from {_fmt(float(t.sel(diaphragm=lo)), 2)} on {lo} to "
                f"{_fmt(float(t.sel(diaphragm=hi)), 2)} on {hi}")

    over = "Over the diaphragms" if eff.diaphragm.size > 1 else "On the one diaphragm"
    return [text + f". {over} `sa_diaphragm` {span('sa_diaphragm')}, "
            f"`{best}` {span(best)}.", ""]


def _sufficiency(m: dict) -> list[str]:
    lines = ["### Sufficiency", ""]
    s = m["suff"]
    if s is None:
        return lines + ["_Not available: the records' magnitudes and distances are not known "
                        "(record manifest and library/catalog.tsv of the records folder)._", ""]
    n = int(np.isfinite(s.p_magnitude.sel(measure=MEASURES[0])).sum())
    rows = []
    for im in MEASURES:
        r = s.sel(measure=im)
        rows.append([f"`{im}`", _fmt(float(r.slope_magnitude.median()), 2),
                     f"{int((r.p_magnitude < 0.05).sum())}/{n}",
                     _fmt(float(r.slope_distance.median()), 2),
                     f"{int((r.p_distance < 0.05).sum())}/{n}"])
    mag, dist = m["mag"], m["dist"]
    return lines + [
        "Per wall and diaphragm, the residuals ln(capacity) - mean over the records that "
        "collapse the wall, regressed on the records' moment magnitude and on ln(rupture "
        f"distance) (Luco & Cornell 2007; magnitudes {np.nanmin(mag):g}-{np.nanmax(mag):g}, "
        f"distances {np.nanmin(dist):g}-{np.nanmax(dist):g} km from the record manifest and "
        "the record library's catalog): the median slope over the cases and the cases whose "
        "slope has p < 0.05. A sufficient measure leaves no trend: about 5 % of cases at "
        "p < 0.05 by chance, though the cases share their records, so they are not "
        "independent. The p-values "
        + ("resample " + FA.grouping_sentence(m.get("groups")) + " (cluster bootstrap of the "
           "slope, `urmx.analysis.ida.group_slope_p`): the two components of a station "
           "share its magnitude and distance, and a t-test would count them twice."
           if m.get("groups") is not None else "are the t-test's (the records carry no "
           "`group`)."), "",
        *table(["measure", "slope on magnitude [1/unit M]", "cases p < 0.05",
                "slope on ln distance [1]", "cases p < 0.05"], rows), ""]


def _measure_table(ds: xr.Dataset, eff: xr.Dataset, intervals: bool = True) -> list[str]:
    """Every wall and diaphragm's dispersion in each measure, with its interval when
    `intervals` (enough records), a degenerate one flagged (`urmx.reports.common.interval`)."""
    rows = []
    def two(v):
        return _fmt(v, 2)

    for lab in [str(x) for x in eff.diaphragm.values]:
        for w in eff.wall.values:
            e = eff.sel(diaphragm=lab, wall=w)
            rows.append([lab, str(w)] + [
                two(float(e.dispersion.sel(measure=im))) + (" " + interval(
                    float(e.dispersion.sel(measure=im)),
                    float(e.dispersion_lower.sel(measure=im)),
                    float(e.dispersion_upper.sel(measure=im)), two) if intervals else "")
                for im in MEASURES])
    text = " ".join(" ".join(r) for r in rows)
    head = (f"Dispersion beta in each measure with its {LEVEL} studentized bootstrap interval "
            "(`urmx.fragility.fit_lognormal`; resampling "
            + FA.grouping_sentence(FA.record_groups(ds)) + "):"
            if intervals else "Dispersion beta in each measure (no intervals: "
            f"{too_few(int(ds.record.size), 'an interval')}):")
    return ["### Dispersion of every wall and diaphragm", "", head, "",
            *table(["diaphragm", "wall", *MEASURES], rows), "",
            *([DEGENERATE_NOTE, ""] if DEGENERATE in text else [])]


# ---- collapse risk ---------------------------------------------------------------------------

def risk_numbers(ds: xr.Dataset, hazard, spectrum, years: float, records_dir=None,
                 site: int = 0) -> dict | None:
    """The collapse risk per (wall, diaphragm) over `hazard` (with its deaggregation and
    extrapolated share), its change when the diaphragm is stiffened, and the margins over
    `spectrum` (None without the measures). The bootstraps resample the records' groups
    (`urmx.analysis.ida.record_groups`) when they have them."""
    if not _has_measures(ds):
        return None
    curve = hazard if isinstance(hazard, HazardCurve) else read_hazard(hazard, site)
    groups = FA.record_groups(ds, records_dir)
    risk = FA.collapse_risk(ds, curve, years, groups=groups, records_dir=records_dir)
    return {"curve": curve, "risk": risk, "change": FA.risk_change(risk),
            "margins": None if spectrum is None else FA.margins(ds, spectrum),
            "years": years, "records": records_per_cell(ds), "groups": groups}


def _rate(v: float) -> str:
    return "-" if not np.isfinite(v) else f"{v:.2g}"


def _rate_ci(v: float, lo: float, hi: float) -> str:
    """A rate with its interval in brackets (none when there is no interval: too few
    records or groups to resample)."""
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return _rate(v)
    return f"{_rate(v)} [{_rate(lo)}-{_rate(hi)}]"


def risk_findings(r: dict | None) -> list[str]:
    """Findings bullets: the range of the rates and the change when stiffening."""
    if r is None:
        return []
    risk, years = r["risk"], r["years"]
    low = risk.rate.where(risk.rate == risk.rate.min(), drop=True)
    high = risk.rate.where(risk.rate == risk.rate.max(), drop=True)
    site = f"- **Collapse risk at the illustrative site** ({Path(r['curve'].source).name}). "
    if not bool(np.isfinite(risk.rate).any()):
        return [site + "No rate: no wall has a fitted fragility (a fit needs at least two "
                f"records with a capacity; this archive has {r.get('records', '?')})."]
    if not enough_records(r.get("records", MIN_RISK)):
        site += f"(From {r['records']} records per wall: an estimate, no interval.) "
    where = f"({str(low.wall.values[0])} on {str(low.diaphragm.values[0])})"
    if risk.rate.size == 1:
        site += (f"The mean annual frequency of collapse is {_rate(float(risk.rate.min()))} "
                 f"{where} per year: a probability of collapse in {years:g} years of "
                 f"{pct(float(risk.probability.min()))}.")
    else:
        site += (f"The mean annual frequency of collapse runs from "
                 f"{_rate(float(risk.rate.min()))} {where} to {_rate(float(risk.rate.max()))} "
                 f"({str(high.wall.values[0])} on {str(high.diaphragm.values[0])}) per year: "
                 f"a probability of collapse in {years:g} years of "
                 f"{pct(float(risk.probability.min()))} to "
                 f"{pct(float(risk.probability.max()))}.")
    lines = [site]
    for g, v in r["change"].items():
        ratio = v["ratio"]
        down = [str(w) for w in ratio.wall.values if float(ratio.sel(wall=w)) < 1.0]
        lines.append(f"- **Stiffening {v['soft']} -> {v['stiff']} in annual risk, "
                     f"{_group_name(g)} walls.** The rate of collapse changes by a factor "
                     f"{_ratio(float(ratio.min()))} to {_ratio(float(ratio.max()))}; it "
                     f"falls for {len(down)} of {ratio.wall.size} walls.")
    return lines


def comparison_findings(c: xr.Dataset | None, records: int = MIN_RECORDS) -> list[str]:
    """The findings bullet of `im_comparison` (from fewer than `MIN_RECORDS` records per
    wall and diaphragm: what it would need, no ratio of rates)."""
    if c is None:
        return []
    if not enough_records(records):
        return [f"- **Risk in pga against sa_avg.** Not compared: "
                f"{too_few(records, 'comparing rates in two measures')}."]
    labs = [str(x) for x in c.diaphragm.values if FA.base_label(str(x)) in STIFFEN]
    ratio = c.ratio.sel(diaphragm=labs)
    ext = c.pga_extrapolated.sel(diaphragm=labs)
    return [f"- **Risk in pga against sa_avg.** Over a hazard curve built the same NZS "
            f"1170.5 way in `sa_avg`, the rate of collapse of a wall on "
            f"{', '.join(labs)} is {_fmt(float(ratio.min()), 2)} to "
            f"{_fmt(float(ratio.max()), 2)} times its rate in `pga` (median "
            f"{_fmt(float(ratio.median()), 2)}); in `pga`, {100 * float(ext.min()):.0f} % to "
            f"{100 * float(ext.max()):.0f} % of these walls' rates comes from ground "
            "motions beyond the curve's last computed intensity (section \"Collapse "
            "risk\")."]


def risk_lines(ds: xr.Dataset, r: dict, heading: str = "###") -> list[str]:
    """The tables of the collapse risk: rate (with interval) and probability per wall and
    diaphragm, the change when stiffening, the margins (what ``urmx risk`` prints)."""
    risk, curve, years = r["risk"], r["curve"], r["years"]
    f, unit = P.display_scale(curve.units)
    d = FA.first_cor(ds)
    sure = enough_records(r.get("records", MIN_RISK))
    lines = []
    for g, labels in FA.supports_groups(d).items():
        rows = [[str(w), f"{float(d.slenderness.sel(wall=w)):.0f}"] + [
            _rate(float(c.rate)) + (" " + interval(float(c.rate), float(c.rate_lower),
                                                   float(c.rate_upper), _rate)
                                    if sure else "") + f", {pct(float(c.probability))}"
            for c in (risk.sel(wall=w, diaphragm=lab) for lab in labels)]
            for w in d.wall.values]
        said = (f"with its {LEVEL} studentized bootstrap interval (resampling "
                + FA.grouping_sentence(r.get("groups")) + ")" if sure else
                f"(no interval: {too_few(r['records'], 'an interval')})")
        lines += [f"{heading} {GROUPS.get(g, g).capitalize()}", "",
                  f"Mean annual frequency of collapse [1/yr] {said}, and the probability "
                  f"of collapse in {years:g} years; fits in `{curve.im}` [{unit}] of the "
                  f"capacities at COR {float(d.cor):g}:", "",
                  *table(["wall", "h/t", *labels], rows), ""]
        if any(DEGENERATE in c for row in rows for c in row):
            lines += [DEGENERATE_NOTE, ""]
    lines += _change_lines(d, r, heading)
    if r["margins"] is not None:
        lines += _margin_lines(d, r, heading)
    lines += deaggregation_lines(d, r, heading)
    return lines


def _computed_text(curve, f: float, unit: str) -> str:
    if curve.computed_to is None:
        return (f"the file marks no intensity as the last computed (no `# computed_to` "
                f"line), so only the extension beyond its last row, "
                f"{_fmt(curve.intensity[-1] * f)} {unit}, counts as extrapolated")
    return (f"the file marks {_fmt(curve.computed_to * f)} {unit} as the last computed "
            "intensity (its `# computed_to` line, or an OpenQuake file's last level); "
            "beyond it the curve is extrapolated")


def deaggregation_lines(d: xr.Dataset, r: dict, heading: str = "###") -> list[str]:
    """Where each rate comes from: its shares by band of intensity (return periods of the
    hazard curve) and from beyond the last computed intensity."""
    risk, curve = r["risk"], r["curve"]
    f, unit = P.display_scale(curve.units)
    cell0 = risk.isel(wall=0, diaphragm=0)
    lows, highs = cell0.band_low.values * f, cell0.band_high.values * f

    periods = [0.0, *BAND_PERIODS, math.inf]
    head = ["diaphragm", "wall", "rate [1/yr]"] + [
        f"{_fmt(lo)}-{_fmt(hi)} {unit} ({_period(periods[k])}-{_period(periods[k + 1])} yr)"
        for k, (lo, hi) in enumerate(zip(lows, highs, strict=True))] + ["extrapolated"]
    rows = []
    for lab in [str(x) for x in risk.diaphragm.values]:
        for w in risk.wall.values:
            c = risk.sel(wall=w, diaphragm=lab)
            rows.append([lab, str(w), _rate(float(c.rate))]
                        + [f"{100 * v:.0f} %" for v in c.band_share.values]
                        + [f"{100 * float(c.extrapolated_share):.0f} %"])
    ext = risk.extrapolated_share
    return [f"{heading} Where the rate comes from", "",
            "The share of each rate from ground motions in each band of intensity (bounded "
            "by the hazard curve's intensities at return periods "
            + ", ".join(f"{p:g}" for p in BAND_PERIODS) + " years: the integral of "
            "P(collapse | x) |d lambda(x)| over the band, `urmx.fragility.risk.deaggregate`) "
            "and from beyond the last computed intensity: "
            f"{_computed_text(curve, f, unit)}. That extrapolated share {_span(ext)}: "
            "where it is large the rate rests on the extension of the curve, not on the "
            "hazard the file computes.", "",
            *table(head, rows), ""]


def _span(ext: xr.DataArray) -> str:
    """``runs from a % to b % (median m %)``, or ``is a %`` when every share prints alike
    (one wall and diaphragm: no range to state)."""
    lo, hi = _share(float(ext.min())), _share(float(ext.max()))
    if lo == hi:
        return f"is {lo} %"
    return f"runs from {lo} % to {hi} % (median {_share(float(ext.median()))} %)"


def _share(v: float) -> str:
    """A share in percent: two significant digits below 10 %, whole percents above."""
    return f"{100 * v:.2g}" if 100 * v < 10 else f"{100 * v:.0f}"


def _period(p: float) -> str:
    return "0" if p == 0 else ("inf" if not math.isfinite(p) else f"{p:g}")


def _change_lines(d: xr.Dataset, r: dict, heading: str) -> list[str]:
    change = r["change"]
    if not change:
        return [f"_No stiffening: the archive lacks {STIFFEN[0]} or {STIFFEN[1]}._", ""]
    head, rows = ["wall", "h/t"], []
    for g, v in change.items():
        head += [f"{v['soft']} [1/yr]", f"{v['stiff']} [1/yr]", f"{_group_name(g)}: ratio"]
    for w in d.wall.values:
        row = [str(w), f"{float(d.slenderness.sel(wall=w)):.0f}"]
        for v in change.values():
            row += [_rate(float(v["rate_soft"].sel(wall=w))),
                    _rate(float(v["rate_stiff"].sel(wall=w))),
                    _fmt(float(v["ratio"].sel(wall=w)), 2)]
        rows.append(row)
    return [f"{heading} Stiffening the diaphragm: {STIFFEN[0]} -> {STIFFEN[1]}", "",
            "The mean annual frequency of collapse with the as-built and the stiffened "
            "diaphragm, and their ratio (below 1: the retrofit lowers the risk):", "",
            *table(head, rows), ""]


def _margin_lines(d: xr.Dataset, r: dict, heading: str) -> list[str]:
    mg = r["margins"]
    f, unit = P.display_scale("m s-2")
    lines = [f"{heading} Margin over the design spectrum", "",
             f"The median collapse capacity in `sa_wall` over the design spectrum's Sa at the "
             f"wall's rocking period ({Path(mg.attrs['spectrum']).name}; below 1: the median "
             "wall collapses under the design spectrum's intensity at its period; T_r and "
             "the design Sa of the group's first diaphragm):", ""]
    for g, labels in FA.supports_groups(d).items():
        rows = [[str(w), f"{float(d.slenderness.sel(wall=w)):.0f}",
                 f"{float(d.rocking_period.sel(wall=w, diaphragm=labels[0])):.2f}",
                 _fmt(float(mg.design_sa.sel(wall=w, diaphragm=labels[0])) * f)]
                + [_fmt(float(mg.margin.sel(wall=w, diaphragm=lab)), 3) for lab in labels]
                for w in d.wall.values]
        lines += [f"{GROUPS.get(g, g).capitalize()}:", "",
                  *table(["wall", "h/t", "T_r [s]", f"design Sa(T_r) [{unit}]", *labels],
                         rows), ""]
    return lines


# ---- the same wall's rate in pga and in sa_avg ----------------------------------------------

def sa_avg_factor(ds: xr.Dataset, spectrum) -> xr.DataArray:
    """Per (wall, diaphragm) at the first COR: the design spectrum's geometric mean over the
    cell's ``sa_avg`` periods (`urmx.fragility.sa_avg_range` from the archive's rocking
    period and diaphragm frequency, 10 log-spaced periods) over its value at T = 0 (the
    PGA). A hazard curve built from the spectrum scaled by the return period factor (NZS
    1170.5: Sa(T) = Ch(T) Z R N) has in ``sa_avg`` this factor times the PGA curve's
    intensities at every return period (`urmx.fragility.risk.scaled_curve`). [1]"""
    spec = spectrum if isinstance(spectrum, DesignSpectrum) else read_spectrum(spectrum)
    d = FA.first_cor(ds)
    tr = d.rocking_period.transpose("wall", "diaphragm").values
    with np.errstate(divide="ignore"):
        td = np.nan_to_num(1.0 / d.cell_frequency.transpose("wall", "diaphragm").values)
    lo = np.maximum(np.minimum(td, tr) / SA_AVG_WIDEN, SA_AVG_FLOOR * tr)
    hi = SA_AVG_WIDEN * np.maximum(td, tr)
    periods = np.geomspace(lo, hi, SA_AVG_PERIODS, axis=-1)
    mean = np.exp(np.mean(np.log(design_sa(spec, periods)), axis=-1))
    return xr.DataArray(mean / float(design_sa(spec, 0.0)), dims=("wall", "diaphragm"),
                        coords={"wall": d.wall, "diaphragm": d.diaphragm})


def im_comparison(ds: xr.Dataset, r: dict, spectrum, records_dir=None) -> xr.Dataset | None:
    """The rate of every (wall, diaphragm) in ``pga`` (`risk_numbers`) beside its rate in
    ``sa_avg`` over a curve built from the same spectrum the same way (`sa_avg_factor`), with
    the ratio's two parts when the PGA curve is a power law ``k0 x^-k`` (exact then: a
    lognormal fragility's rate is ``k0 median^-k exp(k^2 beta^2 / 2)``, Cornell et al. 2002):
    ``shape = (factor / (median_sa_avg / median_pga))^k``, how the records' spectral shape
    at collapse differs from the code spectrum's, and ``spread = exp(k^2 (beta_sa_avg^2 -
    beta_pga^2) / 2)``, the dispersions. None without a pga curve or a spectrum, or when no
    diaphragm of the archive is one the comparison is shown on (`STIFFEN`: an own support)."""
    if r is None or spectrum is None or r["curve"].im != "pga":
        return None
    if not any(FA.base_label(str(x)) in STIFFEN for x in ds.diaphragm.values):
        return None
    factor = sa_avg_factor(ds, spectrum)
    d = FA.first_cor(ds)
    rates = {n: np.full((d.wall.size, d.diaphragm.size), np.nan) for n in (
        "rate", "rate_lower", "rate_upper", "extrapolated_share", "median_collapse_intensity",
        "dispersion")}
    for iw, idp in np.ndindex(factor.shape):
        sub = ds.isel(wall=[iw], diaphragm=[idp], cor=[0])
        curve = scaled_curve(r["curve"], float(factor[iw, idp]), "sa_avg")
        one = FA.collapse_risk(sub, curve, r["years"], groups=r.get("groups"),
                               records_dir=records_dir)
        for n in rates:
            rates[n][iw, idp] = float(one[n].values[0, 0])
    avg = xr.Dataset({n: (("wall", "diaphragm"), v) for n, v in rates.items()},
                     coords={"wall": d.wall, "diaphragm": d.diaphragm})
    pga = r["risk"]
    lx, ll = np.log(r["curve"].intensity), np.log(r["curve"].rate)
    k = -float(np.polyfit(lx, ll, 1)[0])
    shape = (factor / (avg.median_collapse_intensity / pga.median_collapse_intensity)) ** k
    spread = np.exp(k * k * (avg.dispersion ** 2 - pga.dispersion ** 2) / 2)
    return xr.Dataset({"factor": factor, "ratio": avg.rate / pga.rate, "shape": shape,
                       "spread": spread, **{f"avg_{n}": avg[n] for n in avg},
                       "pga_rate": pga.rate, "pga_lower": pga.rate_lower,
                       "pga_upper": pga.rate_upper,
                       "pga_extrapolated": pga.extrapolated_share}).assign_attrs(k=k)


def im_comparison_lines(c: xr.Dataset | None) -> list[str]:
    """The report's table of the same wall's rate in pga and in sa_avg, and why they
    differ."""
    if c is None:
        return []
    labs = [str(x) for x in c.diaphragm.values if FA.base_label(str(x)) in STIFFEN]
    rows = []
    for lab in labs:
        for w in c.wall.values:
            e = c.sel(wall=w, diaphragm=lab)
            rows.append([lab, str(w),
                         _rate_ci(float(e.pga_rate), float(e.pga_lower), float(e.pga_upper)),
                         f"{100 * float(e.pga_extrapolated):.0f} %",
                         _rate_ci(float(e.avg_rate), float(e.avg_rate_lower),
                                  float(e.avg_rate_upper)),
                         f"{100 * float(e.avg_extrapolated_share):.0f} %",
                         _fmt(float(e.ratio), 2), _fmt(float(e.shape), 2),
                         _fmt(float(e.spread), 2)])
    ratio = c.ratio.sel(diaphragm=labs)
    return ["### The same walls' rate in pga and in sa_avg", "",
            "The illustrative PGA curve is a power law fitted to the NZS 1170.5 spectrum at "
            "T = 0 (class D, Z = 0.3) over 250-2500 years. Built the same way from the "
            "spectrum's geometric mean over each wall's `sa_avg` periods (the design "
            "spectrum of `catalog/hazard/`, Sa(T) = Ch(T) Z R: every ordinate scales with "
            "the return period factor R), the `sa_avg` curve is the PGA curve with its "
            "intensities times that mean over Ch(0) (`urmx.risk_report.sa_avg_factor`, "
            f"{_fmt(float(c.factor.min()), 3)}-{_fmt(float(c.factor.max()), 3)} here), and "
            "its last computed intensity likewise. The fragility in `sa_avg` is fitted to "
            "the same IDA's capacities in `sa_avg` (no new analyses).", "",
            f"On these walls the `sa_avg` rate is {_fmt(float(ratio.min()), 2)} to "
            f"{_fmt(float(ratio.max()), 2)} times the `pga` rate (median "
            f"{_fmt(float(ratio.median()), 2)}): the measure alone moves the answer by more "
            "than the rate's interval. With a power-law curve (k = "
            f"{float(c.attrs['k']):.3g}) the ratio is exactly the product of two parts: "
            "**shape**, (the code spectrum's sa_avg/PGA over the records' at collapse)^k: "
            "the records' spectra are not the code spectrum's shape, so a wall that "
            "collapses at a given PGA collapses at an sa_avg that the code spectrum reaches "
            "at another return period; and **spread**, exp(k^2 (beta_sa_avg^2 - "
            "beta_pga^2) / 2): the rate grows with the fragility's dispersion, and the "
            "dispersions differ between the measures. Neither rate is wrong: they answer "
            "for two different hazard models that agree only if real ground motions at the "
            "site have the code spectrum's shape; a site hazard computed for `sa_avg` "
            "directly (OpenQuake's AvgSA) removes the shape assumption.", "",
            *table(["diaphragm", "wall", "rate in pga [1/yr]", "pga: extrapolated",
                    "rate in sa_avg [1/yr]", "sa_avg: extrapolated", "ratio sa_avg / pga",
                    "shape", "spread"], rows), ""]


def _closed_form(r: dict) -> list[str]:
    """The Cornell et al. (2002) closed form next to the integral when the hazard curve is a
    power law."""
    curve, risk = r["curve"], r["risk"]
    lx, ll = np.log(curve.intensity), np.log(curve.rate)
    k, b = np.polyfit(lx, ll, 1)
    if np.max(np.abs(ll - (k * lx + b))) > 1e-3:
        return []
    cell = risk.isel(wall=risk.wall.size // 2, diaphragm=0)
    med, beta = float(cell.median_collapse_intensity), float(cell.dispersion)
    exact = math.exp(b) * med ** k * math.exp(k * k * beta * beta / 2)
    return [f"Check: the hazard curve is a power law (k = {-k:.3g}); the closed form "
            "k0 median^-k exp(k^2 beta^2 / 2) (Cornell et al. 2002) gives "
            f"{_rate(exact)} per year for {str(cell.wall.values)} on "
            f"{str(cell.diaphragm.values)}, the integral {_rate(float(cell.rate))} "
            f"(difference {100 * (float(cell.rate) / exact - 1):.1g} %).", ""]


def risk_section(ds: xr.Dataset, r: dict | None, out: Path,
                 comparison: xr.Dataset | None = None) -> list[str]:
    """The "Collapse risk" section of the fragility report (with `im_comparison`'s table
    when given)."""
    lines = ["## Collapse risk", ""]
    if r is None:
        return lines + [OLDER, ""]
    curve = r["curve"]
    lines += [
        f"The fragility of each wall integrated over a hazard curve "
        f"(`urmx.fragility.collapse_rate`; `{Path(curve.source).name}` of `catalog/hazard/`: "
        "an **illustrative** curve, a power law fitted to the NZS 1170.5 site spectrum at "
        "T = 0 for site class D and Z = 0.3 between 250 and 2500 years, see the file's "
        "header; not the hazard of any real site). Same in two commands: `urmx ida` then "
        "`urmx risk ARCHIVE --hazard curve.csv`.", "",
        _save(P.plot_collapse_risk(r["risk"], curve), out, "collapse_risk.png"), "",
        *_closed_form(r), *risk_lines(ds, r), *im_comparison_lines(comparison)]
    return lines
