"""``reports/assessment/``: the assessment procedures (`urmx.assess`) against urmx's IDA.

`write_report` runs `urmx.analysis.assessment.compare` on an IDA archive and writes
``REPORT.md`` with: the procedures and what of each could be applied; per procedure and
diaphragm (single storey and higher storey apart) the share of (wall, record) pairs where
the procedure is unconservative (it accepts a record scale at which the wall collapses) and
conservative, and the median and dispersion of ``ratio`` (its capacity scale over the
IDA's); one figure per applicable procedure of its median capacity scale against urmx's, per
wall and diaphragm; and findings written from those numbers (which procedure is
unconservative for which diaphragms, by how much, and whether diaphragm flexibility is what
makes it so: D1-D2 against D4-D5).
``comparison.csv`` holds the table's numbers.
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import numpy as np
import xarray as xr

from ..analysis.assessment import compare
from ..assess import PROCEDURES
from ..jitcache import SOURCE_HASH
from ..markdown import number, table
from ..provenance import code_version, describe, identity
from .common import save_figure

SOFT, STIFF = ("D1", "D2"), ("D4", "D5")  # flexible and stiff diaphragms of the findings


def group_of(label: str) -> str:
    """``"single storey"`` for ``"D1"``, ``"higher storey"`` for ``"D1/both"``."""
    return "higher storey" if label.endswith("/both") else "single storey"


def summary(c: xr.Dataset) -> list[dict]:
    """One row per (procedure, diaphragm): pairs, shares unconservative / conservative /
    unknown, median ratio and its dispersion (standard deviation of ln ratio over the pairs
    where the ratio is finite and positive)."""
    rows = []
    for p in c.procedure.values:
        for d in c.diaphragm.values:
            r = c.ratio.sel(procedure=p, diaphragm=d).values.ravel()
            u = c.unconservative.sel(procedure=p, diaphragm=d).values.ravel()
            ida = c.ida_capacity_scale.sel(diaphragm=d).values.ravel()
            n = int(np.sum(~np.isnan(ida)))
            known = ~np.isnan(u)
            finite = r[np.isfinite(r) & (r > 0)]
            applied = int(np.sum(~np.isnan(r)))
            rows.append({
                "procedure": str(p), "diaphragm": str(d), "group": group_of(str(d)),
                "pairs": n, "applicable": applied,
                "unconservative": float(np.sum(u[known] == 1) / n) if applied else math.nan,
                "conservative": float(np.sum(u[known] == 0) / n) if applied else math.nan,
                "accepted_always": float(np.sum(np.isinf(r)) / n) if applied else math.nan,
                "median_ratio_unconservative": float(np.median(r[u == 1]))
                if np.any(u == 1) else math.nan,
                "median_ratio": float(np.median(r[~np.isnan(r)])) if known.any() else math.nan,
                "dispersion": float(np.std(np.log(finite))) if finite.size > 1 else math.nan,
            })
    return rows


def _table_lines(rows: list[dict], procedure: str) -> list[str]:
    body = [[r["group"], r["diaphragm"].replace("/both", ""), r["pairs"], r["applicable"],
             _pct(r["unconservative"]), _pct(r["conservative"]), number(r["median_ratio"]),
             number(r["dispersion"], 2)]
            for r in rows if r["procedure"] == procedure]
    return table(["storey", "diaphragm", "(wall, record) pairs", "applicable",
                  "unconservative", "conservative", "median ratio", "dispersion (ln)"], body)


def _pct(x: float) -> str:
    return "-" if math.isnan(x) else f"{100 * x:.0f} %"


def _figure(c: xr.Dataset, procedure: str, out: Path) -> str:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 4.2))
    axes = fig.subplots(1, 2, sharex=True, sharey=True)
    cap = c.capacity_scale.sel(procedure=procedure).median("record")
    ida = c.ida_capacity_scale.median("record")
    values = np.concatenate([cap.values.ravel(), ida.values.ravel()])
    values = values[np.isfinite(values) & (values > 0)]
    lo, hi = float(values.min()) / 1.5, float(values.max()) * 1.5
    import matplotlib.ticker as mticker

    for ax, group in zip(axes, ("single storey", "higher storey"), strict=True):
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_formatter(mticker.FuncFormatter(lambda v, _: f"{v:g}"))
            axis.set_minor_formatter(mticker.NullFormatter())
        for d in c.diaphragm.values:
            if group_of(str(d)) != group:
                continue
            ax.loglog(ida.sel(diaphragm=d), np.clip(cap.sel(diaphragm=d).values, lo, hi), "o",
                      ms=4, label=str(d).replace("/both", ""))
        ax.plot([lo, hi], [lo, hi], "k-", lw=0.8, label="1:1")
        ax.set_xlim(lo, hi)
        ax.set_ylim(lo, hi)
        ax.set_title(group)
        ax.set_xlabel("urmx IDA median collapse scale [1]")
        ax.legend(fontsize=7, loc="upper left")
    axes[0].set_ylabel(f"{procedure} median capacity scale [1]")
    fig.suptitle(f"{procedure}: median capacity against urmx's, per wall and diaphragm "
                 "(above the line: unconservative; inf and 0 drawn at the edges)", fontsize=9)
    fig.tight_layout()
    return save_figure(axes, out, f"{procedure}.png", dpi=90, palette=True)


def _mean_share(rows: list[dict], procedure: str, labels, key: str) -> float:
    vals = [r[key] for r in rows if r["procedure"] == procedure and r["diaphragm"] in labels]
    vals = [v for v in vals if not math.isnan(v)]
    return float(np.mean(vals)) if vals else math.nan


def findings(c: xr.Dataset, rows: list[dict]) -> list[str]:
    """Sentences written from the numbers of `summary` (module docstring)."""
    out = []
    for p in map(str, c.procedure.values):
        mine = [r for r in rows if r["procedure"] == p]
        if not any(r["applicable"] for r in mine):
            reason = c.reason.sel(procedure=p).item()
            out.append(f"- **{p}** is not applicable to any pair: {reason}")
            continue
        worst = max(mine, key=lambda r: (r["unconservative"], r["median_ratio"]))
        total = float(np.nansum([r["unconservative"] * r["pairs"] for r in mine])
                      / sum(r["pairs"] for r in mine))
        if total == 0:
            line = (f"- **{p}** is never unconservative: it fails every wall at a lower "
                    "record scale than the one that collapses it.")
        else:
            line = (f"- **{p}** is unconservative for {100 * total:.1f} % of all (wall, "
                    f"diaphragm, record) cells, most often on {worst['diaphragm']} "
                    f"({_pct(worst['unconservative'])}")
            if np.isfinite(worst["median_ratio_unconservative"]):
                line += (f"; there its capacity scale is "
                         f"{number(worst['median_ratio_unconservative'])} times the IDA's, "
                         "median over the unconservative cells")
            line += ")."
        always = _mean_share(rows, p, [r["diaphragm"] for r in mine], "accepted_always")
        if always > 0:
            line += (f" It accepts {_pct(always)} of the cells at every intensity (capacity "
                     "scale inf: a check that does not depend on the intensity).")
        for group, suffix in (("single storey", ""), ("higher storey", "/both")):
            line += _flexibility(c, rows, p, group, suffix)
        out.append(line)
    return out


def _flexibility(c: xr.Dataset, rows: list[dict], p: str, group: str, suffix: str) -> str:
    """The D1-D2 against D4-D5 sentence of one group (the procedure's capacity is the same
    on every diaphragm, so the difference is the IDA's)."""
    soft = [s + suffix for s in SOFT]
    stiff = [s + suffix for s in STIFF if s + suffix in c.diaphragm.values]
    a = _mean_share(rows, p, soft, "median_ratio")
    b = _mean_share(rows, p, stiff, "median_ratio")
    ua = _mean_share(rows, p, soft, "unconservative")
    ub = _mean_share(rows, p, stiff, "unconservative")
    text = (f" {group.capitalize()}: median ratio {number(a)} on {'-'.join(soft)} against "
            f"{number(b)} on {'-'.join(stiff)}, unconservative {_pct(ua)} against {_pct(ub)}")
    if np.isfinite(a) and np.isfinite(b) and a > 0 and b > 0:
        word = "less" if a > b else "more"
        text += (f": the procedure is {word} conservative on the flexible diaphragms "
                 f"(ratio x{a / b:.2f})")
        own = _own_change(c, p, soft, stiff)
        if own is None:
            text += (", and since its capacity is the same on every diaphragm, diaphragm "
                     "flexibility (through the dynamics) is what moves it")
        else:
            text += (f"; its own capacity changes with the diaphragm too (median capacity "
                     f"scale on {'-'.join(soft)} x{own:.2f} that on {'-'.join(stiff)}), so "
                     "the procedure and the dynamics move it together")
    return text + "."


def _own_change(c: xr.Dataset, p: str, soft: list[str], stiff: list[str]) -> float | None:
    """None when procedure `p`'s capacity scale is the same on every diaphragm of the two
    groups (to 1e-9 relative, wherever finite); else the ratio of its median capacity scale
    on the `soft` diaphragms to that on the `stiff` ones."""
    cap = c.capacity_scale.sel(procedure=p)
    arr = cap.sel(diaphragm=[*soft, *stiff]).transpose("diaphragm", ...).values
    arr = arr.reshape(arr.shape[0], -1)
    fin = np.isfinite(arr).all(axis=0) & (np.abs(arr).max(axis=0) > 0)
    if not fin.any() or np.all(np.ptp(arr[:, fin], axis=0)
                               <= 1e-9 * np.abs(arr[:, fin]).max(axis=0)):
        return None
    lo = np.nanmedian(cap.sel(diaphragm=soft).values)
    hi = np.nanmedian(cap.sel(diaphragm=stiff).values)
    return float(lo / hi) if np.isfinite(lo) and np.isfinite(hi) and hi > 0 else None


def _procedure_lines(c: xr.Dataset) -> list[str]:
    lines = []
    for p in map(str, c.procedure.values):
        fn = PROCEDURES.get(p)
        src = getattr(sys.modules.get(fn.__module__), "SOURCE", "") if fn else ""
        reason = str(c.reason.sel(procedure=p).item())
        status = f"not applicable: {reason}" if reason and not np.isfinite(
            c.capacity_scale.sel(procedure=p).values).any() else "applied"
        lines.append(f"- `{p}` ({src}): {status}")
    return lines


def write_report(archive, out_dir: str | os.PathLike = "reports/assessment",
                 records_dir=None, **compare_options) -> Path:
    """Compare the procedures with the IDA archive and write ``out_dir/REPORT.md``, its
    figures and ``comparison.csv`` (module docstring); `compare_options` go to
    `urmx.analysis.assessment.compare` (``walls=``, ``records=``). Returns the report's path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    c = compare(archive, records_dir=records_dir, **compare_options)
    rows = summary(c)
    _write_csv(rows, out / "comparison.csv")
    lines = _header(c, archive)
    lines += ["", "## Procedures", "", *_procedure_lines(c), "", "## Findings", "",
              *findings(c, rows), "", _reading(), ""]
    for p in map(str, c.procedure.values):
        lines += [f"## {p}", ""]
        lines += _table_lines(rows, p)
        if not np.isnan(c.capacity_scale.sel(procedure=p).values).all():
            lines += ["", _figure(c, p, out)]
        lines.append("")
    path = out / "REPORT.md"
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def _header(c: xr.Dataset, archive) -> list[str]:
    a = c.attrs
    name = archive if not isinstance(archive, xr.Dataset) else "(Dataset)"
    dirty = " (with uncommitted changes)" if str(a.get("archive_urmx_git_dirty")) in (
        "1", "True") else ""
    return [
        "# Assessment procedures against the dynamics",
        "",
        f"Regenerate: `urmx assess-report {name} --out reports/assessment` (after "
        f"`urmx run fema-p695-ida --out {name}`).",
        "",
        f"- Archive: `{name}`, study `{a.get('archive_study_name', '?')}`, made by urmx "
        f"commit `{a.get('archive_urmx_git_commit', '?')}`{dirty}, kernel source hash "
        f"`{a.get('archive_kernel_source_hash', '?')}`; COR {a.get('cor')}. "
        + _kernel_now(str(a.get("archive_kernel_source_hash", ""))),
        f"- Report written by urmx {code_version()} ({describe(identity())}).",
        f"- {c.sizes['wall']} walls x {c.sizes['diaphragm']} diaphragms x "
        f"{c.sizes['record']} records; the capacity scale of a procedure is the record scale "
        "factor at which its check is at its limit, urmx's is the IDA's collapse scale.",
    ]


def _reading() -> str:
    return ("How to read: `ratio` = procedure capacity scale / IDA collapse scale. Below 1 "
            "the procedure fails the wall at a lower intensity than the one that collapses "
            "it (conservative); above 1 it accepts intensities at which the wall collapses "
            "(unconservative). Every code procedure here uses the rigid-support mechanism "
            "(none has a flexible-diaphragm provision that could be read), so its capacity "
            "is the same on D1-D5: a change of its ratio across diaphragms is the dynamics'. "
            "`urmx_rule` is urmx's own rule from the wall-population study: it depends on "
            "the diaphragm's frequency by design, and it predicts the *median* collapse "
            "capacity with no safety margin, so it is expected to be unconservative for "
            "about half of the cells; its ratio measures its accuracy, not its safety. The "
            "archive has no pinned top; D5 (1e9 N/m) is the catalog's stand-in for it.")


def _write_csv(rows: list[dict], path: Path) -> None:
    keys = list(rows[0])
    text = [",".join(keys)] + [",".join(str(r[k]) for k in keys) for r in rows]
    path.write_text("\n".join(text) + "\n", encoding="utf-8")


def _kernel_now(kernel: str) -> str:
    """Whether the archive's kernel is the one running now (issue 38, item 5)."""
    if kernel[:16] == SOURCE_HASH[:16]:
        return "The current kernel is the same."
    return (f"**The current kernel differs** (`{SOURCE_HASH[:16]}`): run the IDA again for "
            "numbers of the current kernel.")
