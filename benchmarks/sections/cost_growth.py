"""Cost growth: time per analysis against record length (El Centro tiled) and against the
number of events (scale factors), and memory per analysis with and without histories."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from urmx.markdown import table

from ..common import benchmark_wall, fit_line, load_record, median_time, save_figure, verdict


def run(quick: bool, *, figures: Path | None = None) -> dict:
    """Time against record length and events, memory; the figure goes to `figures`."""
    import tracemalloc

    from urmx import kernel

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
    memory["mode_tables_bytes"] = kernel.tables(wall, dt).nbytes
    out = {
        "wall": "benchmark", "record": "elcentro (tiled)", "dt": dt, "by_length": by_length,
        "length_fit": fit_line([r["length"] for r in by_length],
                               [r["seconds"] for r in by_length]),
        "by_events": by_events,
        "events_fit": fit_line([r["events"] for r in ok], [r["seconds"] for r in ok])
        if len(ok) >= 2 else None,
        "memory": memory, "figures": [],
    }
    if figures is not None:
        out["figures"] = [plot(out, Path(figures))]
    return out


def plot(c: dict, folder: Path) -> str:
    """Time against record length and against events, written to `folder`."""
    fig = Figure(figsize=(9, 3.6))
    a1, a2 = fig.subplots(1, 2)
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
    return save_figure(fig, folder, "cost-growth.png")


def linear(fit: dict) -> bool:
    """Time linear in record length: a straight-line fit with R2 >= 0.98 and a log-log
    slope within 15 % of 1."""
    return fit["r2"] >= 0.98 and 0.85 <= fit["loglog_slope"] <= 1.15


def targets(c: dict) -> list[list[str]]:
    """Rows (target, measured, verdict) of the report's targets table."""
    f = c["length_fit"]
    return [["time per analysis linear in record length",
             f"R2 {f['r2']:.4f}, log-log slope {f['loglog_slope']:.2f}", verdict(linear(f))]]


def render(c: dict, *, figures_dir: str = "performance") -> list[str]:
    """The cost-growth section of the report (figures linked from `figures_dir`)."""
    f = c["length_fit"]
    L = ["## Cost growth", "",
         f"Benchmark wall, {c['record']} x 0.5 (El Centro repeated end to end to the length).",
         ""]
    dt = c.get("dt", 0.02)
    L += table(["record length [s]", "time per analysis [ms]", "events", "us per event",
                "us per record step", "status"],
               [[f"{r['length']:g}", f"{1e3 * r['seconds']:.3f}", r["events"],
                 f"{1e6 * r['seconds'] / max(r['events'], 1):.2f}",
                 f"{1e6 * r['seconds'] / (r['length'] / dt):.2f}", r["status"]]
                for r in c["by_length"]])
    lin = linear(f)
    L += ["", f"Linear fit: {1e3 * f['slope']:.4g} ms per second of record + "
          f"{1e3 * f['intercept']:.3g} ms, R2 = {f['r2']:.4f}; log-log slope "
          f"{f['loglog_slope']:.3f} (1 = linear): linear growth {verdict(lin)}."]
    if not lin:
        L += ["", "**Why linearity is missed:** the time per event (column above) is not "
              "constant as the record grows; a cost per event that rises with the record "
              "length points at work proportional to the record (or to the history so far) "
              "done at every event, not at event location itself."]
    L.append("")
    L += table(["scale factor", "events", "time per analysis [ms]", "us per event", "status"],
               [[f"{r['scale']:g}", r["events"], f"{1e3 * r['seconds']:.3f}",
                 f"{1e6 * r['seconds'] / max(r['events'], 1):.2f}", r["status"]]
                for r in c["by_events"]])
    e = c.get("events_fit")
    if e:
        L += ["", f"Against events (runs without collapse): {1e6 * e['slope']:.2f} us per "
              f"event + {1e3 * e['intercept']:.3g} ms, R2 = {e['r2']:.4f}."]
    m = c["memory"]
    L += ["", "Memory per analysis (tracemalloc peak of one `kernel.run`, El Centro x 0.5; "
          "numba's own allocations are not traced, so the history array sizes are listed "
          "too):", ""]
    L += table(["", "traced peak", "history arrays"], [
        ["scalars only", f"{m['scalars']['peak_bytes'] / 1024:.1f} KiB", "-"],
        ["with histories", f"{m['history']['peak_bytes'] / 1024:.1f} KiB",
         f"{m['history']['history_array_bytes'] / 1024:.1f} KiB"]])
    L += ["", f"Cached mode tables of one wall at one dt: {m['mode_tables_bytes'] / 1024:.1f} "
          "KiB (shared by every analysis of that wall).", ""]
    for name in c.get("figures", []):
        L.append(f"![{name}]({figures_dir}/{name})")
    L.append("")
    return L
