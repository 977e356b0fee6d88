"""Kernel: analyses per second per core on the benchmark wall under El Centro x 0.5, warm
(mode tables cached, as in studies) and cold (`urmx.kernel.clear_cache` before each run),
the speed ratio to the reference at ``rtol=1e-8`` and the errors of both against the
converged reference, all in one run; with a profile of the Python layer; and the kernel
against the one at `kernel_paired.BASELINE_COMMIT` in paired processes on one core, on the
benchmark analysis and a typical IDA analysis, with the per-sub-step and per-event costs
against a minimal stepping loop (`benchmarks.kernel_paired`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from urmx import Wall
from urmx.markdown import table

from .. import kernel_paired
from ..common import (
    PEAKS,
    benchmark_wall,
    converged_reference,
    fmt,
    load_record,
    median_time,
    rel_error,
    scalars_only,
    verdict,
)

TARGET_RATE = 2000.0  # analyses per second per core, benchmark wall
TARGET_SPEEDUP = 1000.0  # kernel over the reference at rtol=1e-8


def run(quick: bool, echo: Callable[[str], None] = print) -> dict:
    """Warm and cold rates, the reference at rtol 1e-8 and the converged reference; the
    paired measurement against `kernel_paired.BASELINE_COMMIT` (``"paired"``)."""
    from urmx import kernel, reference

    wall = benchmark_wall()
    ag, dt, sf = load_record("elcentro")
    kw = dict(scale=sf, cor=0.8)
    res = kernel.run(wall, ag, dt, **kw)  # compile / load the numba cache; fill the tables
    warm = median_time(lambda: kernel.run(wall, ag, dt, **kw), repeat=5,
                       min_time=0.5 if quick else 5.0)
    cold = median_time(lambda: kernel.run(wall, ag, dt, **kw), repeat=3 if quick else 10,
                       min_time=0.2 if quick else 3.0, setup=kernel.clear_cache)
    ref8 = {}
    ref_t = median_time(lambda: ref8.update(reference.run(wall, ag, dt, rtol=1e-8, **kw)),
                        repeat=1 if quick else 3)
    conv = converged_reference(wall, ag, dt, **kw)
    err_k = rel_error(res, conv)
    err_r = rel_error(ref8, conv)
    # the kernel's own error, independent of the reference: the same piecewise-linear ground
    # motion sampled at dt/2 must give the same continuous-time peaks
    fine = np.interp(np.arange(2 * ag.size - 1) * (dt / 2), np.arange(ag.size) * dt, ag)
    self_check = rel_error(kernel.run(wall, fine, dt / 2, **kw), res)
    ref_vs_kernel = rel_error(ref8, res)
    out = {
        "case": "benchmark wall, El Centro S00E x 0.5, COR 0.8",
        "samples": int(ag.size), "dt": dt, "scale": sf, "events": res["events"],
        "status": res["status"], "reference_events": ref8["events"],
        "warm": warm, "cold": cold, "reference_1e-8": ref_t,
        "rate_warm": 1.0 / warm["median"], "rate_cold": 1.0 / cold["median"],
        "us_per_event": 1e6 * warm["median"] / max(res["events"], 1),
        "speedup": ref_t["median"] / warm["median"],
        "converged_rtol": conv["rtol"], "converged_seconds": conv["seconds"],
        "converged_events": conv["events"], "converged_rejected": conv["rejected"],
        "error_kernel": err_k, "error_reference_1e-8": err_r,
        "kernel_self_check": self_check, "reference_1e-8_vs_kernel": ref_vs_kernel,
        "kernel": scalars_only(res), "converged": scalars_only(conv),
    }
    out["met_rate"] = out["rate_warm"] >= TARGET_RATE
    out["met_speedup"] = out["speedup"] >= TARGET_SPEEDUP
    out["resolution"] = max(err_k["max"], self_check["max"])
    out["met_error"] = error_verdict(err_k["max"], self_check["max"], err_r["max"],
                                     ref_vs_kernel["max"])
    out["profile"] = profile(wall, ag, dt, n=20 if quick else 200, **kw)
    out["paired"] = kernel_paired.run(quick, echo)
    return out


def error_verdict(kernel_vs_converged: float, kernel_self: float, reference_vs_converged: float,
                  reference_vs_kernel: float) -> bool | None:
    """Is the kernel's error smaller than the reference's? True when the reference's distance
    from both the converged reference and the kernel exceeds ten times the resolution (the
    larger of the kernel-converged cross-check and the kernel's dt/2 self-check); False when
    the kernel is farther from the converged reference than ten times the reference is and
    its self-check does not explain it; None (a tie) when both lie within the resolution."""
    resolution = max(kernel_vs_converged, kernel_self)
    if min(reference_vs_converged, reference_vs_kernel) > 10 * resolution:
        return True
    if kernel_vs_converged > 10 * max(reference_vs_converged, kernel_self, 1e-15):
        return False
    return None


def profile(wall: Wall, ag: np.ndarray, dt: float, n: int = 100, **kw: Any) -> dict:
    """Per-function time of `kernel.run` (cProfile of the Python layer: input checks, tables,
    the numba integrator, the scalar dict) over `n` warm runs, per analysis."""
    import cProfile
    import pstats

    from urmx import kernel

    kernel.run(wall, ag, dt, **kw)
    prof = cProfile.Profile()
    prof.enable()
    for _ in range(n):
        kernel.run(wall, ag, dt, **kw)
    prof.disable()
    stats = pstats.Stats(prof)
    rows = []
    total = 0.0
    for (file, _line, func), (_cc, ncalls, tt, ct, _callers) in stats.stats.items():
        if func == "run" and file.endswith(("kernel.py", "kernel/__init__.py")):
            total = ct / n
        rows.append({"function": f"{where(file)}:{func}", "calls": ncalls / n,
                     "own_us": 1e6 * tt / n, "cumulative_us": 1e6 * ct / n})
    rows.sort(key=lambda r: -r["own_us"])
    return {"analyses": n, "total_us": 1e6 * total, "top": rows[:8]}


def where(file: str) -> str:
    """A profiled function's file as the report names it: its path in the checkout for
    the project's own modules (``urmx/kernel/__init__.py``), else its name (also for an
    installed package in a virtual environment inside the checkout, as CI's)."""
    from urmx.config import project_root

    try:
        rel = Path(file).resolve().relative_to(project_root().resolve())
    except ValueError:  # (numpy, builtins: "~")
        return Path(file).name
    return Path(file).name if "site-packages" in rel.parts else rel.as_posix()


def _error_word(k: dict) -> str:
    if k["met_error"] is None:
        return f"**tie** (both within {fmt(k['resolution'], 2)}: not resolvable)"
    return verdict(k["met_error"])


def targets(k: dict) -> list[list[str]]:
    """Rows (target, measured, verdict) of the report's targets table."""
    return [
        [f">= {TARGET_RATE:.0f} analyses/s/core, benchmark wall",
         f"{k['rate_warm']:.0f} /s warm, {k['rate_cold']:.0f} /s cold", verdict(k["met_rate"])],
        [f">= {TARGET_SPEEDUP:.0f}x faster than the reference at rtol 1e-8",
         f"{k['speedup']:.0f}x", verdict(k["met_speedup"])],
        ["... with smaller error",
         f"kernel {fmt(k['error_kernel']['max'])} (self-check "
         f"{fmt(k['kernel_self_check']['max'])}) vs reference "
         f"{fmt(k['error_reference_1e-8']['max'])} (vs kernel "
         f"{fmt(k['reference_1e-8_vs_kernel']['max'])})", _error_word(k)],
    ] + (kernel_paired.targets(k["paired"]) if "paired" in k else [])


def render(k: dict) -> list[str]:
    """The kernel section of the report."""
    L = ["## Kernel: the benchmark wall", "",
         f"{k['case']}: {k['samples']} samples at {k['dt']} s, {k['events']} events "
         f"(reference: {k['reference_events']}), status {k['status']}.", ""]
    L += table(["", "time per analysis", "analyses/s/core", "repeats"], [
        ["kernel, warm (mode tables cached, as in studies)",
         f"{1e3 * k['warm']['median']:.3f} ms", f"{k['rate_warm']:.0f}", k["warm"]["repeats"]],
        ["kernel, cold (`clear_cache()` before each run)",
         f"{1e3 * k['cold']['median']:.3f} ms", f"{k['rate_cold']:.0f}", k["cold"]["repeats"]],
        ["reference, rtol 1e-8 (DOP853)", f"{k['reference_1e-8']['median']:.3f} s",
         f"{1 / k['reference_1e-8']['median']:.2f}", k["reference_1e-8"]["repeats"]],
        [f"converged reference, rtol {k['converged_rtol']:g}",
         f"{k['converged_seconds']:.3f} s", "", 1]])
    L.append("")
    for r in k.get("converged_rejected", []):
        L.append(f"- not taken as converged: rtol {r['rtol']:g} ({r['why']})")
    L += ["",
          f"Speed ratio kernel (warm) / reference at rtol 1e-8: **{k['speedup']:.0f}x** "
          f"(target {TARGET_SPEEDUP:.0f}x: {verdict(k['met_speedup'])}). "
          f"Rate: **{k['rate_warm']:.0f} analyses/s/core** (target {TARGET_RATE:.0f}: "
          f"{verdict(k['met_rate'])}); {k['us_per_event']:.1f} us per event.", "",
          "Errors against the converged reference (max relative error over the peak outputs):",
          ""]
    cols = ("error_kernel", "kernel_self_check", "error_reference_1e-8",
            "reference_1e-8_vs_kernel")
    L += table(["output", "kernel vs converged", "kernel self-check (dt/2)",
                "reference 1e-8 vs converged", "reference 1e-8 vs kernel"],
               [[name, *(fmt(k[c]["each"][name]) for c in cols)] for name in PEAKS]
               + [["**max**", *(f"**{fmt(k[c]['max'])}**" for c in cols)]])
    L.append("")
    L.append(f"Smaller error than the reference at rtol 1e-8: {_error_word(k)}. The kernel's "
             "distance from the converged reference cannot show below that reference's own "
             "error, so the kernel is also checked against itself: the same piecewise-linear "
             "ground motion resampled at dt/2 must give the same continuous-time peaks. The "
             "resolution is the larger of the two; the reference is judged by its distance "
             "from both the converged reference and the kernel.")
    if k["met_error"] is False:
        L.append(f" The kernel and the converged reference disagree in "
                 f"`{k['error_kernel']['worst']}` by {fmt(k['error_kernel']['max'])} "
                 f"(events {k['events']} vs {k['converged_events']}): they do not resolve the "
                 f"same events, which is a correctness question for the kernel or the "
                 f"reference, not a tolerance effect.")
    L.append("")
    p = k.get("profile")
    if p:
        L += [f"Profile of the Python layer (cProfile, {p['analyses']} warm analyses; "
              f"`kernel.run` {p['total_us']:.0f} us per analysis under the profiler):", ""]
        L += table(["function", "calls/analysis", "own us/analysis", "cumulative us/analysis"],
                   [[f"`{r['function']}`", f"{r['calls']:.3g}", f"{r['own_us']:.1f}",
                     f"{r['cumulative_us']:.1f}"] for r in p["top"]])
        L.append("")
        if not k["met_rate"]:
            top = p["top"][0] if p["top"] else None
            share = top["own_us"] / p["total_us"] if top and p["total_us"] else math.nan
            L.append(f"**Why the rate target is missed:** `{top['function']}` takes "
                     f"{100 * share:.0f} % of the time per analysis; the Python around it "
                     f"(checks, tables, the result dict) is the rest. At "
                     f"{k['us_per_event']:.1f} us per event, {k['events']} events cost "
                     f"{k['us_per_event'] * k['events'] / 1e3:.2f} ms; the target needs "
                     f"{1e6 / TARGET_RATE / max(k['events'], 1):.2f} us per event.")
            L.append("")
    if "paired" in k:
        L += kernel_paired.render(k["paired"])
    return L
