"""Work-precision: the error of the peak outputs against the converged reference versus
time per analysis, for the exact kernel and the reference over ``rtol`` 1e-3 .. 1e-11, per
wall and record (with one figure per case)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from pathlib import Path

from matplotlib.figure import Figure

from urmx.markdown import table

from ..common import (
    CONVERGED_RTOLS,
    PEAKS,
    SELF_CONVERGED,
    bench_walls,
    converged_reference,
    fmt,
    load_record,
    median_time,
    rel_error,
    save_figure,
)

# the reference's own step cap (its default, max_step = dt/8) and none (as MATLAB's ode45)
REFERENCE_SERIES = {"max_step dt/8 (default)": {}, "no step cap": {"max_step": math.inf}}
RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11)


def run(quick: bool, *, window: float | None = 20.0, figures: Path | None = None,
        echo: Callable[[str], None] | None = None) -> dict:
    """Error against time for the kernel and the reference at `RTOLS`, per wall and record.

    Records are scaled by their manifest scale factors and cut to their first `window`
    seconds (the reference integrates every record step separately and costs about 1 ms per
    step whatever its tolerance); one figure per case goes to `figures`."""
    from urmx import kernel, reference

    walls = bench_walls()
    records = ("elcentro", "nahanni", "christchurch")
    rtols = (1e-3, 1e-6, 1e-9) if quick else RTOLS
    if quick:
        walls = {k: walls[k] for k in ("wall12", "benchmark")}
        records = ("elcentro", "nahanni")
        window = min(window or 2.0, 2.0)
    cases = []
    for rid in records:
        ag, dt, sf = load_record(rid, window)
        for wid, wall in walls.items():
            kw = dict(scale=sf, cor=0.8)
            res = kernel.run(wall, ag, dt, **kw)
            t_k = median_time(lambda w=wall, a=ag, d=dt, k=kw: kernel.run(w, a, d, **k),
                              repeat=3, min_time=0.1 if quick else 1.0)
            conv = converged_reference(wall, ag, dt, **kw)
            series = {}
            for sname, extra in REFERENCE_SERIES.items():
                rows = series[sname] = []
                for rtol in rtols:
                    t = time.perf_counter()
                    try:
                        r = reference.run(wall, ag, dt, rtol=rtol, **extra, **kw)
                        err = rel_error(r, conv)
                        row = {"rtol": rtol, "seconds": time.perf_counter() - t,
                               "error": err["max"], "worst": err["worst"],
                               "events": r["events"], "status": r["status"]}
                    except Exception as exc:  # noqa: BLE001 - a loose tolerance may fail
                        row = {"rtol": rtol, "seconds": time.perf_counter() - t,
                               "error": math.nan, "failed": str(exc)[:200]}
                    rows.append(row)
            ref_rows = [r for rows in series.values() for r in rows]
            err_k = rel_error(res, conv)
            if echo is not None:
                echo(f"  {wid} / {rid}: kernel {1e3 * t_k['median']:.2f} ms, error "
                     f"{err_k['max']:.2g}; reference {sum(r['seconds'] for r in ref_rows):.1f} "
                     f"s over {len(ref_rows)} runs")
            cases.append({
                "wall": wid, "record": rid, "scale": sf, "samples": int(ag.size), "dt": dt,
                "duration": float((ag.size - 1) * dt), "events": res["events"],
                "status": res["status"], "converged_rtol": conv["rtol"],
                "converged_events": conv["events"], "converged_status": conv["status"],
                "converged_rejected": conv["rejected"],
                "kernel_seconds": t_k["median"], "kernel_error": err_k["max"],
                "kernel_worst": err_k["worst"], "reference": series})
    out = {"window": window, "rtols": list(rtols), "cases": cases, "figures": []}
    if figures is not None:
        out["figures"] = [plot_case(c, Path(figures)) for c in cases]
    return out


def series_of(case: dict) -> dict:
    """Reference series of a work-precision case (older results hold one list)."""
    ref = case["reference"]
    return ref if isinstance(ref, dict) else {"max_step dt/8 (default)": ref}


def plot_case(c: dict, folder: Path) -> str:
    """The work-precision figure of one case, written to `folder`; returns its file name."""
    floor = 1e-17
    fig = Figure(figsize=(5.5, 4.0))
    ax = fig.subplots()
    for i, (sname, series) in enumerate(series_of(c).items()):
        rows = [r for r in series if math.isfinite(r.get("error", math.nan))]
        ax.loglog([r["seconds"] for r in rows], [max(r["error"], floor) for r in rows],
                  "o-" if i == 0 else "^--", label=f"reference, {sname}")
        for r in rows:
            ax.annotate(f"{r['rtol']:.0e}", (r["seconds"], max(r["error"], floor)),
                        fontsize=6, xytext=(3, 3), textcoords="offset points")
    ax.loglog([c["kernel_seconds"]], [max(c["kernel_error"], floor)], "s", ms=9,
              color="C3", label="exact kernel")
    ax.set_xlabel("time per analysis [s]")
    ax.set_ylabel("max relative error of the peak outputs [1]")
    ax.set_title(f"{c['wall']} / {c['record']} ({c['duration']:.0f} s, "
                 f"{c['events']} events)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure(fig, folder, f"work-precision-{c['wall']}-{c['record']}.png")


def render(w: dict, *, figures_dir: str = "performance") -> list[str]:
    """The work-precision section of the report (figures linked from `figures_dir`)."""
    win = (f"the first {w['window']:g} s of each record" if w["window"] else "whole records")
    L = ["## Work-precision", "",
         f"Error of the peak outputs (max relative error over {len(PEAKS)} peaks) against the "
         f"converged reference vs time per analysis; records scaled by their manifest scale "
         f"factors, COR 0.8, **{win}** (the reference integrates every record step separately "
         "at about 1 ms per step whatever its tolerance, so whole records at nine tolerances "
         "take too long). Two reference series: its default, which caps the step at dt/8 "
         "(an 8th-order method on at least 8 steps per record step is near round-off at any "
         "rtol, so the cap, not rtol, sets its cost and accuracy), and no step cap, the "
         "adaptive integrator as MATLAB's ode45 runs by default. The converged reference "
         "(default series) is the tightest of rtol "
         f"{', '.join(f'{r:g}' for r in CONVERGED_RTOLS)} that runs and agrees with the next "
         f"looser one (same events, peaks within {SELF_CONVERGED:g}); the kernel column is "
         "the cross-check of the two.", ""]
    header = ["wall", "record", "events", "kernel time", "kernel error", "reference",
              *(f"rtol {r:.0e}" for r in w["rtols"])]
    rows = []
    for c in w["cases"]:
        for i, (sname, series) in enumerate(series_of(c).items()):
            head = ([c["wall"], c["record"], f"{c['events']} ({c['status']})",
                     f"{1e3 * c['kernel_seconds']:.2f} ms", fmt(c["kernel_error"], 2)]
                    if i == 0 else [""] * 5)
            rows.append([*head, sname,
                         *(f"{fmt(r.get('error'), 2)} / {r['seconds']:.2g} s" for r in series)])
    L += table(header, rows)
    rej = [f"{c['wall']}/{c['record']}: rtol {r['rtol']:g} ({r['why']})"
           for c in w["cases"] for r in c.get("converged_rejected", [])]
    if rej:
        L += ["", "Tolerances not taken as converged: " + "; ".join(rej) + "."]
    L += ["", "Reference cells: error / time per analysis. Reading the errors: the reference "
          "at a loose tolerance is measured against itself at a tight one, and it restarts "
          "at every record step, so within a step it is close to converged already and its "
          "error against itself can fall below its true error; the kernel-vs-converged "
          "column is the independent cross-check and bounds the true error of both from "
          "below. Reference times hardly depend on rtol: the per-step restart dominates.", ""]
    for name in w.get("figures", []):
        L.append(f"![{name}]({figures_dir}/{name})")
    L.append("")
    return L
