"""The report of a ``wall-population`` archive (issue 37): which wall parameter predicts
collapse, and a resonance-aware rule. Writes ``REPORT.md``, its figures and
``numbers.json`` (the fitted relations and the rule, which `urmx.assess.urmx_rule` states)
into a folder.

Regenerate the committed report with::

    urmx run wall-population --out results/wall-population.nc
    python -m urmx.reports.predictors results/wall-population.nc --out reports/predictors

The analysis is `urmx.analysis.predictors`; the ranking `urmx.fragility.ranking`; the
predictors `urmx.fragility.predictors`.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis import predictors as pa
from ..errors import InputError
from ..fragility.ranking import recommend, within
from .common import made_from

LABELS = {"slenderness": "h/t", "height": "h", "thickness": "t",
          "static_acceleration": "a_rock (Table I M0)", "instability_case2": "Delta_2",
          "instability_case3": "Delta_3 (Case 3)", "housner_lower": "p lower (Housner)",
          "housner_upper": "p upper (Housner)", "effective_period": "T_eff (0.6 Delta)",
          "diaphragm_frequency": "f_d", "frequency_ratio": "f_d T_eff",
          "diaphragm_weight": "q (control)"}


def _label(names) -> str:
    return " + ".join(LABELS.get(n, n) for n in names)


def _run_seconds(ds, path: Path) -> float | None:
    """Wall time of the run: the archive's last write minus the start the history
    records."""
    try:
        started = datetime.fromisoformat(ds.attrs["history"].split(" ")[0])
        return path.stat().st_mtime - started.timestamp()
    except (KeyError, ValueError, OSError):
        return None


def analyse(ds, replicates: int = 200) -> dict[str, Any]:
    """Every table of the report from an open archive."""
    pop = pa.population(ds)
    ranks = pa.rankings(pop, replicates=replicates)
    rec = {}
    for key, r in ranks.items():
        i = recommend(r)
        ht = r.index(("slenderness",))
        rec[key] = {"recommended": pa.relation(r, i), "best": pa.relation(r, 0),
                    "slenderness": pa.relation(r, ht), "rank_slenderness": ht + 1,
                    "best_single": pa.relation(r, next(j for j, s in enumerate(r.sets)
                                                       if len(s) == 1))}
    return {"pop": pop, "corr": pa.correlations(pop), "ranks": ranks, "rec": rec,
            "rigid": pa.rigid_reference(pop, replicates=replicates),
            "resonance": pa.resonance(pop, replicates=replicates)}


# ---- figures ------------------------------------------------------------------------------

def _fig_capacity(a: dict[str, Any], out: Path) -> str:
    """Median collapse PGA against h/t, the static acceleration that starts rocking and the
    recommended criterion's prediction, coloured by the diaphragm frequency (rigid tops
    grey)."""
    from matplotlib.colors import LogNorm
    from matplotlib.figure import Figure

    pop = a["pop"]
    fig = Figure(figsize=(14, 8.5), layout="constrained")
    axes = fig.subplots(2, 3, squeeze=False)
    for row, storey in enumerate(pa.STOREYS):
        st = pop["storey"] == storey
        rel = a["rec"][storey, "pga"]["recommended"]
        fitted = np.exp(rel["intercept"] + sum(
            b * np.log(pop[n] if n in pa.INPUTS else pop[f"p_{n}"])
            for n, b in zip(rel["names"], rel["exponents"], strict=True)))
        columns = [("h/t", pop["p_slenderness"]),
                   (LABELS["static_acceleration"] + " [g]", pop["p_static_acceleration"] / 9.81),
                   (f"recommended: {_power_law(rel)} [g]", fitted / 9.81)]
        for col, (label, x) in enumerate(columns):
            ax = axes[row, col]
            rig = st & pop["rigid"]
            ax.scatter(x[rig], pop["median_pga"][rig] / 9.81, c="0.6", s=8, label="rigid top")
            fl = st & ~pop["rigid"]
            sc = ax.scatter(x[fl], pop["median_pga"][fl] / 9.81, s=8, cmap="viridis",
                            c=pop["p_diaphragm_frequency"][fl], norm=LogNorm(0.8, 8.0))
            if col == 2:
                lim = [np.nanmin(fitted[fl]) / 9.81, np.nanmax(fitted[fl]) / 9.81]
                ax.plot(lim, lim, c="k", lw=0.8, label="1:1")
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel(label, fontsize=8)
            ax.set_ylabel(f"median collapse PGA [g], {storey} storey", fontsize=8)
            ax.legend(loc="best", fontsize=7)
        fig.colorbar(sc, ax=axes[row, :].tolist(), label="diaphragm frequency [Hz]")
    name = "capacity-vs-predictors.png"
    fig.savefig(out / name, dpi=100)
    return name


def _fig_ranking(a: dict[str, Any], out: Path, top: int = 15) -> str:
    """The ranking with its bootstrap intervals: the top sets and h/t, per storey and
    measure."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(13, 10), layout="constrained")
    axes = fig.subplots(2, 2)
    for (i, storey), (j, im) in ((s, m) for s in enumerate(pa.STOREYS)
                                 for m in enumerate(pa.MEASURES)):
        r, ax = a["ranks"][storey, im], axes[i, j]
        show = list(range(min(top, len(r.sets))))
        for extra in (("slenderness",), ("diaphragm_weight",)):
            if r.index(extra) not in show:
                show.append(r.index(extra))
        y = np.arange(len(show))[::-1]
        rec = pa_index(a, storey, im)
        colors = ["C3" if k == rec else ("C1" if r.sets[k] == ("slenderness",) else "C0")
                  for k in show]
        ax.errorbar(r.share[show], y, xerr=[r.share[show] - r.lower[show],
                                            r.upper[show] - r.share[show]],
                    fmt="none", ecolor=colors)
        ax.scatter(r.share[show], y, c=colors, s=14, zorder=3)
        ax.set_yticks(y, [f"{r.rank(r.sets[k])}. {_label(r.sets[k])}" for k in show],
                      fontsize=7)
        ax.set_xlabel(f"cross-validated share of var ln C ({im})")
        ax.set_title(f"{storey} storey, flexible diaphragms, {r.n} walls", fontsize=9)
        ax.axvline(0.0, color="0.7", lw=0.8)
    name = "ranking.png"
    fig.savefig(out / name, dpi=110)
    return name


def pa_index(a: dict[str, Any], storey: str, im: str) -> int:
    """Index of the recommended set in the ranking of (storey, im)."""
    r = a["ranks"][storey, im]
    return r.index(a["rec"][storey, im]["recommended"]["names"])


def _fig_resonance(a: dict[str, Any], out: Path) -> str:
    """The resonance data: the residual of each (wall, record) capacity against the log
    frequency ratio (binned means with intervals) and against Sa(T_d)/PGA (the rule)."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import NullFormatter

    fig = Figure(figsize=(12, 8.5), layout="constrained")
    axes = fig.subplots(2, 2)
    for i, storey in enumerate(pa.STOREYS):
        res = a["resonance"][storey]
        ax = axes[i, 0]
        ax.scatter(np.exp(res["x"]), res["e"], s=2, c="0.75", rasterized=True)
        mid = np.exp(0.5 * (res["edges"][1:] + res["edges"][:-1]))
        ax.errorbar(mid, res["mean"], yerr=[res["mean"] - res["lower"],
                                            res["upper"] - res["mean"]], fmt="o-", c="C3",
                    label="binned mean")
        ax.plot(mid, res["mean_adjusted"], "s--", c="C0", ms=4,
                label="each record's own mean taken out")
        ax.axvspan(1 / pa.BAND, pa.BAND, color="C1", alpha=0.2, label="resonance band")
        ax.set_xscale("log")
        ax.set_xlabel("record's dominant frequency / diaphragm frequency")
        ax.set_ylabel(f"ln(C / median C), {storey} storey")
        ax.legend(fontsize=7)
        ax = axes[i, 1]
        ax.scatter(np.exp(res["s"]), res["e"], s=2, c="0.75", rasterized=True)
        s = np.linspace(res["s"].min(), res["s"].max(), 50)
        ax.plot(np.exp(s), res["slope"] * (s - res["s_mean"]), c="C3",
                label=f"ln C/median = {res['slope']:.2f} ln(S / {math.exp(res['s_mean']):.2f})")
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("S = Sa(T_d) / PGA of the record")
        ax.legend(fontsize=7)
    name = "resonance.png"
    fig.savefig(out / name, dpi=110)
    return name


def _fig_correlation(a: dict[str, Any], out: Path) -> str:
    """The design's correlation matrices (sampled inputs; log predictors)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(15, 6.5), layout="constrained")
    axes = fig.subplots(1, 2)
    for ax, key in zip(axes, ("inputs", "predictors"), strict=True):
        c = a["corr"][key]
        im = ax.imshow(c["r"], vmin=-1, vmax=1, cmap="RdBu_r")
        labels = [LABELS.get(n, n) if key == "predictors" else n for n in c["names"]]
        ax.set_xticks(range(len(labels)), labels, rotation=70, fontsize=7)
        ax.set_yticks(range(len(labels)), labels, fontsize=7)
        for (i, j), v in np.ndenumerate(c["r"]):
            ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=5)
        ax.set_title(f"{key}: max |r| off the diagonal {c['max']:.2f}", fontsize=9)
    fig.colorbar(im, ax=axes.tolist())
    name = "correlation.png"
    fig.savefig(out / name, dpi=110)
    return name


# ---- the text -----------------------------------------------------------------------------

def _power_law(rel: dict[str, Any], unit: str = "g") -> str:
    scale = math.exp(rel["intercept"]) / 9.81
    terms = " ".join(f"{LABELS.get(n, n)}^{b:+.2f}" for n, b in
                     zip(rel["names"], rel["exponents"], strict=True))
    return f"C = {scale:.4g} {unit} x {terms}"


def numbers(a: dict[str, Any]) -> dict[str, Any]:
    """The fitted relations and the resonance rule, as plain data (``numbers.json``)."""
    out: dict[str, Any] = {"relations": {}, "resonance": {}}
    for (storey, im), rec in a["rec"].items():
        for key in ("recommended", "slenderness", "best"):
            r = rec[key]
            out["relations"][f"{storey}/{im}/{key}"] = {
                "predictors": list(r["names"]), "intercept": r["intercept"],
                "exponents": r["exponents"], "dispersion": r["dispersion"],
                "share": r["share"], "interval": list(r["interval"]), "walls": r["n"]}
    for storey in pa.STOREYS:
        res = a["resonance"][storey]
        out["resonance"][storey] = {
            "slope": res["slope"], "slope_interval": list(res["slope_interval"]),
            "s_reference": math.exp(res["s_mean"]), "band_factor": res["factor"],
            "band_factor_interval": list(res["factor_interval"]), "band": pa.BAND,
            "band_factor_adjusted": res["factor_adjusted"],
            "slope_within": res["slope_within"],
            "slope_within_interval": list(res["slope_within_interval"]),
            "band_factor_adjusted_interval": list(res["factor_adjusted_interval"]),
            "spread": res["spread"], "spread_rule": res["spread_rule"]}
    return out


def _fmt_share(r, k: int) -> str:
    return f"{r.share[k]:.2f} [{r.lower[k]:.2f}, {r.upper[k]:.2f}]"


def _ranking_table(a: dict[str, Any], storey: str, top: int = 15) -> list[str]:
    """Markdown rows: the sets ranked in PGA with their shares in PGA and sa_avg."""
    rp, rs = a["ranks"][storey, "pga"], a["ranks"][storey, "sa_avg"]
    show = list(range(min(top, len(rp.sets))))
    for extra in (("slenderness",), ("diaphragm_weight",)):
        if rp.index(extra) not in show:
            show.append(rp.index(extra))
    rows = ["| rank (PGA) | predictors | share, PGA [95 % interval] | rank (sa_avg) | "
            "share, sa_avg [95 % interval] | max VIF |", "|---|---|---|---|---|---|"]
    for k in show:
        s = rp.sets[k]
        j = rs.index(s)
        rows.append(f"| {k + 1} | {_label(s)} | {_fmt_share(rp, k)} | {j + 1} | "
                    f"{_fmt_share(rs, j)} | {rp.vif[k]:.2f} |")
    return rows


def _singles_table(a: dict[str, Any]) -> list[str]:
    """Markdown rows: each predictor alone, its share per storey and measure."""
    keys = [(s, m) for s in pa.STOREYS for m in pa.MEASURES]
    rows = ["| predictor alone | " + " | ".join(f"{s}, {m}" for s, m in keys) + " |",
            "|---|" + "---|" * len(keys)]
    for name in pa.RANKED:
        cells = []
        for key in keys:
            r = a["ranks"][key]
            cells.append(_fmt_share(r, r.index((name,))))
        rows.append(f"| {LABELS.get(name, name)} | " + " | ".join(cells) + " |")
    return rows


def _criterion_rows(a: dict[str, Any]) -> list[str]:
    rows = ["| storey | measure | recommended criterion | relation | residual dispersion | "
            "CV share [interval] | VIF | h/t: share, rank, dispersion |",
            "|---|---|---|---|---|---|---|---|"]
    for (storey, im), rec in a["rec"].items():
        r, ht = rec["recommended"], rec["slenderness"]
        unit = "g" if im == "pga" else "g (sa_avg)"
        rows.append(
            f"| {storey} | {im} | {_label(r['names'])} | {_power_law(r, unit)} | "
            f"{r['dispersion']:.3f} | {r['share']:.2f} [{r['interval'][0]:.2f}, "
            f"{r['interval'][1]:.2f}] | {max(r['vif']):.2f} | {ht['share']:.2f} "
            f"[{ht['interval'][0]:.2f}, {ht['interval'][1]:.2f}], rank "
            f"{rec['rank_slenderness']}, {ht['dispersion']:.3f} |")
    return rows


def _design_lines(a: dict[str, Any]) -> list[str]:
    c = a["corr"]
    pairs = [(c["predictors"]["names"][i], c["predictors"]["names"][j], c["predictors"]["r"][i, j])
             for i, j in zip(*np.triu_indices(len(c["predictors"]["names"]), 1), strict=True)
             if abs(c["predictors"]["r"][i, j]) > 0.9]
    lines = [f"- Sampled inputs: the largest |r| between two inputs is "
             f"**{c['inputs']['max']:.3f}** "
             f"({c['inputs']['pair'][0]}, {c['inputs']['pair'][1]}); the catalog's nine "
             "parametric walls had 0.996 between ln(h/t) and ln(rocking period). "
             f"{'No pair exceeds 0.9: met.' if c['inputs']['max'] <= 0.9 else 'NOT MET.'}",
             f"- Log predictors (walls on flexible diaphragms): the largest |r| is "
             f"**{c['predictors']['max']:.3f}** "
             f"({' / '.join(_label([p]) for p in c['predictors']['pair'])})."]
    if pairs:
        lines.append("  Pairs above 0.9, each a function of the other by its formula (not a "
                     "confound of the design, which cannot separate a quantity from its own "
                     "formula): " + "; ".join(f"{_label([p])} / {_label([q])} {r:+.3f}"
                                              for p, q, r in pairs) + ".")
    lines.append("- `Delta_2` (Case 2 instability displacement at crack height) equals t "
                 "exactly (Table I: theta0 = b / a1), so it is ranked as t.")
    return lines


def _resonance_lines(a: dict[str, Any]) -> list[str]:
    rows = ["| storey | cells | band cells | capacity factor in the band [95 %] | same, "
            "record severity out [95 %] | slope b [95 %] | slope within records [95 %] | "
            "S_ref | spread of ln C/median, before -> after the slope rule |",
            "|---|---|---|---|---|---|---|---|---|"]
    for storey in pa.STOREYS:
        r = a["resonance"][storey]
        rows.append(f"| {storey} | {len(r['e'])} | {r['band_cells']} | {r['factor']:.3f} "
                    f"[{r['factor_interval'][0]:.3f}, {r['factor_interval'][1]:.3f}] | "
                    f"{r['factor_adjusted']:.3f} [{r['factor_adjusted_interval'][0]:.3f}, "
                    f"{r['factor_adjusted_interval'][1]:.3f}] | {r['slope']:.3f} "
                    f"[{r['slope_interval'][0]:.3f}, "
                    f"{r['slope_interval'][1]:.3f}] | {r['slope_within']:.3f} "
                    f"[{r['slope_within_interval'][0]:.3f}, {r['slope_within_interval'][1]:.3f}]"
                    f" | {math.exp(r['s_mean']):.2f} | "
                    f"{r['spread']:.3f} -> {r['spread_rule']:.3f} |")
    rows += ["", "Binned mean of ln(C / median C) against the record's dominant frequency over "
             "the diaphragm's:", "", "| f_rec / f_d | " + " | ".join(pa.STOREYS) + " |",
             "|---|---|---|"]
    edges = a["resonance"]["single"]["edges"]
    for i in range(len(edges) - 1):
        cells = []
        for storey in pa.STOREYS:
            r = a["resonance"][storey]
            cells.append(f"{r['mean'][i]:+.3f} [{r['lower'][i]:+.3f}, {r['upper'][i]:+.3f}]"
                         f" ({r['count'][i]})" if np.isfinite(r["mean"][i]) else "-")
        rows.append(f"| {math.exp(edges[i]):.2f}-{math.exp(edges[i + 1]):.2f} | "
                    + " | ".join(cells) + " |")
    return rows


def _share_of(r, names: tuple[str, ...]) -> float:
    return float(r.share[r.index(names)])


def _findings(a: dict[str, Any]) -> list[str]:
    """The answers to the paper's two questions (Section 6.3.2), in words from the
    numbers."""
    lines = ["**Is h/t a suitable criterion on flexible diaphragms?**", ""]
    verdicts = {k: within(r, r.index(("slenderness",))) for k, r in a["ranks"].items()}
    picks = sorted({_label(a["rec"][k]["recommended"]["names"]) for k in a["ranks"]})
    lines += [f"In short: h/t is within the uncertainty of the best criterion in "
              f"{sum(verdicts.values())} of the {len(verdicts)} rankings (single and higher "
              f"storey, capacity in PGA and in sa_avg); "
              + ("it is **not adequate** on flexible diaphragms, and what replaces it is "
                 if not any(verdicts.values()) else "where it falls short, the criterion is ")
              + " or ".join(f"**{p}**" for p in picks) + " (below, by storey and measure).",
              ""]
    for storey in pa.STOREYS:
        for im in pa.MEASURES:
            rec, r = a["rec"][storey, im], a["ranks"][storey, im]
            ht, best, pick = rec["slenderness"], rec["best"], rec["recommended"]
            ok = within(r, r.index(("slenderness",)))
            lines.append(
                f"- {storey.capitalize()} storey, capacity in {im}: h/t explains "
                f"{ht['share']:.0%} [{ht['interval'][0]:.0%}, {ht['interval'][1]:.0%}] of the "
                f"variance of the log median capacity (rank {rec['rank_slenderness']} of "
                f"{len(r.sets)}), with residual dispersion {ht['dispersion']:.2f}; the best set "
                f"({_label(best['names'])}) explains {best['share']:.0%}. h/t is "
                f"**{'adequate' if ok else 'not adequate'}** (its share "
                f"{'is' if ok else 'is not'} within the bootstrap uncertainty of the best); "
                f"the recommended criterion is **{_label(pick['names'])}** "
                f"({pick['share']:.0%}, dispersion {pick['dispersion']:.2f}); the best single "
                f"predictor is {_label(rec['best_single']['names'])} "
                f"({rec['best_single']['share']:.0%}, dispersion "
                f"{rec['best_single']['dispersion']:.2f}).")
    rig = a["rigid"]
    if rig is not None:
        k = rig.index(("slenderness",))
        lines += ["", f"- Reference, rigid diaphragms ({rig.n} walls, both storeys): h/t "
                  f"explains {rig.share[k]:.0%} [{rig.lower[k]:.0%}, {rig.upper[k]:.0%}] (rank "
                  f"{k + 1}; the best single predictor {_label(rig.sets[0])} "
                  f"{rig.share[0]:.0%}): h/t is "
                  f"{'within' if within(rig, k) else 'outside'} the uncertainty of the best "
                  "there."]
    lines += ["",
              "- The control q (diaphragm seismic weight, which the dynamics cannot see once "
              "O/W and f_d are drawn) ranks "
              + ", ".join(f"{a['ranks'][s, m].rank(('diaphragm_weight',))} of "
                          f"{len(a['ranks'][s, m].sets)} ({s}, {m})"
                          for s in pa.STOREYS for m in pa.MEASURES)
              + " among the sets (alone: share "
              + ", ".join(f"{_share_of(a['ranks'][s, 'pga'], ('diaphragm_weight',)):+.2f}"
                          for s in pa.STOREYS) + " in PGA).", ""]
    lines += ["**A procedure that includes the resonance effects**", ""]
    for storey in pa.STOREYS:
        r = a["resonance"][storey]
        lines.append(
            f"- {storey.capitalize()} storey: with the record's dominant frequency within a "
            f"factor {pa.BAND:.3f} of the diaphragm's, the capacity is {r['factor']:.2f} "
            f"[{r['factor_interval'][0]:.2f}, {r['factor_interval'][1]:.2f}] of the wall's "
            f"median ({r['factor_adjusted']:.2f} [{r['factor_adjusted_interval'][0]:.2f}, "
            f"{r['factor_adjusted_interval'][1]:.2f}] with each record's own severity per "
            f"unit PGA taken out). Against S = Sa(T_d)/PGA the capacity goes as "
            f"(S / {math.exp(r['s_mean']):.2f})^{r['slope']:.2f} [{r['slope_interval'][0]:.2f}, "
            f"{r['slope_interval'][1]:.2f}], which takes the record-to-record spread of ln C "
            f"from {r['spread']:.3f} to {r['spread_rule']:.3f}.")
    return lines


def _rule_lines(a: dict[str, Any]) -> list[str]:
    lines = ["The rule (`urmx.assess.urmx_rule`): median collapse PGA of the wall from the "
             "recommended criterion (PGA rows above), times the resonance factor "
             "`(S / S_ref)^b`, S = Sa(T_d) / PGA of the demand's 5 %-damped spectrum at the "
             "diaphragm's period T_d = 1 / f_d (a rigid top: factor 1):", ""]
    for storey in pa.STOREYS:
        r = a["resonance"][storey]
        lines.append(f"- {storey} storey: factor = (S / {math.exp(r['s_mean']):.2f})^"
                     f"{r['slope']:.3f}; equivalently assess against a demand PGA x "
                     f"(S / {math.exp(r['s_mean']):.2f})^{-r['slope']:.3f}.")
    lines += ["", "By hand: read Sa at the diaphragm's period and the PGA off the spectrum, form "
              "S, and multiply the wall's median capacity by the factor (or divide the demand "
              "PGA by it). The coarser statement of the same effect: where the record's "
              "dominant frequency lies within a factor 1.41 of the diaphragm's, reduce the "
              "capacity by the band factor with the record's own severity taken out (the "
              "table's fifth column); the raw band factor stays near 1 because records whose "
              "dominant frequency is high are also the ones that need a large PGA to collapse "
              "any wall (the binned table: ln C / median rises with f_rec / f_d), which hides "
              "the dip at resonance unless each record's own level is taken out."]
    return lines


def write(archive: str | Path, out: str | Path = "reports/predictors",
          replicates: int = 200, run_seconds: float | None = None) -> Path:
    """Analyse `archive` and write ``REPORT.md``, its figures and ``numbers.json`` into
    `out`; returns the report's path."""
    import xarray as xr

    archive, out = Path(archive), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    with xr.open_dataset(archive) as ds:
        ds.load()
        a = analyse(ds, replicates)
        run = run_seconds if run_seconds is not None else _run_seconds(ds, archive)
        head = _header(ds, a, run)
    figs = [f(a, out) for f in (_fig_correlation, _fig_capacity, _fig_ranking, _fig_resonance)]
    (out / "numbers.json").write_text(json.dumps(numbers(a), indent=1) + "\n")
    body = _body(a, figs, replicates, time.perf_counter() - t0)
    path = out / "REPORT.md"
    path.write_text("\n".join(head + body) + "\n")
    return path


def _header(ds, a: dict[str, Any], run: float | None) -> list[str]:
    pop = a["pop"]
    analyses = int(np.nansum(ds["analyses"].values))
    cells = pop["n_walls"] * pop["n_records"]
    when = ds.attrs.get("history", "").split(" ")[0]
    rt = f"{run / 60:.1f} min wall time (from the archive's start to its last write)" \
        if run else "not known"
    return ["# Which wall parameter predicts collapse (issue 37)", "",
            "Regenerate: `urmx run wall-population --out results/wall-population.nc` then "
            "`python -m urmx.reports.predictors results/wall-population.nc --out "
            "reports/predictors`.", "",
            "| | |", "|---|---|",
            f"| study | `{ds.attrs.get('study_name')}` (catalog/studies/wall-population.toml) |",
            f"| walls | {pop['n_walls']} ({int((~pop['rigid']).sum())} on flexible diaphragms, "
            f"{int(pop['rigid'].sum())} rigid; {int((pop['storey'] == 'single').sum())} single, "
            f"{int((pop['storey'] == 'higher').sum())} higher storey) |",
            f"| records | {pop['n_records']} (FEMA P695 far-field set, unscaled) |",
            f"| collapse capacities | {cells} ({int(np.sum(pop['censored']))} censored at 5 g) |",
            f"| analyses | {analyses} ({analyses / cells:.1f} per capacity) |",
            f"| run time | {rt}; started {when}, on the shared 2-core machine |",
            f"| urmx / kernel | {ds.attrs.get('urmx_version')} (commit "
            f"`{str(ds.attrs.get('urmx_git_commit'))[:12]}`), kernel source hash "
            f"`{ds.attrs.get('kernel_source_hash')}` |", "", made_from(ds), ""]


def _body(a: dict[str, Any], figs: list[str], replicates: int, seconds: float) -> list[str]:
    lines = ["## Findings", "", *_findings(a), "", "## The design and its correlation check", "",
             "Latin hypercube (scipy.stats.qmc) over the inputs of the study file, walls above "
             "h/t = 35 left out; `urmx.uncertainty.sampler` builds each wall.", "",
             *_design_lines(a), "", f"![correlation]({figs[0]})", "",
             "## Ranking", "",
             f"Cross-validated share of the variance of ln(median collapse capacity), 5-fold "
             f"(walls never in both fit and score), linear in the logs of the predictors (a "
             f"power law); intervals: {replicates} bootstrap replicates over walls "
             "(`urmx.fragility.ranking`). Walls on flexible diaphragms only; the median is the "
             f"lognormal fit over the {a['pop']['n_records']} records (censored capacities as "
             "lower bounds). Each predictor alone and every pair; the top 15 in PGA, h/t and "
             "the control q shown.",
             ""]
    lines += ["### Each predictor alone", "", *_singles_table(a), ""]
    for storey in pa.STOREYS:
        lines += [f"### {storey.capitalize()} storey", "", *_ranking_table(a, storey), ""]
    lines += [f"![ranking]({figs[2]})", "", "## Recommended criterion", "",
              "The smallest set whose paired bootstrap difference from the best's share "
              "reaches 0 at 95 %; its power law fitted on all walls of the population, the "
              "residual dispersion the log standard deviation about it.", "",
              *_criterion_rows(a), "",
              "Each relation takes its predictors in SI units (a_rock in m s-2, T_eff in s, "
              "f_d in Hz, lengths in m) and gives the median capacity in g. By hand, for a "
              "single-storey wall in PGA: compute a_rock = (M0_2 + (a1/a2) M0_1) / (m a1 / 2) "
              "from Table I and T_eff (`urmx.fragility.rocking_period`), then C_50 from the "
              "first row.", "", f"![capacity]({figs[1]})", "",
              "## Resonance", "",
              "Each (wall, record) capacity over the wall's median, ln(C / median), against "
              "the record's dominant frequency (Konno-Ohmachi smoothed Fourier peak) over the "
              "diaphragm's, and against S = Sa(T_d)/PGA; intervals from a bootstrap over walls "
              "and records together. Uncensored capacities of walls on flexible diaphragms.",
              "", *_resonance_lines(a), "", *_rule_lines(a), "", f"![resonance]({figs[3]})", "",
              "## Predictors", "",
              "Formulas and sources: `urmx.fragility.predictors` (module docstring). "
              "Per-record measures (pga, pgv, sa_avg, Sa(T_d)) are in the archive as "
              "`measure_*`.", "", f"Report computed in {seconds:.0f} s."]
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m urmx.reports.predictors",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("archive", help="a wall-population archive (urmx run wall-population)")
    parser.add_argument("--out", default="reports/predictors", help="folder of the report")
    parser.add_argument("--replicates", type=int, default=200, help="bootstrap replicates")
    parser.add_argument("--run-seconds", type=float, default=None,
                        help="the study's run time, when the archive's times do not give it")
    args = parser.parse_args(argv)

    if not Path(args.archive).is_file():
        raise SystemExit(f"urmx: no archive {args.archive} (run: urmx run wall-population "
                         f"--out {args.archive})")
    try:
        print(write(args.archive, args.out, args.replicates, args.run_seconds))
    except (InputError, KeyError) as exc:
        raise SystemExit(f"urmx: {args.archive} is not a wall-population archive ({exc})") \
            from None
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
