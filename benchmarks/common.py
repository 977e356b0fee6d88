"""What the benchmark sections share: walls, records, the converged reference, the
machine, line fits, number formatting and figures.

The measuring primitives (:func:`median_time`, :func:`rel_error`, `PEAKS`, the benchmark
wall, manifest records) are the regression guard's, `urmx.guard`, so the report and CI
measure the same way.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import platform
import subprocess
import time
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from urmx import Wall
from urmx.guard import (  # noqa: F401 - re-exported for the sections
    PEAKS,
    benchmark_wall,
    cpu_model,
    git_commit,
    load_record,
    machine_class,
    median_time,
    rel_error,
)


class SectionSkipped(Exception):
    """Raised by a section's ``run`` that cannot measure here (an optional package is
    missing): the runner says so in one line and keeps the section's last measurement."""


# the converged reference: the tightest of these that runs and agrees with the next one
CONVERGED_RTOLS = (1e-12, 1e-11, 1e-10)
SELF_CONVERGED = 1e-8  # peaks of two successive tolerances this close: converged


# ---- another commit's source -------------------------------------------------------------

def export_commit(commit: str, where: Path, paths: tuple[str, ...] = ()) -> Path:
    """The files of `commit` (or only `paths` of it) written into folder `where` by ``git
    archive``, to run that commit's code beside this one's; kept if `where` holds an export
    already (with its compiled kernel). No worktree is made, so the repository's
    worktree list is left alone."""
    from urmx.config import project_root

    # (the kernel is urmx/kernel.py up to 0.2.0, the package urmx/kernel/ after)
    if not any((where / "urmx" / k).exists() for k in ("kernel.py", "kernel/__init__.py")):
        where.mkdir(parents=True, exist_ok=True)
        archive = subprocess.run(["git", "archive", commit, *paths], cwd=project_root(),
                                 check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(where)], input=archive, check=True)
    return where


# ---- long-lived worker processes ---------------------------------------------------------

def ask(proc: subprocess.Popen, who: str, line: str) -> dict:
    """Send one request line to a worker process (none when `line` is empty) and read its
    one-line JSON answer; a worker that has ended, before the request (the write meets a
    closed pipe) or during it (no answer), is named as `who` with its exit status (its
    traceback is on stderr)."""
    try:
        if line:
            proc.stdin.write(line + "\n")
            proc.stdin.flush()
        answer = proc.stdout.readline()
    except BrokenPipeError:
        answer = ""
    if not answer:
        raise RuntimeError(f"the {who} ended early (exit {proc.wait(timeout=60)})")
    return json.loads(answer)


# ---- walls and records ------------------------------------------------------------------

def slender12_wall() -> Wall:
    """A parametric wall of slenderness 12 (h = 2.76 m) on diaphragm D3 (21310 kN/m)."""
    return benchmark_wall(height=12 * 0.23, mass=30000.0 * 12 * 0.23 / 4.14,
                          top_stiffness=21310e3)


def table2_walls() -> dict[str, Wall]:
    """The three Table II walls of the catalog, on their own supports."""
    from urmx.catalog import load_catalog

    cat = load_catalog()
    return {k: cat.walls[k].wall for k in ("wall12", "west", "c9")}


def bench_walls() -> dict[str, Wall]:
    """The five walls of the work-precision study: Table II plus two parametric walls."""
    walls = table2_walls()
    walls["benchmark"] = benchmark_wall()
    walls["slender12-D3"] = slender12_wall()
    return walls


def synthetic_record(duration: float = 5.0, dt: float = 0.01, pga: float = 3.0) -> np.ndarray:
    """A short synthetic record: a 2 Hz sine under a triangular envelope peaking at 1/3 of
    the duration, PGA `pga` [m s-2] (deterministic)."""
    t = np.arange(int(round(duration / dt)) + 1) * dt
    env = np.minimum(t / (duration / 3), (duration - t) / (2 * duration / 3))
    ag = np.clip(env, 0, 1) * np.sin(2 * np.pi * 2.0 * t)
    return pga * ag / np.max(np.abs(ag))


# ---- the converged reference ------------------------------------------------------------

def converged_reference(wall: Wall, ag: np.ndarray, dt: float, **kw: Any) -> dict:
    """The converged reference: the tightest `rtol` of `CONVERGED_RTOLS` that runs and agrees
    with the next looser one (same events, peaks to `SELF_CONVERGED`). The result carries
    ``rtol``, ``seconds`` and ``rejected`` (tighter tolerances that did not run or did not
    agree, with why)."""
    from urmx import reference

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


def scalars_only(res: dict) -> dict:
    """The scalar entries of a kernel result (no histories or event log)."""
    return {k: v for k, v in res.items() if isinstance(v, (int, float, str))}


# ---- the machine ------------------------------------------------------------------------

def _ram_gb() -> float:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal"):
                return int(line.split()[1]) / 1024 ** 2
    except OSError:
        pass
    return math.nan


def machine_info() -> dict:
    """CPU, cores, RAM, load, versions, urmx version and commit, date."""
    import dask
    import distributed
    import numba
    import scipy

    from urmx import __version__

    return {
        "cpu": cpu_model(), "cores": os.cpu_count() or 1, "ram_gb": round(_ram_gb(), 1),
        "machine_class": machine_class(),
        "load_average": [round(x, 2) for x in os.getloadavg()] if hasattr(os, "getloadavg")
        else None,
        "python": platform.python_version(), "numpy": np.__version__,
        "numba": numba.__version__, "scipy": scipy.__version__, "dask": dask.__version__,
        "distributed": distributed.__version__, "urmx": __version__, "commit": git_commit(),
        "date": _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat(),
    }


# ---- fits, numbers, figures -------------------------------------------------------------

def fit_line(x, y) -> dict:
    """Least-squares line through (x, y): ``slope``, ``intercept``, ``r2`` and the slope
    of log y against log x (``loglog_slope``, NaN unless all values are positive)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    slope, icpt = np.polyfit(x, y, 1)
    pred = slope * x + icpt
    ss = float(np.sum((y - y.mean()) ** 2))
    r2 = 1.0 - float(np.sum((y - pred) ** 2)) / ss if ss > 0 else 1.0
    loglog = float(np.polyfit(np.log(x), np.log(y), 1)[0]) if np.all(x > 0) and np.all(
        y > 0) else math.nan
    return {"slope": float(slope), "intercept": float(icpt), "r2": r2, "loglog_slope": loglog}


def fmt(x: float | None, digits: int = 3) -> str:
    """A number to `digits` significant digits; ``-`` for None, NaN and inf."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x:.{digits}g}"


def verdict(ok: bool | None) -> str:
    """``**met**``, ``**NOT MET**`` or ``n/a`` (None)."""
    return "n/a" if ok is None else ("**met**" if ok else "**NOT MET**")


def save_figure(fig: Figure, folder: Path, name: str, dpi: int = 90) -> str:
    """Write `fig` as `folder`/`name` (PNG); returns `name`."""
    folder.mkdir(parents=True, exist_ok=True)
    fig.savefig(folder / name, dpi=dpi)
    return name
