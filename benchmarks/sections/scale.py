"""Scale: a study of about 10^6 analyses on the real kernel, run as a user runs one
(`urmx.run_study` into an archive, on a local cluster of 2 worker processes, the record a
file read through its own manifest), with the memory of every process sampled over the run,
the archive's size, and the expected time of a 10^8-analysis building-stock study on a
cluster of N workers.

The grid: the 9 parametric walls x D1-D5 (single storey) x one synthetic record (5 s at
0.01 s) x 148 CORs x 150 scale factors = 999,000 analyses, ``batch_size`` 256: 6,660
batches of 150 analyses (the 150 scales whole, one COR each: the cut takes the innermost
dimensions whole while they fit). Not part of ``all`` (about 8-10 minutes on 2 shared
cores); ``urmx bench scale`` (``--quick``: 4,500 analyses, to check the machinery).
"""

from __future__ import annotations

import os
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

from urmx.markdown import table

from ..common import fmt, save_figure, synthetic_record, verdict

IN_ALL = False
BATCH = 256
SAMPLE = 0.5  # seconds between memory samples
FLAT_MB = 64.0  # bound on the main process's growth over the computation [MB]
WRITE_MB = 128.0  # bound on what the archive's writing adds to the main process [MB]
CLUSTERS = (16, 64, 256, 1024)
BIG = 1e8  # analyses of the building-stock study projected


def _load() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


def _records(folder: Path) -> None:
    """The synthetic record as a PEER AT2 file (g) with the folder's manifest."""
    from urmx.records.manifest import index, write_manifest

    acc = synthetic_record(5.0, 0.01) / 9.80665
    rows = [" ".join(f"{v: .7E}" for v in acc[i:i + 5]) for i in range(0, len(acc), 5)]
    (folder / "synthetic.AT2").write_text(
        "PEER NGA STRONG MOTION DATABASE RECORD\nurmx scale benchmark: 2 Hz sine, triangular "
        "envelope, PGA 3 m s-2\nACCELERATION TIME SERIES IN UNITS OF G\n"
        f"NPTS= {len(acc):5d}, DT= .0100 SEC\n" + "\n".join(rows) + "\n")
    entries, _ = index(folder, pattern="*.AT2")
    write_manifest(entries, folder / "manifest.toml")


def _study(folder: Path, n_cor: int, n_scale: int) -> Path:
    cor = [round(float(c), 6) for c in np.linspace(0.60, 0.95, n_cor)]
    scale = [round(float(s), 6) for s in np.linspace(0.2, 1.2, n_scale)]
    path = folder / "scale.toml"
    path.write_text(f'[study]\nname = "scale"\nwalls = "parametric"\n'
                    f'diaphragms = ["D1", "D2", "D3", "D4", "D5"]\nsupports = "top"\n'
                    f'records = ["synthetic"]\ncor = {cor}\nscale = {scale}\n')
    return path


class Sampler:
    """RSS of this process and of every process it started, every `SAMPLE` seconds."""

    def __init__(self):
        import psutil

        self.proc, self.rows, self.names = psutil.Process(), [], {}
        self.t0, self.stop = time.perf_counter(), threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        import psutil

        while not self.stop.is_set():
            row = {"t": time.perf_counter() - self.t0, "main": self.proc.memory_info().rss}
            for child in self.proc.children(recursive=True):
                try:
                    row[child.pid] = child.memory_info().rss
                    if child.pid not in self.names:
                        cmd = " ".join(child.cmdline())
                        self.names[child.pid] = "resource tracker" \
                            if "resource_tracker" in cmd else "worker"
                except psutil.Error:
                    continue
            self.rows.append(row)
            self.stop.wait(SAMPLE)

    def now(self) -> float:
        return time.perf_counter() - self.t0

    def __enter__(self) -> Sampler:
        self.thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self.stop.set()
        self.thread.join()


def _series(sampler: Sampler) -> dict[str, list]:
    """Time and RSS [MB] of the main process and of each child, by role."""
    t = [r["t"] for r in sampler.rows]
    out: dict[str, list] = {"t": t, "main": [r["main"] / 1e6 for r in sampler.rows]}
    roles: dict[str, int] = {}
    for pid, role in sorted(sampler.names.items()):
        roles[role] = roles.get(role, 0) + 1
        out[f"{role} {roles[role]}"] = [r.get(pid, 0) / 1e6 or None for r in sampler.rows]
    return out


def _cluster():
    """A LocalCluster of 2 worker processes as `urmx run` starts one (`urmx.study.engine`:
    its connections keep `MESSAGE_LOG` batches of sent messages)."""
    import dask
    import distributed  # noqa: F401 - its config defaults first

    from urmx.study import local_client
    from urmx.study.engine import MESSAGE_LOG

    with dask.config.set({"distributed.admin.low-level-log-length": MESSAGE_LOG}):
        return local_client(2)


def _timed_run(path: Path, records: Path, out: Path, client: Any, phases: dict) -> Any:
    """`urmx.run_study` with the start of the archive's writing noted in `phases`."""
    from urmx.study import engine

    write, assemble = engine._write, engine._assemble

    def timed(ds, target):
        phases["write"] = time.perf_counter()
        write(ds, target)
        phases["written"] = time.perf_counter()

    def assembled(*args, **kw):
        phases["computed"] = time.perf_counter()
        return assemble(*args, **kw)

    engine._write, engine._assemble = timed, assembled
    try:
        phases["start"] = time.perf_counter()
        engine.run_study(path, out=out, scheduler=client, progress=False, batch_size=BATCH,
                         records_dir=records)
        phases["end"] = time.perf_counter()
    finally:
        engine._write, engine._assemble = write, assemble
    return engine.last_run()


def _memory(series: dict, t_write: float, t_end: float) -> dict:
    """The main process's RSS: at a tenth of the computation, its highest during the
    computation and during the writing, its growth over the computation (a line fit)."""
    t, main = np.array(series["t"]), np.array(series["main"])
    comp = t < t_write
    tenth = t_write * 0.1
    after = comp & (t >= tenth)
    at_tenth = float(main[after][0]) if after.any() else float(main[comp][-1])
    slope = float(np.polyfit(t[after], main[after], 1)[0]) if after.sum() > 2 else 0.0
    workers = {k: max(v for v in vals if v is not None) for k, vals in series.items()
               if k not in ("t", "main") and any(v is not None for v in vals)}
    return {"at_tenth": at_tenth, "compute_max": float(main[comp].max()),
            "compute_growth": float(main[comp].max()) - at_tenth,
            "slope_mb_per_min": 60.0 * slope,
            "write_max": float(main[(t >= t_write) & (t <= t_end)].max())
            if ((t >= t_write) & (t <= t_end)).any() else float(main[-1]),
            "end": float(main[-1]), "children_max": workers}


def run(quick: bool, figures: Path | None = None, echo=print,
        size: tuple[int, int] | None = None) -> dict:
    """Run the grid (`size`: its CORs and scales, default 148 x 150, quick 10 x 10)."""
    from urmx.kernel import warm_up
    from urmx.study import close_client

    n_cor, n_scale = size or ((10, 10) if quick else (148, 150))
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "records").mkdir()
        _records(tmp / "records")
        path = _study(tmp, n_cor, n_scale)
        out = tmp / "scale.nc"
        warm_up()
        client = _cluster()
        try:
            client.run(warm_up)
            phases: dict = {}
            load0 = _load()
            with Sampler() as sampler:
                base = sampler.now()
                time.sleep(2 * SAMPLE)
                stats = _timed_run(path, tmp / "records", out, client, phases)
                time.sleep(2 * SAMPLE)
            load1 = _load()
        finally:
            close_client(client)
        size = out.stat().st_size
    t0 = phases["start"] - sampler.t0 - base
    series = _series(sampler)
    series["t"] = [x - base - t0 for x in series["t"]]
    compute = phases["computed"] - phases["start"]
    write = phases["written"] - phases["computed"]
    total = phases["end"] - phases["start"]
    mem = _memory(series, compute, total)
    data = {
        "grid": f"9 parametric walls x 5 diaphragms (D1-D5, single storey) x 1 record x "
                f"{n_cor} CORs (0.60-0.95) x {n_scale} scales (0.2-1.2)",
        "record": "synthetic, 5 s at 0.01 s (501 samples): a 2 Hz sine under a triangular "
                  "envelope, PGA 3 m s-2, read from a PEER AT2 file with its own manifest",
        "analyses": stats.computed, "cells": stats.runs, "batches": stats.batches,
        "batch_size": BATCH, "workers": 2, "seconds": total, "compute_seconds": compute,
        "write_seconds": write, "rate": stats.computed / compute,
        "rate_end_to_end": stats.computed / total, "archive_bytes": size,
        "bytes_per_cell": size / stats.runs, "load": [load0, load1], "memory": mem,
        "series": {k: v[::max(1, len(v) // 400)] for k, v in series.items()},
        "flat_bound_mb": FLAT_MB, "write_bound_mb": WRITE_MB,
        "met_flat": mem["compute_growth"] <= FLAT_MB,
        "met_write": mem["write_max"] - mem["compute_max"] <= WRITE_MB,
    }
    data["projection"] = _projection(data)
    if figures is not None:
        data["figure"] = _figure(series, compute, figures)
    echo(f"  {stats.computed:,} analyses in {total:.0f} s ({data['rate']:.0f}/s while "
         f"computing), archive {size / 1e6:.1f} MB, main RSS {mem['at_tenth']:.0f} -> "
         f"{mem['compute_max']:.0f} MB (write {mem['write_max']:.0f} MB)")
    return data


def _projection(d: dict) -> list[dict]:
    """Expected hours of a 10^8-analysis study on N workers (module docstring of render)."""
    per_worker = d["rate"] / d["workers"]
    write_rate = d["cells"] / max(d["write_seconds"], 1e-9)
    rows = []
    for n in CLUSTERS:
        compute = BIG / (n * per_worker)
        rows.append({"workers": n, "compute_hours": compute / 3600,
                     "write_hours": BIG / write_rate / 3600,
                     "hours": (compute + BIG / write_rate) / 3600})
    return rows


def _figure(series: dict, t_write: float, folder: Path) -> str:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.5, 3.6))
    ax = fig.add_subplot()
    t = series["t"]
    for k, v in series.items():
        if k == "t":
            continue
        ax.plot(t, [np.nan if x is None else x for x in v], lw=1.4 if k == "main" else 0.9,
                label="main process (client, scheduler, writer)" if k == "main" else k)
    ax.axvline(t_write, color="0.5", ls="--", lw=0.8)
    ax.text(t_write, ax.get_ylim()[1] * 0.97, " archive gathered and written", va="top",
            fontsize=8)
    ax.set_xlabel("time since the run started [s]")
    ax.set_ylabel("RSS [MB]")
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    return save_figure(fig, folder, "scale-memory.png")


def targets(d: dict) -> list[list[str]]:
    m = d["memory"]
    return [[f"main process flat over a {d['analyses']:,}-analysis run (growth <= "
             f"{FLAT_MB:.0f} MB after a tenth)", f"{m['compute_growth']:+.0f} MB",
             verdict(d["met_flat"])]]


def render(d: dict, figures_dir: str = "performance") -> list[str]:
    m = d["memory"]
    L = ["## Scale: a million analyses into one archive", "",
         f"Grid: {d['grid']} = **{d['cells']:,} analyses**; record: {d['record']}. Run as a "
         "user runs a study: `urmx.run_study(study.toml, out=FILE.nc, records_dir=...)` on "
         f"a LocalCluster of {d['workers']} worker processes (started and warmed before the "
         f"clock), `batch_size={d['batch_size']}`: {d['batches']:,} batches of "
         f"{d['analyses'] / d['batches']:.0f} analyses cut over every dimension, each "
         "saved as a part at once; the archive is then written from the parts, slab by "
         "slab. Load average (1, 5, 15 min) before and after: "
         f"{', '.join(map(str, d['load'][0]))} / {', '.join(map(str, d['load'][1]))} "
         "(2 cores, shared with other work: the rates are lower than on an idle machine).", ""]
    L += table(["", "value"], [
        ["analyses", f"{d['analyses']:,}"], ["batches", f"{d['batches']:,}"],
        ["computing [s]", f"{d['compute_seconds']:.1f}"],
        ["gathering and writing the archive [s]", f"{d['write_seconds']:.1f}"],
        ["analyses/s while computing (2 workers)", f"{d['rate']:.0f}"],
        ["analyses/s end to end", f"{d['rate_end_to_end']:.0f}"],
        ["archive size", f"{d['archive_bytes'] / 1e6:.1f} MB ({d['bytes_per_cell']:.1f} "
                         "bytes per analysis, compressed)"],
        ["main process RSS at a tenth of the computation", f"{m['at_tenth']:.0f} MB"],
        ["main process RSS, highest while computing", f"{m['compute_max']:.0f} MB "
         f"({m['compute_growth']:+.0f} MB; line fit {m['slope_mb_per_min']:+.1f} MB/min)"],
        ["main process RSS, highest while writing", f"{m['write_max']:.0f} MB"],
        *[[f"{k} RSS, highest", f"{v:.0f} MB"] for k, v in m["children_max"].items()]])
    L += ["", f"The main process (the client, the dask scheduler of the local cluster and the "
          f"archive's writer): {m['compute_growth']:+.0f} MB from a tenth of the "
          f"computation to its end (bound {d['flat_bound_mb']:.0f} MB: "
          f"{verdict(d['met_flat'])}); writing the archive adds "
          f"{m['write_max'] - m['compute_max']:+.0f} MB at most (bound "
          f"{d['write_bound_mb']:.0f} MB: {verdict(d['met_write'])}). It holds two int32 per "
          "cell (where each result lies) and no result; the results go to part files as "
          "they arrive, and the archive is gathered from them one 2^17-cell slab at a time "
          "with no netCDF chunk cache (each slab is one whole chunk, written once).", ""]
    if d.get("figure"):
        L += [f"![RSS of every process over the run]({figures_dir}/{d['figure']})", ""]
    per_batch = d["analyses"] / d["batches"]
    tasks = d["rate"] / d["workers"] / per_batch
    L += ["**A building-stock study of 10^8 analyses** on a cluster of N workers, from this "
          f"run: each worker computes {d['rate'] / d['workers']:.0f} analyses/s (this run's "
          "rate over its 2 workers), and the main process writes the archive at this run's "
          f"{d['cells'] / max(d['write_seconds'], 1e-9):,.0f} cells/s. Assumed: the same cost "
          "per analysis (a 5 s record at 0.01 s; the cost grows about in proportion to the "
          "record's samples, see *Cost growth*, so a 30 s record costs about 6 times as "
          "much), workers as fast as these cores and never idle (batches of "
          f"{per_batch:.0f} analyses mean {tasks:.1f} tasks per second and worker, "
          f"{tasks * CLUSTERS[-1]:,.0f} per second on {CLUSTERS[-1]:,} workers: one dask "
          "scheduler handles a few thousand, so a cluster that large takes batches of "
          "thousands of analyses), the archive written after the computation by one process, "
          "and the limits raised (`--max-cells 1e8 --max-gb 20`: about "
          f"{BIG * d['bytes_per_cell'] / 1e9:.1f} GB compressed, 13.3 GB uncompressed; the "
          "main process holds 8 bytes per cell, 0.8 GB).", ""]
    L += table(["workers", "computing [h]", "writing [h]", "total [h]"],
               [[r["workers"], fmt(r["compute_hours"]), fmt(r["write_hours"]),
                 fmt(r["hours"])] for r in d["projection"]])
    L.append("")
    return L
