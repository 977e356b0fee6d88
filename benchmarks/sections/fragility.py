"""Collapse fragility (IDA): collapse capacities of the ``fema-p695-ida`` study.

Measures what the fragility workflow promises:

- analyses per collapse capacity at rtol 1e-3 (target: at most 15 on average);
- the whole ``fema-p695-ida`` study on 2 local dask worker processes after compilation
  (target: under 2 minutes), with the number of analyses: compute time on a started and
  warmed cluster, and end to end as ``urmx ida`` runs it (cluster start included); and the
  same study in one process, for the speed-up;
- how the capacities compare with a brute-force scan on a 1 % grid of scale factors for
  sampled (wall, diaphragm) pairs over all 40 records: the share of cells where the scan
  finds a collapse below the capacity (a collapse window the search stepped over), how far
  below, and what that does to the fitted median and dispersion; for the cold search
  (``collapse_capacity`` with no hint, the search before issue 41) and for the study's
  warm-started chain (each pair's wall computed as the study computes it, after the walls
  before it on its diaphragm), with each one's analyses per capacity on those cells;
- `urmx ida` of the study on 2 local worker processes, end to end in fresh processes,
  against the code of `BASELINE_COMMIT` exported beside this tree, alternating (issue 41:
  the ratio and each side's analyses per capacity in one run).

Not part of ``all`` (it runs the study three times and the scan: about 5 minutes on 2
cores, and the end-to-end runs of both trees); ask for it by name: ``urmx bench
fragility`` (``--quick``: a 36-cell study, 2 x 4 scanned cells and a 72-cell end-to-end
study, to check the machinery). The numbers depend on the machine and on its
load (the 2 cores may be shared): the section carries the load average seen before and
after each timing.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from urmx.markdown import table

from ..common import export_commit, verdict

IN_ALL = False
TARGET_ANALYSES = 15.0  # mean analyses per collapse capacity at rtol 1e-3
TARGET_STUDY = 120.0  # whole fema-p695-ida study on 2 cores after compilation [s]
STUDY = "fema-p695-ida"
TARGET_NEW_ANALYSES = 10.0  # the warm-started chain's mean analyses per capacity (issue 41)
TARGET_SPEEDUP = 2.0  # fema-p695-ida end to end on 2 workers against BASELINE_COMMIT
BASELINE_COMMIT = "834f656"  # main before issue 41
SCAN_STEP = 1.01  # brute-force grid ratio
SCAN_FROM = 0.25  # brute-force scan from this fraction of the wall's static acceleration
PLAIN_STEP = 1.5  # the plain geometric hunt the search is compared with
SCAN_PAIRS = (("s08", "D1"), ("s16", "D2"), ("s24", "D4"), ("s12", "D5"),
              ("s20", "D1/both"), ("s14", "D3/both"))


def _load() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


def _ida_study(path: Path, name: str, walls: str, diaphragms: str, extra: str = "") -> Path:
    """Write a small IDA study over four FEMA P695 records at the catalog study's search
    settings (walls and diaphragms as TOML values, `extra` more [study] lines)."""
    path.write_text(f"""
[study]
name = "{name}"
walls = {walls}
diaphragms = {diaphragms}
{extra}records = ["p695-01-mul009", "p695-09-dzc270", "p695-12-clwln", "p695-18-rio270"]
cor = [0.8]
[study.ida]
im = "pga"
rtol = 1e-3
step = 1.05
""")
    return path


def _small_study(tmp: Path) -> Path:
    return _ida_study(tmp / "quick-ida.toml", "quick-ida", '["s08", "s16", "s24"]',
                      '["D1", "D5", "D2/both"]')


def _cluster(n: int):
    """A local cluster of `n` worker processes with every compiled function of an IDA batch
    loaded on each worker (`urmx.fragility.warm_up`: a package function, since the workers
    cannot import this checkout's benchmarks)."""
    from urmx.fragility import warm_up
    from urmx.study import local_client

    warm_up()  # compiled or loaded from numba's cache here, before the workers start
    client = local_client(n)
    client.run(warm_up)  # every worker loads the compiled code before the clock starts
    return client


def time_study(study, records_dir=None) -> dict:
    """The study on a warmed 2-worker cluster, end to end as ``urmx ida`` runs it, and in
    one process: seconds, analyses, load averages."""
    from urmx.study import close_client, run_study

    out: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        client = _cluster(2)
        try:
            load0 = _load()
            t = time.perf_counter()
            ds = run_study(study, out=Path(tmp) / "a.nc", scheduler=client, progress=False,
                           records_dir=records_dir)
            ds = ds.load()  # (the archive is opened lazily, and removed with `tmp`)
            out["cluster_seconds"] = time.perf_counter() - t
            out["cluster_load"] = [load0, _load()]
        finally:
            close_client(client)
        load0 = _load()
        t = time.perf_counter()
        run_study(study, out=Path(tmp) / "b.nc", scheduler=None, progress=False,
                  records_dir=records_dir)
        out["end_to_end_seconds"] = time.perf_counter() - t
        out["end_to_end_load"] = [load0, _load()]
        load0 = _load()
        t = time.perf_counter()
        run_study(study, out=Path(tmp) / "c.nc", scheduler="serial", progress=False,
                  records_dir=records_dir)
        out["serial_seconds"] = time.perf_counter() - t
        out["serial_load"] = [load0, _load()]
    n = ds.analyses.where(ds.analyses >= 0)
    out.update({
        "study": ds.attrs["study_name"], "cells": int(n.count()),
        "analyses": int(n.sum()), "analyses_per_capacity": float(n.mean()),
        "analyses_median": float(n.median()), "analyses_max": int(n.max()),
        "analyses_histogram": {str(int(k)): int((n == k).sum())
                               for k in np.unique(n.values[np.isfinite(n.values)])},
        "censored": int(ds.censored.sum()), "event_limits": int(ds.event_limits.sum()),
        "rtol": ds.attrs["ida_rtol"], "step": ds.attrs["ida_step"],
        "im": ds.attrs["intensity_measure"],
    })
    out["analyses_per_second_cluster"] = out["analyses"] / out["cluster_seconds"]
    return out


def _chain_capacities(study, wid: str, did: str, rec) -> tuple[float, int]:
    """The capacity of wall `wid` on diaphragm `did` under `rec` as the study computes it
    (the chain of warm starts over the walls before it, `urmx.study.kinds.ida.run_batch`)
    and its number of analyses."""
    from urmx.study.kinds import ida

    d = next(x for x in study.diaphragms if x.id == did)
    iw = [w.id for w in study.walls].index(wid)
    task = dict(walls=[[study.wall(study.walls[i], d)] for i in range(iw + 1)], dt=rec.dt,
                scale_factor=1.0, record=f"bench-{rec.id}", cor=[0.8], impact=study.impact,
                ida=study.settings.to_dict(), kernel=None, t_rest=study.t_rest, hint=None)
    out = ida.run_batch(task, rec.acceleration)
    return float(out["capacity"][-1, 0, 0, 0]), int(out["analyses"][-1, 0, 0, 0])


def _scan_first(w, rec, lo: float, up_to: float) -> float:
    """The first collapse on the 1 % grid of intensities from `lo` below `up_to` (inf: none)."""
    from urmx.kernel import run

    pga = float(np.max(np.abs(rec.acceleration)))
    n = max(2, int(math.ceil(math.log(up_to / lo) / math.log(SCAN_STEP))))
    for x in lo * SCAN_STEP ** np.arange(n):
        if x >= up_to:
            break
        if run(w, rec.acceleration, rec.dt, scale=x / pga, cor=0.8)["status"] == "collapsed":
            return float(x)
    return math.inf


def _bias(caps: np.ndarray, first: np.ndarray, rtol: float) -> dict:
    """Cells whose scan finds a collapse below the capacity (below it by more than rtol)
    and the log-bias of the capacities against the scan's first collapse."""
    first = np.where(first < caps / (1 + rtol), first, caps)
    over = caps / first
    missed = over > 1 + 1e-9
    return {"missed": int(missed.sum()), "missed_share": float(missed.mean()),
            "overshoot_median": float(np.median(over[missed])) if missed.any() else 1.0,
            "overshoot_p90": float(np.quantile(over[missed], 0.9)) if missed.any() else 1.0,
            "overshoot_max": float(over.max()),
            "mean_log_bias": float(np.mean(np.log(over)))}


def brute_force(study, pairs, records: list[str] | None = None) -> dict:
    """Capacities of the search against a 1 % scan from a quarter of the wall's static
    acceleration up to the capacity, for every record of the given (wall, diaphragm) pairs:
    today's cold search (``old``, `urmx.fragility.collapse_capacity` without a hint) and
    the study's warm-started chain (``new``); and the lognormal fits."""
    from urmx import fragility as F

    # each record as analysed (times its manifest scale factor), as one Record
    recs = {r: F.Record(r, rec.scaled(), rec.dt) for r, rec in
            ((r, F.as_record(r)) for r in (records or study.records))}
    walls = {w.id: w for w in study.walls}
    dias = {d.id: d for d in study.diaphragms}
    ida, rtol = study.settings, study.settings.rtol
    cells, fits = [], []
    t0 = time.perf_counter()
    for wid, did in pairs:
        w = study.wall(walls[wid], dias[did])
        for rid, rec in recs.items():
            res = F.collapse_capacity(w, rec, im=ida.im, rtol=rtol, step=ida.step,
                                      max_intensity=ida.max_intensity)
            new, n_new = _chain_capacities(study, wid, did, rec)
            first = _scan_first(w, rec, SCAN_FROM * F.static_acceleration(w),
                                max(res.capacity, new) / (1 + rtol))
            plain, n_plain = _plain(w, rec, res.record_intensity, ida)
            cells.append({"wall": wid, "diaphragm": did, "record": rid,
                          "capacity": res.capacity, "new_capacity": new,
                          "scan_first": first, "censored": res.censored,
                          "analyses": res.analyses, "new_analyses": n_new,
                          "plain_capacity": plain, "plain_analyses": n_plain})
        mine = [c for c in cells if (c["wall"], c["diaphragm"]) == (wid, did)]
        a, c = (F.fit_lognormal([x[k] for x in mine]) for k in ("capacity", "new_capacity"))
        b = F.fit_lognormal([min(x["scan_first"], x["capacity"], x["new_capacity"])
                             for x in mine])
        fits.append({"wall": wid, "diaphragm": did, "median_search": a.median,
                     "median_new": c.median, "median_scan": b.median,
                     "dispersion_search": a.dispersion, "dispersion_new": c.dispersion,
                     "dispersion_scan": b.dispersion})
    col = {k: np.array([c[k] for c in cells], dtype=float) for k in cells[0]
           if k not in ("wall", "diaphragm", "record")}
    # the plain hunt's capacity may lie above the scanned range: its first collapse is the
    # scan's, or the lowest capacity where the scan found none below it
    first = np.minimum.reduce([col["scan_first"], col["capacity"], col["new_capacity"]])
    plain_over = col["plain_capacity"] / np.minimum(first, col["plain_capacity"])
    plain_missed = plain_over > 1 + 2 * rtol  # the same transition within rtol
    return {
        "plain": {"step": PLAIN_STEP,
                  "analyses_per_capacity": float(col["plain_analyses"].mean()),
                  "missed": int(plain_missed.sum()),
                  "missed_share": float(plain_missed.mean()),
                  "mean_log_bias": float(np.mean(np.log(plain_over)))},
        "cells": len(cells), "seconds": time.perf_counter() - t0,
        "scan_step": SCAN_STEP, "scan_from": SCAN_FROM,
        **_bias(col["capacity"], col["scan_first"], rtol),
        "analyses_per_capacity": float(col["analyses"].mean()),
        "new": {**_bias(col["new_capacity"], col["scan_first"], rtol),
                "analyses_per_capacity": float(col["new_analyses"].mean()),
                "same_capacity": float(np.mean(np.abs(np.log(
                    col["new_capacity"] / col["capacity"])) <= math.log1p(rtol)))},
        "fits": fits, "cell_list": cells,
    }


def _plain(w, rec, unit: float, ida) -> tuple[float, int]:
    """The capacity by a plain geometric hunt (every stride one step of `PLAIN_STEP`) and
    bisection, for comparison; and its number of analyses."""
    from urmx import fragility as F
    from urmx.kernel import run as kernel

    n = [0]

    def analyse(s):
        n[0] += 1
        r = kernel(w, rec.acceleration, rec.dt, scale=s, cor=0.8)
        return r["status"] == "collapsed", r["instability_ratio"]

    pga = float(np.max(np.abs(rec.acceleration)))
    s, _ = F.search(analyse, F.START_FRACTION * F.static_acceleration(w) / pga,
                    ida.max_intensity / unit, PLAIN_STEP, ida.rtol, max_stride=PLAIN_STEP)
    return s * unit, n[0]


_IDA = r"""
import sys, time, json
sys.path.insert(0, sys.argv[1])
from urmx.cli import main
t = time.perf_counter()
code = main(["ida", *sys.argv[2:]])
print(json.dumps({"seconds": time.perf_counter() - t, "code": code}))
"""


def _quick_ida(tmp: Path) -> Path:
    """The end-to-end study of ``--quick``: the 9 walls on 2 diaphragms over 4 records."""
    return _ida_study(tmp / "quick-e2e.toml", "quick-e2e", '"parametric"',
                      '["D2", "D3/both"]', 'supports = "top"\n')


def end_to_end(quick: bool, echo=print) -> dict:
    """`urmx ida` of the study on a local cluster of 2 worker processes, as a user runs it
    (a fresh process: cluster start, warm-up, every cell, the archive), this tree against
    `BASELINE_COMMIT` exported beside it, alternating (1 round quick, 2 full); each tree's
    numba cache filled by a first run not timed. Seconds per run, the ratio of the medians
    and each archive's analyses per capacity."""
    import subprocess
    import sys

    import xarray as xr

    from urmx.config import project_root

    tmp = Path(tempfile.mkdtemp(prefix="urmx-ida-e2e-"))
    trees = {"now": project_root(), "then": export_commit(BASELINE_COMMIT, tmp / "then")}
    study = str(_quick_ida(tmp)) if quick else STUDY
    out: dict = {"study": "quick-e2e" if quick else STUDY, "commit": BASELINE_COMMIT,
                 **{k: {"seconds": [], "analyses_per_capacity": None} for k in trees}}
    try:
        for i in range(1 + (1 if quick else 2)):  # the first round fills the caches
            for name, tree in trees.items():
                nc = tmp / f"{name}-{i}.nc"
                env = dict(os.environ, PYTHONPATH=str(tree))
                proc = subprocess.run(
                    [sys.executable, "-c", _IDA, str(tree), study, "--out", str(nc),
                     "--scheduler", "processes", "--quiet"], cwd=tree, env=env,
                    capture_output=True, text=True, timeout=7200)
                if proc.returncode:
                    raise RuntimeError(proc.stderr[-800:])
                sec = json.loads(proc.stdout.strip().splitlines()[-1])["seconds"]
                with xr.open_dataset(nc) as ds:
                    n = ds.analyses.where(ds.analyses >= 0)
                    out[name]["analyses_per_capacity"] = float(n.mean())
                    out[name]["analyses"] = int(n.sum())
                if i:
                    out[name]["seconds"].append(sec)
                echo(f"  end to end {name} (round {i}): {sec:.1f} s")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    med = {k: float(np.median(out[k]["seconds"])) for k in trees}
    out["speedup"] = med["then"] / med["now"]
    return out


def run(quick: bool, echo=print) -> dict:
    """Measure the section (``quick``: a 36-cell study and 2 x 4 brute-force cells, to check
    the machinery; not the acceptance numbers)."""
    from urmx.study.file import load_study

    full = load_study(STUDY)
    data = {"load_start": _load()}
    with tempfile.TemporaryDirectory() as tmp:
        study = load_study(_small_study(Path(tmp))) if quick else full
        echo(f"  {study.name}: warmed 2-worker cluster, end to end, serial")
        data["study"] = time_study(study)
    pairs = SCAN_PAIRS[:2] if quick else SCAN_PAIRS
    echo(f"  brute-force scan of {len(pairs)} wall-diaphragm pairs")
    data["brute_force"] = brute_force(full, pairs, full.records[:4] if quick else None)
    echo(f"  end to end against {BASELINE_COMMIT}")
    data["end_to_end"] = end_to_end(quick, echo)
    data["load_end"] = _load()
    return data


def targets(data: dict) -> list[list[str]]:
    """Rows (target, measured, verdict) of the report's targets table."""
    s = data["study"]
    per = s["analyses_per_capacity"]
    return [[f"analyses per collapse capacity <= {TARGET_ANALYSES:g} (mean, rtol "
             f"{s['rtol']:g})", f"{per:.2f}", verdict(per <= TARGET_ANALYSES)],
            [f"`{s['study']}` on 2 workers < {TARGET_STUDY:g} s after compilation",
             f"{s['cluster_seconds']:.1f} s ({s['analyses']} analyses)",
             verdict(s["cluster_seconds"] < TARGET_STUDY)],
            *_new_targets(data)]


def _new_targets(data: dict) -> list[list[str]]:
    """Issue 41's rows: the warm-started search's analyses and bias, the end-to-end ratio."""
    b, e = data["brute_force"], data.get("end_to_end")
    if "new" not in b:
        return []
    n, old = b["new"], b
    rows = [[f"warm-started search: analyses per capacity <= {TARGET_NEW_ANALYSES:g} "
             f"(`{data['study']['study']}`)", f"{data['study']['analyses_per_capacity']:.2f}",
             verdict(data["study"]["analyses_per_capacity"] <= TARGET_NEW_ANALYSES)],
            ["scan bias no worse than the cold search's (cells stepping over a window; "
             "mean log-bias)", f"{100 * n['missed_share']:.0f} % vs "
             f"{100 * old['missed_share']:.0f} %; {n['mean_log_bias']:+.4f} vs "
             f"{old['mean_log_bias']:+.4f}",
             verdict(n["missed_share"] <= old["missed_share"]
                     and n["mean_log_bias"] <= old["mean_log_bias"])]]
    if e:
        rows.append([f"`{e['study']}` end to end on 2 workers >= {TARGET_SPEEDUP:g}x "
                     f"{e['commit']}", f"{e['speedup']:.2f}x",
                     verdict(e["speedup"] >= TARGET_SPEEDUP)])
    return rows


def _new_lines(data: dict) -> list[str]:
    """The warm-started search beside the cold one (issue 41), and the end-to-end run."""
    b, e = data["brute_force"], data.get("end_to_end")
    if "new" not in b:
        return []
    n = b["new"]
    lines = [
        "Warm-started search (`urmx.fragility.capacity`, the study's chain: each wall "
        "starts 10 % below the capacity of the wall before it on the same diaphragm and "
        "record, scaled by their static accelerations, on a grid of 1.001**32) on the "
        "same cells, "
        "the capacity of each pair's wall as the study computes it (the chain over the "
        "walls before it):",
        "",
        *table(["search", "analyses per capacity (these cells)",
                "cells stepping over a window", "mean log-bias",
                "capacity over the scan's first collapse (median where missed; max)"],
               [["cold (today's)", f"{b['analyses_per_capacity']:.2f}",
                 f"{b['missed']} ({100 * b['missed_share']:.1f} %)",
                 f"{b['mean_log_bias']:+.4f}",
                 f"{b['overshoot_median']:.3f}; {b['overshoot_max']:.3f}"],
                ["warm-started chain", f"{n['analyses_per_capacity']:.2f}",
                 f"{n['missed']} ({100 * n['missed_share']:.1f} %)",
                 f"{n['mean_log_bias']:+.4f}",
                 f"{n['overshoot_median']:.3f}; {n['overshoot_max']:.3f}"]]),
        "",
        f"Same capacity within rtol in {100 * n['same_capacity']:.0f} % of the cells.",
        ""]
    if e:
        t, w = e["then"], e["now"]
        lines += [
            f"`urmx ida {e['study']} --scheduler processes` (2 local worker processes, a "
            f"fresh process each run, cluster start and archive included), this tree and "
            f"`{e['commit']}` alternating after a first round that fills the caches: "
            f"{', '.join(f'{x:.1f}' for x in w['seconds'])} s against "
            f"{', '.join(f'{x:.1f}' for x in t['seconds'])} s, **{e['speedup']:.2f}x**; "
            f"analyses per capacity {w['analyses_per_capacity']:.2f} against "
            f"{t['analyses_per_capacity']:.2f}.", ""]
    return lines


def _search_text(s: dict, warm: bool) -> str:
    """How the study's search runs: warm-started (issue 41) or, for a report measured
    before it, cold."""
    grid = (f"hunt up in strides (up to a factor 3) and then grid steps of {s['step']:g} "
            f"to the first collapse, bisect the last step to rtol {s['rtol']:g} (6 analyses "
            "for a step of 1.05")
    if not warm:
        return f"Analyses per capacity: start at half the wall's static acceleration, {grid})."
    return ("Analyses per capacity: the first wall of each chain starts at half the wall's "
            "static acceleration, the others 10 % below the capacity of the wall before "
            "them (warm start on a grid of 1.001**32, `urmx.fragility.capacity`); "
            f"{grid}, 5 for the warm grid, 1 when the wall collapses where the hint says).")


def render(data: dict) -> list[str]:
    """Markdown lines of the section, from the saved dict alone."""
    s, b = data["study"], data["brute_force"]
    per = s["analyses_per_capacity"]
    lines = [
        "## Collapse fragility (IDA)",
        "",
        "`urmx bench fragility`; load average (1, 5, 15 min) "
        f"{data['load_start']} at the start, {data['load_end']} at the end.",
        "",
        f"Study `{s['study']}`: {s['cells']} collapse capacities (im {s['im']}, rtol "
        f"{s['rtol']:g}, hunt step {s['step']:g}), {s['analyses']} analyses, "
        f"{s['censored']} censored, {s['event_limits']} analyses stopped by the event bound.",
        "",
        *table(["measure", "value", "target"], [
            ["analyses per collapse capacity (mean; median; max)",
             f"{per:.2f}; {s['analyses_median']:g}; {s['analyses_max']}",
             f"<= {TARGET_ANALYSES:g}: {verdict(per <= TARGET_ANALYSES)}"],
            ["whole study, 2 worker processes, warmed cluster",
             f"{s['cluster_seconds']:.1f} s ({s['analyses_per_second_cluster']:.0f} "
             f"analyses/s); load {s['cluster_load'][0]} -> {s['cluster_load'][1]}",
             f"< {TARGET_STUDY:g} s: {verdict(s['cluster_seconds'] < TARGET_STUDY)}"],
            ["whole study as `urmx ida` runs it (local cluster started and warmed inside)",
             f"{s['end_to_end_seconds']:.1f} s; load {s['end_to_end_load'][0]} -> "
             f"{s['end_to_end_load'][1]}", ""],
            ["whole study in one process (serial)",
             f"{s['serial_seconds']:.1f} s ({s['serial_seconds'] / s['cluster_seconds']:.2f}x "
             f"the 2-worker time); load {s['serial_load'][0]} -> {s['serial_load'][1]}", ""]]),
        "",
        _search_text(s, "new" in b) + " Histogram (analyses: cells): "
        + ", ".join(f"{k}: {v}" for k, v in s["analyses_histogram"].items()) + ".",
        "",
        "### Capacities against a brute-force scan",
        "",
        f"{b['cells']} cells ({len(b['fits'])} wall-diaphragm pairs x their records), each "
        f"scanned on a {100 * (b['scan_step'] - 1):.0f} % grid of scale factors from "
        f"{b['scan_from']:g} of the wall's static acceleration up to the capacity "
        f"({b['seconds']:.0f} s). Rocking walls resurrect: a record that collapses a wall "
        "may not collapse it when scaled slightly higher, and such collapse windows are "
        "often narrower than 1 %. The search (about 14 analyses) cannot see windows "
        "narrower than its strides; the scan finds a collapse below the capacity in "
        f"**{b['missed']} of {b['cells']} cells ({100 * b['missed_share']:.0f} %)**, "
        f"there the capacity is {b['overshoot_median']:.3f} times the scan's first collapse "
        f"(median; 90th percentile {b['overshoot_p90']:.3f}, max {b['overshoot_max']:.3f}); "
        f"over all cells the mean log-bias is {b['mean_log_bias']:.4f}. A plain geometric "
        f"hunt (steps of {b['plain']['step']:g}, no fine grid near collapse) on the same "
        f"cells takes {b['plain']['analyses_per_capacity']:.2f} analyses a capacity and "
        f"misses {b['plain']['missed']} ({100 * b['plain']['missed_share']:.0f} %), mean "
        f"log-bias {b['plain']['mean_log_bias']:.4f}.",
        "",
        *_new_lines(data),
        *table(["wall", "diaphragm", "median, search [m s-2]", "median, 1 % scan [m s-2]",
                "ratio", "dispersion, search", "dispersion, scan"],
               [[f["wall"], f["diaphragm"], f"{f['median_search']:.3f}",
                 f"{f['median_scan']:.3f}", f"{f['median_search'] / f['median_scan']:.3f}",
                 f"{f['dispersion_search']:.3f}", f"{f['dispersion_scan']:.3f}"]
                for f in b["fits"]]),
        "",
    ]
    return lines
