"""Speed against error: the benchmark suite behind ``urmx bench`` and ``reports/performance.md``.

Sections (each a function returning a plain, JSON-able dict; :func:`render` turns the dicts
into Markdown):

- :func:`bench_kernel` - analyses per second per core of `urmx.kernel.run` on the benchmark
  wall of issue 2 (warm: mode tables cached, as in studies; cold: `kernel.clear_cache` before
  each run), the speed ratio to `urmx.reference.run` at ``rtol=1e-8`` and the errors of both
  against a converged reference, all measured in one run; with a profile of the Python layer.
- :func:`work_precision` - error of the peak outputs against the converged reference versus
  time per analysis, for the exact kernel and the reference over ``rtol`` 1e-3 .. 1e-11.
- :func:`cost_growth` - time per analysis against record length and number of events, and
  memory per analysis with and without histories.
- :func:`grid_scaling` - analyses per second of a synthetic study grid run through the study
  layer (`urmx.study`) in this process and on a `dask.distributed.LocalCluster` of 1 and 2
  worker processes; optionally `urmx paper` end to end from a cold start.
- :func:`hard_cases` - the hard cases of MODEL.md section 10: time, events, agreement.
- :func:`guard` - the CI regression guard (< 30 s) against ``benchmarks/baseline.toml``.

Timings are medians over repeats (:func:`median_time`). Nothing here is a test: the numbers
depend on the machine and its load, so the report carries the machine, the versions and the
load average of the run.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .config import project_root
from .model import Wall

# ---- targets (issues 2, 4 and 6) ---------------------------------------------------------------

TARGET_RATE = 2000.0  # analyses per second per core, benchmark wall (issue 2)
TARGET_SPEEDUP = 1000.0  # kernel over reference at rtol=1e-8 (issue 2)
TARGET_SCALING = 1.7  # 2 workers over 1 (issue 6)
TARGET_GRID_RATE = 1500.0  # synthetic 100,000-analysis grid, 2 local workers (issue 4)
TARGET_PAPER = 60.0  # urmx paper end to end from a cold start [s] (issue 4)
GUARD_SLOWDOWN = 3.0  # the guard fails when the kernel is this much slower than stored
GUARD_ERROR = 1e-9  # ... or its relative error against the reference exceeds this

# the reference's own step cap (its default, max_step = dt/8) and none (as MATLAB's ode45)
REFERENCE_SERIES = {"max_step dt/8 (default)": {}, "no step cap": {"max_step": math.inf}}
RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11)
# the converged reference: the tightest of these that runs and agrees with the next one
CONVERGED_RTOLS = (1e-12, 1e-11, 1e-10)
SELF_CONVERGED = 1e-8  # peaks of two successive tolerances this close: converged
# the peak outputs whose error is measured (MODEL.md section 10)
PEAKS = ("peak_crack_displacement", "peak_top_displacement", "peak_base_displacement",
         "peak_lower_drift", "peak_upper_drift", "peak_top_acceleration",
         "peak_crack_acceleration", "peak_base_acceleration", "instability_ratio_lower",
         "instability_ratio_upper")
BASELINE = Path("benchmarks") / "baseline.toml"
SECTIONS = ("kernel", "work_precision", "cost_growth", "grid_scaling", "paper", "hard_cases",
            "guard")


# ---- walls and records -------------------------------------------------------------------------

def benchmark_wall(**changes: Any) -> Wall:
    """The benchmark wall of issue 2: b 0.23 m, h 4.14 m, crack at 2/3, m 30 t, rigid base,
    top diaphragm 815 kN/m with 20 t and 12 % damping, PMR 75."""
    w = Wall(thickness=0.23, height=4.14, crack_ratio=2.0 / 3.0, mass=30000.0,
             bottom_stiffness="rigid", bottom_mass=0.0, top_stiffness=815e3, top_mass=20000.0,
             top_damping=0.12, pmr=75.0)
    return w.replace(**changes) if changes else w


def slender12_wall() -> Wall:
    """A parametric wall of slenderness 12 (h = 2.76 m) on diaphragm D3 (21310 kN/m)."""
    return benchmark_wall(height=12 * 0.23, mass=30000.0 * 12 * 0.23 / 4.14,
                          top_stiffness=21310e3)


def table2_walls() -> dict[str, Wall]:
    """The three Table II walls of the catalog, on their own supports."""
    from .catalog import load_catalog

    cat = load_catalog()
    return {k: cat.walls[k].wall for k in ("wall12", "west", "c9")}


def bench_walls() -> dict[str, Wall]:
    """The five walls of the work-precision study: Table II plus two parametric walls."""
    walls = table2_walls()
    walls["benchmark"] = benchmark_wall()
    walls["slender12-D3"] = slender12_wall()
    return walls


def load_record(record_id: str, window: float | None = None) -> tuple[np.ndarray, float, float]:
    """(samples [m s-2], dt [s], manifest scale factor) of a manifest record, optionally
    only its first `window` seconds."""
    from .records import load

    trace = load(record_id)
    ag = np.ascontiguousarray(trace.data, dtype=np.float64)
    dt = float(trace.stats.delta)
    if window is not None:
        ag = ag[:int(round(window / dt)) + 1]
    return ag, dt, float(trace.stats.record.scale_factor)


def synthetic_record(duration: float = 5.0, dt: float = 0.01, pga: float = 3.0) -> np.ndarray:
    """A short synthetic record: a 2 Hz sine under a triangular envelope peaking at 1/3 of
    the duration, PGA `pga` [m s-2] (deterministic)."""
    t = np.arange(int(round(duration / dt)) + 1) * dt
    env = np.minimum(t / (duration / 3), (duration - t) / (2 * duration / 3))
    ag = np.clip(env, 0, 1) * np.sin(2 * np.pi * 2.0 * t)
    return pga * ag / np.max(np.abs(ag))


# ---- measuring ---------------------------------------------------------------------------------

def median_time(fn: Callable[[], Any], repeat: int = 5, min_time: float = 0.0,
                setup: Callable[[], Any] | None = None, max_repeat: int = 10000) -> dict:
    """Median wall time of `fn()` over at least `repeat` calls and `min_time` seconds
    (`setup()` runs before each call, untimed)."""
    times = []
    start = time.perf_counter()
    while len(times) < repeat or (time.perf_counter() - start < min_time
                                  and len(times) < max_repeat):
        if setup is not None:
            setup()
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    a = np.array(times)
    return {"median": float(np.median(a)), "min": float(a.min()), "max": float(a.max()),
            "repeats": len(times)}


def rel_error(res: dict, ref: dict, names=PEAKS) -> dict:
    """Relative error of each peak output of `res` against `ref` (0 when both are 0), and
    their maximum under ``"max"`` and the name of the worst under ``"worst"``."""
    errs = {}
    for k in names:
        a, b = float(res[k]), float(ref[k])
        if a == b:
            errs[k] = 0.0
        elif not (math.isfinite(a) and math.isfinite(b)):
            errs[k] = math.inf
        else:
            errs[k] = abs(a - b) / max(abs(b), 1e-300)
    worst = max(errs, key=errs.get)
    return {"max": errs[worst], "worst": worst, "each": errs}


def converged_reference(wall: Wall, ag: np.ndarray, dt: float, **kw: Any) -> dict:
    """The converged reference: the tightest `rtol` of `CONVERGED_RTOLS` that runs and agrees
    with the next looser one (same events, peaks to `SELF_CONVERGED`). The result carries
    ``rtol``, ``seconds`` and ``rejected`` (tighter tolerances that did not run or did not
    agree, with why)."""
    from . import reference

    runs = []
    for rtol in CONVERGED_RTOLS:
        t = time.perf_counter()
        try:
            res = reference.run(wall, ag, dt, rtol=rtol, **kw)
        except Exception as exc:  # noqa: BLE001 - too tight for the solver
            runs.append((rtol, None, f"failed: {str(exc)[:120]}"))
            continue
        res["seconds"] = time.perf_counter() - t
        res["rtol"] = rtol
        runs.append((rtol, res, ""))
    done = [(r, res) for r, res, _ in runs if res is not None]
    if not done:
        raise RuntimeError(f"the reference solver ran at none of rtol {CONVERGED_RTOLS}: "
                           f"{runs[-1][2]}")
    rejected = [{"rtol": r, "why": why} for r, res, why in runs if res is None]
    for (rtol, res), (looser, nxt) in zip(done, done[1:], strict=False):
        diff = rel_error(res, nxt)["max"]
        if res["events"] == nxt["events"] and diff <= SELF_CONVERGED:
            res["rejected"] = rejected
            return res
        rejected.append({"rtol": rtol, "why": f"{res['events']} events vs {nxt['events']} and "
                         f"peaks {diff:.2g} apart at rtol {looser:g}"})
    res = done[-1][1]  # none agrees with a looser one: the loosest that ran
    res["rejected"] = rejected
    return res


def _scalars_only(res: dict) -> dict:
    return {k: v for k, v in res.items() if isinstance(v, (int, float, str))}


# ---- machine -----------------------------------------------------------------------------------

def machine_class() -> str:
    """The key of the stored baseline: architecture and core count (``x86_64-2cpu``)."""
    return f"{platform.machine() or 'unknown'}-{os.cpu_count() or 1}cpu"


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def _ram_gb() -> float:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal"):
                return int(line.split()[1]) / 1024 ** 2
    except OSError:
        pass
    return math.nan


def _git_commit() -> str:
    root = project_root()
    try:
        head = subprocess.run(["git", "rev-parse", "--short=12", "HEAD"], cwd=root,
                              capture_output=True, text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "urmx"], cwd=root,
                               capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return (head or "unknown") + (" (urmx/ modified)" if dirty else "")


def machine_info() -> dict:
    """CPU, cores, RAM, load, versions, urmx version and commit, date."""
    import dask
    import distributed
    import numba
    import scipy

    from . import __version__

    return {
        "cpu": _cpu_model(), "cores": os.cpu_count() or 1, "ram_gb": round(_ram_gb(), 1),
        "machine_class": machine_class(),
        "load_average": [round(x, 2) for x in os.getloadavg()] if hasattr(os, "getloadavg")
        else None,
        "python": platform.python_version(), "numpy": np.__version__,
        "numba": numba.__version__, "scipy": scipy.__version__, "dask": dask.__version__,
        "distributed": distributed.__version__, "urmx": __version__, "commit": _git_commit(),
        "date": _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat(),
    }


# ---- kernel ------------------------------------------------------------------------------------

def bench_kernel(quick: bool = False) -> dict:
    """Analyses per second per core on the benchmark wall under El Centro x 0.5, warm and
    cold; the reference at rtol=1e-8 and the converged reference in the same run."""
    from . import kernel, reference

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
        "kernel": _scalars_only(res), "converged": _scalars_only(conv),
    }
    out["met_rate"] = out["rate_warm"] >= TARGET_RATE
    out["met_speedup"] = out["speedup"] >= TARGET_SPEEDUP
    out["resolution"] = max(err_k["max"], self_check["max"])
    out["met_error"] = error_verdict(err_k["max"], self_check["max"], err_r["max"],
                                     ref_vs_kernel["max"])
    out["profile"] = profile_kernel(wall, ag, dt, n=20 if quick else 200, **kw)
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


def profile_kernel(wall: Wall, ag: np.ndarray, dt: float, n: int = 100, **kw: Any) -> dict:
    """Per-phase time of `kernel.run` (cProfile of the Python layer: input checks, tables,
    the numba integrator, the scalar dict) over `n` warm runs, per analysis."""
    import cProfile
    import pstats

    from . import kernel

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
        if func == "run" and file.endswith("kernel.py"):
            total = ct / n
        rows.append({"function": f"{Path(file).name}:{func}", "calls": ncalls / n,
                     "own_us": 1e6 * tt / n, "cumulative_us": 1e6 * ct / n})
    rows.sort(key=lambda r: -r["own_us"])
    return {"analyses": n, "total_us": 1e6 * total, "top": rows[:8]}


# ---- work-precision ----------------------------------------------------------------------------

def work_precision(quick: bool = False, window: float | None = 20.0,
                   figures: str | os.PathLike | None = None,
                   echo: Callable[[str], None] | None = None) -> dict:
    """Error of the peak outputs against the converged reference versus time per analysis,
    for the exact kernel and the reference at `RTOLS`, per wall and record.

    Records are scaled by their manifest scale factors and cut to their first `window`
    seconds (the reference integrates every record step separately and costs about 1 ms per
    step whatever its tolerance)."""
    from . import kernel, reference

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
                              repeat=3,
                              min_time=0.1 if quick else 1.0)
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
        out["figures"] = _plot_work_precision(cases, Path(figures))
    return out


def _series(case: dict) -> dict:
    """Reference series of a work-precision case (older results hold one list)."""
    ref = case["reference"]
    return ref if isinstance(ref, dict) else {"max_step dt/8 (default)": ref}


def _plot_work_precision(cases: list[dict], folder: Path) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder.mkdir(parents=True, exist_ok=True)
    files = []
    floor = 1e-17
    for c in cases:
        fig, ax = plt.subplots(figsize=(5.5, 4.0))
        for i, (sname, series) in enumerate(_series(c).items()):
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
        name = f"work-precision-{c['wall']}-{c['record']}.png"
        fig.savefig(folder / name, dpi=90)
        plt.close(fig)
        files.append(name)
    return files


# ---- cost growth -------------------------------------------------------------------------------

def _fit_line(x, y) -> dict:
    x, y = np.asarray(x, float), np.asarray(y, float)
    slope, icpt = np.polyfit(x, y, 1)
    pred = slope * x + icpt
    ss = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - float(np.sum((y - pred) ** 2)) / ss if ss > 0 else 1.0
    loglog = float(np.polyfit(np.log(x), np.log(y), 1)[0]) if np.all(x > 0) and np.all(
        y > 0) else math.nan
    return {"slope": float(slope), "intercept": float(icpt), "r2": r2, "loglog_slope": loglog}


def cost_growth(quick: bool = False, figures: str | os.PathLike | None = None) -> dict:
    """Time per analysis against record length (El Centro tiled), against the number of
    events (scale factors), and memory per analysis with and without histories."""
    import tracemalloc

    from . import kernel

    wall = benchmark_wall()
    ag0, dt, sf = load_record("elcentro")
    lengths = (10.0, 20.0, 40.0) if quick else (10.0, 20.0, 30.0, 60.0, 90.0, 120.0)
    min_time = 0.2 if quick else 2.0
    by_length = []
    for L in lengths:
        ag = np.resize(ag0, int(round(L / dt)) + 1)  # El Centro repeated end to end
        res = kernel.run(wall, ag, dt, scale=sf)
        t = median_time(lambda a=ag: kernel.run(wall, a, dt, scale=sf), repeat=3,
                        min_time=min_time)
        by_length.append({"length": L, "seconds": t["median"], "events": res["events"],
                          "status": res["status"]})
    scales = (0.25, 0.5, 1.0) if quick else (0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0)
    by_events = []
    for s in scales:
        res = kernel.run(wall, ag0, dt, scale=s)
        t = median_time(lambda s=s: kernel.run(wall, ag0, dt, scale=s), repeat=3,
                        min_time=min_time)
        by_events.append({"scale": s, "seconds": t["median"], "events": res["events"],
                          "status": res["status"], "collapsed": res["collapsed"]})
    ok = [r for r in by_events if not r["collapsed"]]
    memory = {}
    for hist in (False, True):
        kernel.run(wall, ag0, dt, scale=sf, history=hist)
        tracemalloc.start()
        res = kernel.run(wall, ag0, dt, scale=sf, history=hist)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        arrays = sum(v.nbytes for v in res.get("history", {}).values()
                     if isinstance(v, np.ndarray))
        memory["history" if hist else "scalars"] = {"peak_bytes": int(peak),
                                                    "history_array_bytes": int(arrays)}
    tables = kernel._TABLES.get((wall.params.tobytes(), float(dt)))
    memory["mode_tables_bytes"] = int(sum(a.nbytes for a in tables)) if tables else 0
    out = {
        "wall": "benchmark", "record": "elcentro (tiled)", "dt": dt, "by_length": by_length,
        "length_fit": _fit_line([r["length"] for r in by_length],
                                [r["seconds"] for r in by_length]),
        "by_events": by_events,
        "events_fit": _fit_line([r["events"] for r in ok], [r["seconds"] for r in ok])
        if len(ok) >= 2 else None,
        "memory": memory, "figures": [],
    }
    if figures is not None:
        out["figures"] = [_plot_cost(out, Path(figures))]
    return out


def _plot_cost(c: dict, folder: Path) -> str:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder.mkdir(parents=True, exist_ok=True)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 3.6))
    x = [r["length"] for r in c["by_length"]]
    y = [1e3 * r["seconds"] for r in c["by_length"]]
    a1.plot(x, y, "o")
    f = c["length_fit"]
    xs = np.linspace(0, max(x), 50)
    a1.plot(xs, 1e3 * (f["slope"] * xs + f["intercept"]), "-", lw=1,
            label=f"fit: {1e3 * f['slope']:.3g} ms/s, R2 {f['r2']:.4f}")
    a1.set_xlabel("record length [s]")
    a1.set_ylabel("time per analysis [ms]")
    a1.legend(fontsize=8)
    ok = [r for r in c["by_events"] if not r["collapsed"]]
    a2.plot([r["events"] for r in ok], [1e3 * r["seconds"] for r in ok], "o")
    for r in ok:
        a2.annotate(f"x{r['scale']:g}", (r["events"], 1e3 * r["seconds"]), fontsize=7,
                    xytext=(3, 3), textcoords="offset points")
    a2.set_xlabel("events per analysis")
    a2.set_ylabel("time per analysis [ms]")
    for a in (a1, a2):
        a.grid(True, alpha=0.3)
        a.set_ylim(bottom=0)
    fig.tight_layout()
    name = "cost-growth.png"
    fig.savefig(folder / name, dpi=90)
    plt.close(fig)
    return name


# ---- grid scaling ------------------------------------------------------------------------------

def synthetic_study(n_cor: int, n_scale: int, duration: float = 5.0, dt: float = 0.01):
    """(Study, records) of a synthetic grid: the catalog's parametric walls x diaphragms
    D1-D5 (single storey) x the synthetic record x `n_cor` CORs x `n_scale` scale factors."""
    import hashlib

    from .catalog import Study, load_catalog
    from .study import RecordData

    cat = load_catalog()
    acc = synthetic_record(duration, dt)
    study = Study(
        name="bench-synthetic", title="synthetic benchmark grid", path=None, text="",
        catalog=cat, walls=[cat.walls[k] for k in cat.parametric_walls],
        diaphragms=[cat.diaphragms[k] for k in ("D1", "D2", "D3", "D4", "D5")],
        supports="top", records=["synthetic"],
        cor=[round(float(c), 6) for c in np.linspace(0.6, 0.95, n_cor)],
        extra={"scale": [round(float(s), 6) for s in np.linspace(0.2, 1.2, n_scale)]})
    digest = hashlib.sha256(acc.tobytes()).hexdigest()[:16]
    records = {"synthetic": RecordData("synthetic", acc, dt, 1.0, digest)}
    return study, records


def run_grid(study, records: dict, scheduler: Any, batch_size: int = 16):
    """Run a study grid through the study layer's batches, scheduler and Dataset assembly
    (`urmx.study.run_study` without its archive and record resolution). Returns the
    Dataset and the seconds taken."""
    from . import study as S

    t = time.perf_counter()
    tasks = [(b, S._task(study, b, records, None)) for b in S._batches(study, batch_size)]
    results: dict = {}

    def on_result(batch, result):
        results[batch.key] = result

    S._compute(tasks, records, study.records, scheduler, on_result)
    ds = S._assemble(study, records, tasks, results, "bench", "urmx bench study")
    return ds, time.perf_counter() - t


def batch_balance(study, records: dict, batch_size: int = 16) -> dict:
    """Serial time of each batch of a grid, and the best speed-up 2 workers can reach with
    them: batches handed out in submission order to whichever worker is free."""
    from . import study as S

    times = []
    for b in S._batches(study, batch_size):
        task = S._task(study, b, records, None)
        t = time.perf_counter()
        S.run_batch(task, records[study.records[b.record]].acceleration)
        times.append(time.perf_counter() - t)
    free = [0.0, 0.0]
    for t in times:
        i = int(np.argmin(free))
        free[i] += t
    total = float(sum(times))
    return {"count": len(times), "total": total, "largest": float(max(times)),
            "median": float(np.median(times)), "best_speedup_2": total / max(free)}


def _local_client(n_workers: int):
    from distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                           dashboard_address=":0")
    return Client(cluster)


def _warm_workers(client) -> None:
    """Import urmx and load the numba kernel on every worker (not part of the timing)."""
    def warm():
        from urmx import kernel

        kernel.run(benchmark_wall(), synthetic_record(1.0), 0.01)
        return True

    client.run(warm)


def grid_scaling(quick: bool = False, batch_size: int = 16, repeats: int | None = None) -> dict:
    """Analyses per second of a synthetic grid: in this process, and on LocalClusters of 1
    and 2 worker processes (54,000 analyses, at least the 10,000 issue 6 asks); then the
    100,000-analysis grid of issue 4 on 2 workers."""
    # 45 x 1200 = 54,000 analyses: with the kernel at ~0.1 ms an analysis on this record, a
    # 10,000-analysis grid is ~1 s of work and measures the per-run costs (scheduling, the
    # Dataset assembly in this process) rather than throughput
    n_cor, n_scale = (4, 4) if quick else (40, 30)
    repeats = repeats or (1 if quick else 3)
    study, records = synthetic_study(n_cor, n_scale)
    out: dict[str, Any] = {
        "record": "synthetic: 5 s at 0.01 s (501 samples), 2 Hz sine under a triangular "
                  "envelope, PGA 3 m s-2",
        "grid": f"{len(study.walls)} parametric walls x 5 diaphragms (D1-D5, single storey) "
                f"x {n_cor} CORs (0.60-0.95) x {n_scale} scales (0.2-1.2)",
        "analyses": study.size, "batch_size": batch_size, "runs": []}
    ds, _ = run_grid(study, records, "serial", batch_size)  # warm this process
    out["collapsed_share"] = float((ds["collapsed"] == 1).mean())
    out["batches"] = batch_balance(study, records, batch_size)
    # 1 and 2 workers alternate, `repeats` times each (medians): a machine shared with other
    # work changes its load over minutes, and alternating spreads that over both
    clients, startup, held = {}, {}, []
    cpu: dict = {1: [], 2: []}  # CPU seconds the workers used per run
    times: dict = {"serial": [], 1: [], 2: []}
    try:
        for n in (1, 2):
            t0 = time.perf_counter()
            clients[n] = _local_client(n)
            _warm_workers(clients[n])
            startup[n] = time.perf_counter() - t0
            # keep the record scattered for the whole section: each run scatters the same
            # samples under the same content key, and a key released by one run and
            # scattered again by the next can be lost in between ("lost dependencies")
            held.append(clients[n].scatter(records["synthetic"].acceleration, broadcast=True))
        for _ in range(repeats):
            times["serial"].append(run_grid(study, records, "serial", batch_size)[1])
            for n in (1, 2):
                c0 = clients[n].run(time.process_time)
                times[n].append(run_grid(study, records, clients[n], batch_size)[1])
                c1 = clients[n].run(time.process_time)
                cpu[n].append(sum(c1[w] - c0[w] for w in c1 if w in c0))
        # issue 4: a synthetic 100,000-analysis grid on the 2 local workers
        n_cor, n_scale = (5, 10) if quick else (40, 56)  # 45 x 2240 = 100,800 analyses
        big, recs = synthetic_study(n_cor, n_scale)
        _, t_big = run_grid(big, recs, clients[2], batch_size)
    finally:
        for c in clients.values():
            cluster = c.cluster
            c.close()
            cluster.close()
    for key, label in (("serial", "serial (this process)"),
                       (1, "LocalCluster, 1 worker process"),
                       (2, "LocalCluster, 2 worker processes")):
        t = float(np.median(times[key]))
        out["runs"].append({"scheduler": label, "workers": 1 if key == "serial" else key,
                            "seconds": t, "rate": study.size / t, "repeats": len(times[key]),
                            "all_seconds": times[key], "startup": startup.get(key)})
        if key in cpu:  # worker CPU over wall time x workers: below 1, the workers waited
            out["runs"][-1]["cpu_share"] = float(np.median(
                [c / (w * key) for c, w in zip(cpu[key], times[key], strict=True)]))
    r1, r2 = out["runs"][1]["rate"], out["runs"][2]["rate"]
    out["scaling"] = r2 / r1
    out["met_scaling"] = out["scaling"] >= TARGET_SCALING
    out["big"] = {"analyses": big.size, "seconds": t_big, "rate": big.size / t_big,
                  "grid": f"{len(big.walls)} walls x 5 diaphragms x {n_cor} CORs x "
                          f"{n_scale} scales"}
    out["met_big"] = out["big"]["rate"] >= TARGET_GRID_RATE
    return out


def paper_timing(out_dir: str | os.PathLike | None = None) -> dict:
    """`urmx paper` end to end from a cold start: a fresh Python process (imports, numba
    cache loads, a new LocalCluster), writing into a temporary folder."""
    with tempfile.TemporaryDirectory(prefix="urmx-bench-paper-") as tmp:
        dest = Path(out_dir or tmp)
        # archives and report into the temporary folder: the checkout's reports/ is not touched
        cmd = [sys.executable, "-m", "urmx.cli", "paper", "--out", str(dest / "results"),
               "--report", str(dest / "report"), "--quiet"]
        t = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True, cwd=tmp)
        seconds = time.perf_counter() - t
    return {"command": "urmx paper --out <tmp>/results --report <tmp>/report --quiet",
            "seconds": seconds,
            "returncode": proc.returncode, "stderr_tail": proc.stderr.strip()[-600:],
            "met": proc.returncode == 0 and seconds < TARGET_PAPER}


# ---- hard cases (MODEL.md section 10) ----------------------------------------------------------

def _energy_drift(wall: Wall, hist: dict, start: int) -> float:
    """Largest relative change of the mechanical energy (kinetic + trilinear strain energy
    of both segments) over the grid points from `start` on (a wall with both supports
    rigid: one coordinate, theta1)."""
    from .model import P_A1, P_A2, lower_case, potential, system

    P = wall.params
    r = hist["r"][start:, 0]
    v = hist["r_dot"][start:, 0]
    fam = hist["pattern"][start:] // 10
    E = np.empty(r.size)
    for i in range(r.size):
        f = int(fam[i]) if fam[i] in (1, 2) else 2
        M = system(P, f, 0, 0)[0][0, 0]
        th2 = -P[P_A1] / P[P_A2] * r[i]
        E[i] = 0.5 * M * v[i] ** 2 + potential(P, lower_case(f), r[i]) + potential(P, 1, th2)
    return float(np.max(np.abs(E - E[0])) / E[0])


def hard_cases(quick: bool = False) -> dict:
    """The hard cases of MODEL.md section 10: time, events, agreement with the reference."""
    from . import kernel, reference

    rows = []
    bw = benchmark_wall()
    ag_ec, dt_ec, sf_ec = load_record("elcentro", 10.0 if quick else None)
    w12 = table2_walls()["wall12"]
    ag_nh, dt_nh, sf_nh = load_record("nahanni", 5.0 if quick else None)

    def timed(fn, min_time=0.2 if quick else 1.0):
        res = fn()
        return res, median_time(fn, repeat=3, min_time=min_time)["median"]

    def row(name, wall, ag, dt, check, value, ok, ref=True, **kw):
        res, t = timed(lambda: kernel.run(wall, ag, dt, **kw))
        r = {"case": name, "kernel_ms": 1e3 * t, "events": res["events"],
             "status": res["status"], "check": check, "value": value, "ok": bool(ok)}
        if ref:
            t0 = time.perf_counter()
            rr = reference.run(wall, ag, dt, rtol=1e-10, **kw)
            r["reference_s"] = time.perf_counter() - t0
            r["reference_events"] = rr["events"]
            r["agreement"] = rel_error(res, rr)["max"]
            # every case must also agree with the reference (issue 2: 1e-6 in every peak)
            r["ok"] = r["ok"] and r["agreement"] <= 1e-6 and res["status"] == rr["status"]
        rows.append(r)
        return res

    # zero input stays exactly at rest
    zero = np.zeros_like(ag_ec)
    res = kernel.run(bw, zero, dt_ec)
    at_rest = max(abs(res[k]) for k in PEAKS)
    row("zero input (benchmark wall, 0 m s-2)", bw, zero, dt_ec,
        "max peak output", at_rest, at_rest == 0.0 and res["events"] == 0)
    # mirrored input gives mirrored output
    a = kernel.run(bw, ag_ec, dt_ec, scale=sf_ec)
    b = kernel.run(bw, -ag_ec, dt_ec, scale=sf_ec)
    mirror = rel_error(b, a)["max"]
    row("mirrored input (benchmark wall, -El Centro x 0.5)", bw, -ag_ec, dt_ec,
        "max rel. difference of peaks vs unmirrored", mirror, mirror <= 1e-9, scale=sf_ec)
    # energy: both rigid, cor 1, no damping, free vibration after a pulse
    dt = 0.005
    n_pulse, n_free = int(0.5 / dt), int((2.0 if quick else 10.0) / dt)
    for amp in (3.0, 2.0, 1.5, 1.0, 0.7, 0.5):  # the strongest pulse that rocks, no collapse
        pulse = np.zeros(n_pulse + n_free)
        pulse[:n_pulse] = amp * np.sin(np.pi * np.arange(n_pulse) / n_pulse)
        res = kernel.run(w12, pulse, dt, cor=1.0, history=True)
        if not res["collapsed"] and res["events"] > 0:
            break
    drift = _energy_drift(w12, res["history"], n_pulse + 1)
    row(f"energy (Wall 12 both rigid, COR 1, free vibration after a 0.5 s {amp:g} m s-2 "
        "half-sine pulse)", w12, pulse,
        dt, "max rel. energy change in free vibration", drift, drift <= 1e-9, cor=1.0)
    # both supports rigid: simultaneous contacts
    res = kernel.run(w12, ag_nh, dt_nh, scale=sf_nh)
    row("both supports rigid (Wall 12, Nahanni; simultaneous contacts)", w12, ag_nh, dt_nh,
        "base / crack impacts", f"{res['base_impacts']} / {res['crack_impacts']}",
        res["status"] in ("ok", "collapsed"), scale=sf_nh)
    # 1e9 N/m springs with zero diaphragm mass (Table II Wall 12 literally)
    stiff = w12.replace(bottom_stiffness=1e9, top_stiffness=1e9)
    soft = w12.replace(bottom_stiffness=5.5e5, top_stiffness=5.5e5)
    _, t_soft = timed(lambda: kernel.run(soft, ag_nh, dt_nh, scale=sf_nh))
    res, t_stiff = timed(lambda: kernel.run(stiff, ag_nh, dt_nh, scale=sf_nh))
    finite = all(math.isfinite(res[k]) for k in PEAKS)
    row("1e9 N/m springs, zero diaphragm mass (Wall 12 literally, Nahanni)", stiff, ag_nh,
        dt_nh, "time vs 5.5e5 N/m springs", round(t_stiff / t_soft, 2),
        finite and t_stiff / t_soft < 10, scale=sf_nh)
    # a scale factor bracketing collapse (bisection on the kernel)
    lo, hi = sf_ec, None
    s = sf_ec
    while hi is None and s < 64:
        s *= 2
        if kernel.run(bw, ag_ec, dt_ec, scale=s)["collapsed"]:
            hi = s
        else:
            lo = s
    if hi is not None:
        for _ in range(6 if quick else 12):
            mid = 0.5 * (lo + hi)
            if kernel.run(bw, ag_ec, dt_ec, scale=mid)["collapsed"]:
                hi = mid
            else:
                lo = mid
        below = kernel.run(bw, ag_ec, dt_ec, scale=lo)
        above = kernel.run(bw, ag_ec, dt_ec, scale=hi)
        rb = reference.run(bw, ag_ec, dt_ec, scale=lo, rtol=1e-10)
        ra = reference.run(bw, ag_ec, dt_ec, scale=hi, rtol=1e-10)
        same = (below["collapsed"], above["collapsed"]) == (rb["collapsed"], ra["collapsed"])
        row(f"collapse bracket (benchmark wall, El Centro x {lo:.6g} / x {hi:.6g})", bw,
            ag_ec, dt_ec, "collapsed below / above; reference agrees; collapse time diff [s]",
            f"{below['collapsed']} / {above['collapsed']}; {same}; "
            f"{abs(above['collapse_time'] - ra['collapse_time']):.2g}",
            (not below["collapsed"]) and above["collapsed"] and same, ref=False, scale=hi)
    else:
        rows.append({"case": "collapse bracket", "check": "no collapse up to x64",
                     "value": "-", "ok": False})
    # a long fine record: 60 s at 0.001 s (El Centro interpolated, repeated)
    ag_full, _, _ = load_record("elcentro")
    t_fine = np.arange(60001 if not quick else 10001) * 0.001
    fine = np.interp(t_fine % 53.74, np.arange(ag_full.size) * 0.02, ag_full)
    res = row(f"long fine record ({t_fine[-1]:.0f} s at 0.001 s, El Centro x 0.5)", bw, fine,
              0.001, "finished", "-", True, ref=not quick, scale=sf_ec)
    rows[-1]["value"] = res["status"]
    rows[-1]["ok"] = res["status"] in ("ok", "collapsed")
    return {"rows": rows, "reference_rtol": 1e-10}


# ---- regression guard --------------------------------------------------------------------------

def _read_baseline(path: Path) -> dict:
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover
        import tomli as tomllib
    if not path.is_file():
        return {}
    return tomllib.loads(path.read_text(encoding="utf-8"))


def write_baseline(path: Path, cls: str, entry: dict) -> None:
    """Store `entry` (flat str/float/int values) under `cls` in the baseline TOML, keeping
    the other machine classes."""
    data = _read_baseline(path)
    data[cls] = entry
    lines = ["# Stored figures of `urmx bench guard`, one table per machine class",
             "# (architecture-cores). Rewrite a class with `urmx bench guard --update` on a",
             "# quiet machine of that class.", ""]
    for key in sorted(data):
        lines.append(f'["{key}"]')
        for k, v in data[key].items():
            lines.append(f"{k} = {json.dumps(v) if isinstance(v, str) else repr(v)}")
        lines.append("")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines), encoding="utf-8")


def guard_verdict(measured: dict, baseline: dict | None) -> tuple[bool, list[str]]:
    """(passed, messages) of the regression guard for one measurement against the stored
    entry of its machine class (None: unknown class, speed not judged)."""
    msgs = []
    ok = True
    if measured["error"] > GUARD_ERROR:
        ok = False
        msgs.append(f"FAIL: kernel error vs reference {measured['error']:.3g} > {GUARD_ERROR:g} "
                    f"({measured['worst']})")
    else:
        msgs.append(f"ok: kernel error vs reference {measured['error']:.3g} <= {GUARD_ERROR:g}")
    if baseline is None:
        msgs.append(f"no stored figure for machine class {measured['machine_class']!r}: "
                    "speed not judged (store one with `urmx bench guard --update`)")
    else:
        ratio = measured["seconds"] / baseline["seconds"]
        line = (f"kernel {1e3 * measured['seconds']:.3f} ms vs stored "
                f"{1e3 * baseline['seconds']:.3f} ms: {ratio:.2f}x")
        if ratio > GUARD_SLOWDOWN:
            ok = False
            msgs.append(f"FAIL: {line} (> {GUARD_SLOWDOWN:g}x slower)")
        else:
            msgs.append(f"ok: {line} (limit {GUARD_SLOWDOWN:g}x)")
    return ok, msgs


def guard_measure(quick: bool = False) -> dict:
    """The guard's measurement: the benchmark wall under El Centro x 0.5, warm median time
    of the kernel, and its max relative peak error against the reference at rtol 1e-11."""
    from . import kernel, reference

    wall = benchmark_wall()
    ag, dt, sf = load_record("elcentro", 5.0 if quick else None)
    t0 = time.perf_counter()
    res = kernel.run(wall, ag, dt, scale=sf)  # includes numba compilation on a fresh install
    first = time.perf_counter() - t0
    t = median_time(lambda: kernel.run(wall, ag, dt, scale=sf), repeat=5,
                    min_time=0.3 if quick else 2.0)
    ref = reference.run(wall, ag, dt, scale=sf, rtol=1e-11)
    err = rel_error(res, ref)
    return {"machine_class": machine_class(), "seconds": t["median"], "first_call": first,
            "repeats": t["repeats"], "events": res["events"],
            "reference_events": ref["events"], "error": err["max"], "worst": err["worst"],
            "samples": int(ag.size)}


def guard(update: bool = False, baseline_path: str | os.PathLike | None = None,
          quick: bool = False, echo: Callable[[str], None] = print) -> dict:
    """Run the regression guard; with `update` store the measurement as the baseline of
    this machine class. Returns the measurement with ``passed`` and ``messages``."""
    path = Path(baseline_path) if baseline_path else project_root() / BASELINE
    t0 = time.perf_counter()
    m = guard_measure(quick)
    stored = _read_baseline(path).get(m["machine_class"])
    if update:
        info = machine_info()
        write_baseline(path, m["machine_class"], {
            "seconds": m["seconds"], "error": m["error"], "events": m["events"],
            "samples": m["samples"], "cpu": info["cpu"], "commit": info["commit"],
            "date": info["date"],
            "load_average": float(info["load_average"][0]) if info["load_average"] else -1.0})
        stored = _read_baseline(path).get(m["machine_class"])
    ok, msgs = guard_verdict(m, stored)
    m.update(passed=ok, messages=msgs, baseline=stored, guard_seconds=time.perf_counter() - t0)
    echo(f"urmx bench guard [{m['machine_class']}]: kernel {1e3 * m['seconds']:.3f} ms per "
         f"analysis ({1 / m['seconds']:.0f} /s, {m['events']} events, median of "
         f"{m['repeats']}; first call {m['first_call']:.2f} s), error vs reference rtol 1e-11 "
         f"{m['error']:.3g} ({m['worst']})")
    for line in msgs:
        echo("  " + line)
    if update:
        echo(f"  stored as the baseline of {m['machine_class']} in {path}")
    echo(f"  guard took {m['guard_seconds']:.1f} s ({m['guard_seconds'] - m['first_call']:.1f} s "
         f"without the first call, which compiles the numba kernel when its cache is cold): "
         f"{'PASS' if ok else 'FAIL'}")
    return m


# ---- results and the report --------------------------------------------------------------------

def save_section(folder: Path, name: str, data: dict, info: dict, quick: bool) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    payload = {"machine": info, "quick": quick, "data": data}
    (folder / f"{name}.json").write_text(json.dumps(payload, indent=1, default=_json_default),
                                         encoding="utf-8")


def _json_default(o):
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, (np.bool_,)):
        return bool(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)


def load_sections(folder: Path) -> dict:
    out = {}
    for name in SECTIONS:
        p = folder / f"{name}.json"
        if p.is_file():
            out[name] = json.loads(p.read_text(encoding="utf-8"))
    return out


def _error_word(k: dict) -> str:
    if k["met_error"] is None:
        return f"**tie** (both within {_f(k['resolution'], 2)}: not resolvable)"
    return _yes(k["met_error"])


def _yes(ok: bool | None) -> str:
    return "n/a" if ok is None else ("**met**" if ok else "**NOT MET**")


def _f(x: float, d: int = 3) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x:.{d}g}"


def render(sections: dict, figures_dir: str = "performance") -> str:
    """The Markdown of ``reports/performance.md`` from saved sections."""
    L: list[str] = ["# Performance: speed against error", ""]
    L.append("Regenerate with `urmx bench all --paper` (about 25 minutes on a 2-core "
             "machine, most of it the reference solver in the work-precision study; "
             "`--window 10` about halves that; the parts: `urmx bench "
             "kernel|records|study|hard|guard`). Timings are medians "
             "over repeats, in one process unless stated; a *core* is one process. Each "
             "section lists the machine and the load it was measured under; numbers taken "
             "on a loaded machine are noisy.")
    L.append("")
    if not sections:
        return "\n".join(L + ["No measurements yet.", ""])
    info = next(iter(sections.values()))["machine"]
    L += ["## Machine", "",
          "| | |", "|---|---|",
          f"| CPU | {info['cpu']} |", f"| cores | {info['cores']} |",
          f"| RAM | {info['ram_gb']} GB |", f"| machine class | `{info['machine_class']}` |",
          f"| Python | {info['python']} |",
          f"| numpy / scipy / numba | {info['numpy']} / {info['scipy']} / {info['numba']} |",
          f"| dask / distributed | {info['dask']} / {info['distributed']} |",
          f"| urmx | {info['urmx']}, commit `{info['commit']}` |", ""]
    L += ["| section | measured (UTC) | load average (1, 5, 15 min) | sizes | commit |",
          "|---|---|---|---|---|"]
    for name, s in sections.items():
        m = s["machine"]
        load = ", ".join(str(x) for x in m["load_average"] or [])
        L.append(f"| {name} | {m['date']} | {load} | {'QUICK (reduced)' if s['quick'] else 'full'}"
                 f" | `{m['commit']}` |")
    L.append("")
    if any(s["quick"] for s in sections.values()):
        L += ["> **Sections marked QUICK were run at reduced sizes to check the machinery; "
              "they are not the acceptance measurement.**", ""]
    L += _summary(sections)
    if "kernel" in sections:
        L += _render_kernel(sections["kernel"]["data"])
    if "work_precision" in sections:
        L += _render_wp(sections["work_precision"]["data"], figures_dir)
    if "cost_growth" in sections:
        L += _render_cost(sections["cost_growth"]["data"], figures_dir)
    if "grid_scaling" in sections or "paper" in sections:
        L += _render_grid(sections.get("grid_scaling", {}).get("data"),
                          sections.get("paper", {}).get("data"))
    if "hard_cases" in sections:
        L += _render_hard(sections["hard_cases"]["data"])
    if "guard" in sections:
        L += _render_guard(sections["guard"]["data"])
    return "\n".join(L) + "\n"


def _summary(sections: dict) -> list[str]:
    L = ["## Targets", "", "| target | measured | verdict |", "|---|---|---|"]
    k = sections.get("kernel", {}).get("data")
    if k:
        L.append(f"| >= {TARGET_RATE:.0f} analyses/s/core, benchmark wall (issue 2) | "
                 f"{k['rate_warm']:.0f} /s warm, {k['rate_cold']:.0f} /s cold | "
                 f"{_yes(k['met_rate'])} |")
        L.append(f"| >= {TARGET_SPEEDUP:.0f}x faster than the reference at rtol 1e-8 | "
                 f"{k['speedup']:.0f}x | {_yes(k['met_speedup'])} |")
        L.append(f"| ... with smaller error | kernel {_f(k['error_kernel']['max'])} (self-check "
                 f"{_f(k['kernel_self_check']['max'])}) vs reference "
                 f"{_f(k['error_reference_1e-8']['max'])} (vs kernel "
                 f"{_f(k['reference_1e-8_vs_kernel']['max'])}) | {_error_word(k)} |")
    c = sections.get("cost_growth", {}).get("data")
    if c:
        f = c["length_fit"]
        lin = _linear(f)
        L.append(f"| time per analysis linear in record length | R2 {f['r2']:.4f}, log-log "
                 f"slope {f['loglog_slope']:.2f} | {_yes(lin)} |")
    g = sections.get("grid_scaling", {}).get("data")
    if g:
        L.append(f"| 2 workers >= {TARGET_SCALING}x one | {g['scaling']:.2f}x | "
                 f"{_yes(g['met_scaling'])} |")
        L.append(f"| synthetic {g['big']['analyses']:,}-analysis grid >= "
                 f"{TARGET_GRID_RATE:.0f} /s on 2 workers (issue 4) | {g['big']['rate']:.0f} /s "
                 f"| {_yes(g['met_big'])} |")
    p = sections.get("paper", {}).get("data")
    if p:
        L.append(f"| `urmx paper` < {TARGET_PAPER:.0f} s from a cold start (issue 4) | "
                 f"{p['seconds']:.1f} s (exit {p['returncode']}) | {_yes(p['met'])} |")
    gd = sections.get("guard", {}).get("data")
    if gd:
        L.append(f"| regression guard passes | error {_f(gd['error'])}, "
                 f"{1e3 * gd['seconds']:.2f} ms | {_yes(gd['passed'])} |")
    return L + [""]


def _render_kernel(k: dict) -> list[str]:
    L = ["## Kernel: the benchmark wall", "",
         f"{k['case']}: {k['samples']} samples at {k['dt']} s, {k['events']} events "
         f"(reference: {k['reference_events']}), status {k['status']}.", "",
         "| | time per analysis | analyses/s/core | repeats |", "|---|---|---|---|",
         f"| kernel, warm (mode tables cached, as in studies) | {1e3 * k['warm']['median']:.3f}"
         f" ms | {k['rate_warm']:.0f} | {k['warm']['repeats']} |",
         f"| kernel, cold (`clear_cache()` before each run) | {1e3 * k['cold']['median']:.3f}"
         f" ms | {k['rate_cold']:.0f} | {k['cold']['repeats']} |",
         f"| reference, rtol 1e-8 (DOP853) | {k['reference_1e-8']['median']:.3f} s | "
         f"{1 / k['reference_1e-8']['median']:.2f} | {k['reference_1e-8']['repeats']} |",
         f"| converged reference, rtol {k['converged_rtol']:g} | "
         f"{k['converged_seconds']:.3f} s | | 1 |", ""]
    for r in k.get("converged_rejected", []):
        L.append(f"- not taken as converged: rtol {r['rtol']:g} ({r['why']})")
    L += ["",
         f"Speed ratio kernel (warm) / reference at rtol 1e-8: **{k['speedup']:.0f}x** "
         f"(target {TARGET_SPEEDUP:.0f}x: {_yes(k['met_speedup'])}). "
         f"Rate: **{k['rate_warm']:.0f} analyses/s/core** (target {TARGET_RATE:.0f}: "
         f"{_yes(k['met_rate'])}); {k['us_per_event']:.1f} us per event.", "",
         "Errors against the converged reference (max relative error over the peak outputs):",
         "", "| output | kernel vs converged | kernel self-check (dt/2) | reference 1e-8 vs "
         "converged | reference 1e-8 vs kernel |", "|---|---|---|---|---|"]
    cols = ("error_kernel", "kernel_self_check", "error_reference_1e-8",
            "reference_1e-8_vs_kernel")
    for name in PEAKS:
        L.append(f"| {name} | " + " | ".join(_f(k[c]["each"][name]) for c in cols) + " |")
    L.append("| **max** | " + " | ".join(f"**{_f(k[c]['max'])}**" for c in cols) + " |")
    L.append("")
    L.append(f"Smaller error than the reference at rtol 1e-8: {_error_word(k)}. The kernel's "
             "distance from the converged reference cannot show below that reference's own "
             "error, so the kernel is also checked against itself: the same piecewise-linear "
             "ground motion resampled at dt/2 must give the same continuous-time peaks. The "
             "resolution is the larger of the two; the reference is judged by its distance "
             "from both the converged reference and the kernel.")
    if k["met_error"] is False:
        L.append(f" The kernel and the converged reference disagree in "
                 f"`{k['error_kernel']['worst']}` by {_f(k['error_kernel']['max'])} "
                 f"(events {k['events']} vs {k['converged_events']}): they do not resolve the "
                 f"same events, which is a correctness question for the kernel or the "
                 f"reference, not a tolerance effect.")
    L.append("")
    p = k.get("profile")
    if p:
        L += [f"Profile of the Python layer (cProfile, {p['analyses']} warm analyses; "
              f"`kernel.run` {p['total_us']:.0f} us per analysis under the profiler):", "",
              "| function | calls/analysis | own us/analysis | cumulative us/analysis |",
              "|---|---|---|---|"]
        for r in p["top"]:
            L.append(f"| `{r['function']}` | {r['calls']:.3g} | {r['own_us']:.1f} | "
                     f"{r['cumulative_us']:.1f} |")
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
    return L


def _render_wp(w: dict, figures_dir: str) -> list[str]:
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
         "the cross-check of the two.", "",
         "| wall | record | events | kernel time | kernel error | reference | "
         + " | ".join(f"rtol {r:.0e}" for r in w["rtols"]) + " |",
         "|---|---|---|---|---|---|" + "---|" * len(w["rtols"])]
    for c in w["cases"]:
        for i, (sname, series) in enumerate(_series(c).items()):
            cells = [f"{_f(r.get('error'), 2)} / {r['seconds']:.2g} s" for r in series]
            head = (f"| {c['wall']} | {c['record']} | {c['events']} ({c['status']}) | "
                    f"{1e3 * c['kernel_seconds']:.2f} ms | {_f(c['kernel_error'], 2)} |"
                    if i == 0 else "| | | | | |")
            L.append(f"{head} {sname} | " + " | ".join(cells) + " |")
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


def _linear(fit: dict) -> bool:
    """Time linear in record length: a straight-line fit with R2 >= 0.98 and a log-log
    slope within 15 % of 1."""
    return fit["r2"] >= 0.98 and 0.85 <= fit["loglog_slope"] <= 1.15


def _render_cost(c: dict, figures_dir: str) -> list[str]:
    f = c["length_fit"]
    L = ["## Cost growth", "",
         f"Benchmark wall, {c['record']} x 0.5 (El Centro repeated end to end to the length).",
         "", "| record length [s] | time per analysis [ms] | events | us per event | "
         "us per record step | status |", "|---|---|---|---|---|---|"]
    for r in c["by_length"]:
        steps = r["length"] / c.get("dt", 0.02)
        L.append(f"| {r['length']:g} | {1e3 * r['seconds']:.3f} | {r['events']} | "
                 f"{1e6 * r['seconds'] / max(r['events'], 1):.2f} | "
                 f"{1e6 * r['seconds'] / steps:.2f} | {r['status']} |")
    lin = _linear(f)
    L += ["", f"Linear fit: {1e3 * f['slope']:.4g} ms per second of record + "
          f"{1e3 * f['intercept']:.3g} ms, R2 = {f['r2']:.4f}; log-log slope "
          f"{f['loglog_slope']:.3f} (1 = linear): linear growth {_yes(lin)}."]
    if not lin:
        L += ["", "**Why linearity is missed:** the time per event (column above) is not "
              "constant as the record grows; a cost per event that rises with the record "
              "length points at work proportional to the record (or to the history so far) "
              "done at every event, not at event location itself."]
    L += ["",
          "| scale factor | events | time per analysis [ms] | us per event | status |",
          "|---|---|---|---|---|"]
    for r in c["by_events"]:
        L.append(f"| {r['scale']:g} | {r['events']} | {1e3 * r['seconds']:.3f} | "
                 f"{1e6 * r['seconds'] / max(r['events'], 1):.2f} | {r['status']} |")
    e = c.get("events_fit")
    if e:
        L += ["", f"Against events (runs without collapse): {1e6 * e['slope']:.2f} us per "
              f"event + {1e3 * e['intercept']:.3g} ms, R2 = {e['r2']:.4f}."]
    m = c["memory"]
    L += ["", "Memory per analysis (tracemalloc peak of one `kernel.run`, El Centro x 0.5; "
          "numba's own allocations are not traced, so the history array sizes are listed "
          "too):", "", "| | traced peak | history arrays |", "|---|---|---|",
          f"| scalars only | {m['scalars']['peak_bytes'] / 1024:.1f} KiB | - |",
          f"| with histories | {m['history']['peak_bytes'] / 1024:.1f} KiB | "
          f"{m['history']['history_array_bytes'] / 1024:.1f} KiB |",
          "", f"Cached mode tables of one wall at one dt: {m['mode_tables_bytes'] / 1024:.1f} "
          "KiB (shared by every analysis of that wall).", ""]
    for name in c.get("figures", []):
        L.append(f"![{name}]({figures_dir}/{name})")
    L.append("")
    return L


def _render_grid(g: dict | None, p: dict | None) -> list[str]:
    L = ["## Grid scaling", ""]
    if g:
        L += [f"Grid: {g['grid']} = **{g['analyses']:,} analyses**; record: {g['record']}. "
              f"Run through the study layer (`urmx.study` batches of {g['batch_size']} "
              "analyses, its scheduler code and Dataset assembly; no archive). Worker start-up "
              "and the numba cache load on each worker are excluded (listed apart). Serial, 1 "
              "and 2 workers alternate, medians of the repeats. "
              f"Collapsed share of the grid: {100 * g['collapsed_share']:.0f} %.", "",
              "| scheduler | workers | seconds | analyses/s | efficiency vs serial x workers "
              "| worker CPU / (wall x workers) | start-up [s] |",
              "|---|---|---|---|---|---|---|"]
        serial = g["runs"][0]["rate"]
        for r in g["runs"]:
            L.append(f"| {r['scheduler']} | {r['workers']} | {r['seconds']:.2f} | "
                     f"{r['rate']:.0f} | {r['rate'] / (serial * r['workers']):.2f} | "
                     f"{_f(r.get('cpu_share'), 2)} | {_f(r.get('startup'))} |")
        b = g["big"]
        L += ["", f"2 workers over 1: **{g['scaling']:.2f}x** (target {TARGET_SCALING}x: "
              f"{_yes(g['met_scaling'])}).", ""]
        bb = g.get("batches")
        if bb:
            L += [f"Batches: {bb['count']} (the study layer's batches: one diaphragm and a "
                  "group of walls over every COR and scale; one wall's cells are never split, "
                  "so here a batch is one wall on one diaphragm), serial time "
                  f"{bb['total']:.2f} s, largest {bb['largest']:.2f} s, median "
                  f"{bb['median']:.3f} s; the best 2 workers can do with these batches "
                  f"(handed out in order to the free worker) is "
                  f"**{bb['best_speedup_2']:.2f}x**.", ""]
        L += [
              f"Issue 4's synthetic grid ({b['grid']} = {b['analyses']:,} analyses, same "
              f"record) on a LocalCluster of 2 worker processes: {b['seconds']:.1f} s, "
              f"**{b['rate']:.0f} analyses/s** (target {TARGET_GRID_RATE:.0f}: "
              f"{_yes(g['met_big'])}).", ""]
        if not (g["met_scaling"] and g["met_big"]):
            L += ["**Why a grid target is missed:** the efficiency column compares each run "
                  "with the in-process (serial) rate times the workers. An efficiency well "
                  "below 1 on 1 worker is the scheduler's per-batch cost (task submission, "
                  "pickling, result transfer); on 2 workers it also includes the second core "
                  "being shared with other processes (see the load average of the run). The "
                  "CPU column tells the two apart: the CPU seconds the workers used over the "
                  "wall time times the workers; well below 1 means the workers were waiting, "
                  "for the scheduler or for a core other processes held. Unequal batches "
                  "cap the speed-up too (the best speed-up with these batches, above). The "
                  "client and scheduler also run on the same 2 cores. A serial rate below "
                  "the target alone means the kernel itself is too slow for this record.", ""]
    if p:
        L += [f"`urmx paper` end to end from a cold start (a fresh process: imports, numba "
              f"cache, a new LocalCluster, three studies, the reports): **{p['seconds']:.1f} s**"
              f", exit code {p['returncode']} (target < {TARGET_PAPER:.0f} s: "
              f"{_yes(p['met'])}).", ""]
        if p["returncode"]:
            L += ["```", p["stderr_tail"], "```", ""]
    return L


def _render_hard(h: dict) -> list[str]:
    L = ["## Hard cases (MODEL.md section 10)", "",
         f"Agreement: max relative difference of the peak outputs, kernel vs the reference at "
         f"rtol {h['reference_rtol']:g}.", "",
         "| case | kernel time [ms] | events (kernel / reference) | reference time [s] | "
         "agreement | check | value | ok |", "|---|---|---|---|---|---|---|---|"]
    for r in h["rows"]:
        ev = f"{r.get('events', '-')} / {r.get('reference_events', '-')}"
        v = r["value"]
        v = _f(v) if isinstance(v, float) else v
        L.append(f"| {r['case']} | {_f(r.get('kernel_ms'))} | {ev} | "
                 f"{_f(r.get('reference_s'))} | {_f(r.get('agreement'), 2)} | {r['check']} | "
                 f"{v} | {'yes' if r['ok'] else '**no**'} |")
    L.append("")
    return L


def _render_guard(g: dict) -> list[str]:
    b = g.get("baseline")
    L = ["## Regression guard", "",
         f"`urmx bench guard` (CI, < 30 s): the benchmark wall under El Centro x 0.5, "
         f"{g['samples']} samples; fails when the kernel is more than {GUARD_SLOWDOWN:g}x "
         f"slower than the stored figure of its machine class (`benchmarks/baseline.toml`) "
         f"or its max relative peak error vs the reference at rtol 1e-11 exceeds "
         f"{GUARD_ERROR:g}. With a cold numba cache (a fresh install) the first call "
         "compiles the kernel (about 40 s on this machine), so CI runs the guard after the "
         "test suite, which fills the cache.", "",
         f"Measured: {1e3 * g['seconds']:.3f} ms per analysis (first call "
         f"{g.get('first_call', 0):.2f} s), error {_f(g['error'])} "
         f"(`{g['worst']}`), events {g['events']} (reference {g['reference_events']}); "
         f"stored: {('%.3f ms' % (1e3 * b['seconds'])) if b else 'none for this class'}; "
         f"{g['guard_seconds']:.1f} s; **{'PASS' if g['passed'] else 'FAIL'}**.", ""]
    L += [f"- {m}" for m in g["messages"]]
    return L + [""]


def write_report(out: str | os.PathLike) -> Path:
    """Render every saved section next to `out` into `out` (Markdown)."""
    out = Path(out)
    folder = out.with_suffix("")
    text = render(load_sections(folder), folder.name)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text, encoding="utf-8")
    return out


def run_sections(names: list[str], out: str | os.PathLike = "reports/performance.md",
                 quick: bool = False, echo: Callable[[str], None] = print,
                 window: float | None = 20.0) -> Path:
    """Run benchmark sections, save each as JSON in ``<out without .md>/`` and rewrite the
    report from every saved section (sections not run keep their last measurement).
    `window`: seconds of each record in the work-precision study (None: whole records)."""
    out = Path(out)
    folder = out.with_suffix("")
    for name in names:
        t = time.perf_counter()
        echo(f"urmx bench: {name} ...")
        if name == "kernel":
            data = bench_kernel(quick)
        elif name == "work_precision":
            data = work_precision(quick, window=window, figures=folder, echo=echo)
        elif name == "cost_growth":
            data = cost_growth(quick, figures=folder)
        elif name == "grid_scaling":
            data = grid_scaling(quick)
        elif name == "paper":
            data = paper_timing()
        elif name == "hard_cases":
            data = hard_cases(quick)
        elif name == "guard":
            data = guard(quick=quick, echo=echo)
        else:
            raise ValueError(f"unknown benchmark section {name!r} (known: {', '.join(SECTIONS)})")
        save_section(folder, name, data, machine_info(), quick)
        echo(f"urmx bench: {name} done in {time.perf_counter() - t:.1f} s")
        write_report(out)
    return write_report(out)
