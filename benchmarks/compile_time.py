"""The kernel's first compile before and after issue 41's compile work, side by side.

Part of the start-up section (:mod:`benchmarks.sections.startup` runs it and renders its
lines); ``python -m benchmarks.compile_time [RUNS]`` runs it alone and prints them.

A cold first analysis is the benchmark analysis (El Centro x 0.5) in a fresh process with
an empty cache folder (``NUMBA_CACHE_DIR`` set to a new temporary folder, which
:mod:`urmx.jitcache` and :mod:`urmx.native` honour): numba's import, the compile of the
loop and its helpers, the native object's emission and the analysis. The tree before
(`BEFORE_COMMIT`, exported from the repository's history) and this one alternate, run after
run, under ``nice -n 10``; each run reports its wall time and the CPU time of its process
(the CPU time moves less with the host's load; on a shared machine the wall time is what a
user waits, the CPU time what the compile costs), the numba compiles it made (one per
function and argument types) and the load average when it started.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from urmx.markdown import table

from .common import export_commit

#: the tree before the helpers compiled one version per argument type and the loop was
#: compiled to machine code once
BEFORE_COMMIT = "d3f270d"
RUNS, QUICK_RUNS = 5, 2

_COLD = r"""
import sys, time, json
sys.path.insert(0, sys.argv[1])
t0, c0 = time.perf_counter(), time.process_time()
import numpy as np
from urmx import kernel, Wall, jitcache
jitcache.materialize()  # numba imported: count its compiles
from numba.core import dispatcher
names = []
compile_extra = dispatcher.compiler.compile_extra
def counted(typingctx, targetctx, func, *args, **kws):
    names.append(func.__qualname__)
    return compile_extra(typingctx, targetctx, func, *args, **kws)
dispatcher.compiler.compile_extra = counted
ag = np.loadtxt(sys.argv[2]).ravel() / 100.0
w = Wall(thickness=0.23, height=4.14, crack_ratio=2 / 3, mass=30000.0, top_mass=20000.0,
         top_stiffness=815e3, top_damping=0.12, pmr=75.0)
res = kernel.run(w, ag, 0.02, scale=0.5)
print(json.dumps({"wall": time.perf_counter() - t0, "cpu": time.process_time() - c0,
                  "compiles": len(names), "functions": len(set(names)),
                  "peaks": [res[k] for k in sorted(res) if k.startswith("peak_")]}))
"""


def _cold(tree: Path, record: str) -> dict:
    """One cold first analysis of the tree's kernel in a fresh process and cache folder."""
    with tempfile.TemporaryDirectory(prefix="urmx-cold-") as cache:
        load = os.getloadavg()[0]
        out = subprocess.run(["nice", "-n", "10", sys.executable, "-c", _COLD, str(tree),
                              record], capture_output=True, text=True, timeout=3600,
                             env=dict(os.environ, NUMBA_CACHE_DIR=cache), cwd=cache)
    if out.returncode:
        raise RuntimeError(out.stderr[-800:])
    return {**json.loads(out.stdout.strip().splitlines()[-1]), "load": load}


def run(quick: bool = False, echo=print, runs: int | None = None) -> dict:
    """Alternating cold first analyses of the tree at `BEFORE_COMMIT` and this one
    (`runs` each; `QUICK_RUNS` when quick, else `RUNS`)."""
    from urmx.config import project_root

    runs = runs or (QUICK_RUNS if quick else RUNS)
    record = str(Path(os.environ.get("URMX_RECORDS", "")) / "elcentro1940"
                 / "elcentro_S00E_1940.dat")
    with tempfile.TemporaryDirectory(prefix="urmx-compile-") as tmp:
        trees = {"before": export_commit(BEFORE_COMMIT, Path(tmp) / "before"),
                 "after": project_root()}
        raw: dict = {name: [] for name in trees}
        for i in range(runs):
            for name in (trees if i % 2 == 0 else list(trees)[::-1]):
                raw[name].append(_cold(trees[name], record))
                echo(f"compile time: {name} run {i + 1}/{runs}: "
                     f"{raw[name][-1]['wall']:.1f} s wall, {raw[name][-1]['cpu']:.1f} s CPU")
    out = {"before_commit": BEFORE_COMMIT, "runs": runs, "raw": raw}
    for name, rows in raw.items():
        out[name] = {k: statistics.median(r[k] for r in rows) for k in ("wall", "cpu")}
        out[name]["compiles"] = rows[-1]["compiles"]
        out[name]["functions"] = rows[-1]["functions"]
    loads = [r["load"] for rows in raw.values() for r in rows]
    out["load"] = [min(loads), max(loads)]
    # the same peaks (bit for bit) from both kernels' first analysis
    out["same_peaks"] = all(r["peaks"] == raw["before"][0]["peaks"]
                            for rows in raw.values() for r in rows)
    return out


def headline(d: dict) -> str:
    """``first compile: before X s, after Y s`` (medians of the CPU times)."""
    return (f"first compile: before {d['before']['cpu']:.1f} s, after {d['after']['cpu']:.1f} s "
            f"(CPU; wall {d['before']['wall']:.1f} s and {d['after']['wall']:.1f} s)")


def render(d: dict) -> list[str]:
    b, a = d["before"], d["after"]
    rows = [
        ["CPU time of the process [s]", f"{b['cpu']:.1f}", f"{a['cpu']:.1f}",
         f"{a['cpu'] / b['cpu']:.2f}"],
        ["wall time [s]", f"{b['wall']:.1f}", f"{a['wall']:.1f}", f"{a['wall'] / b['wall']:.2f}"],
        ["numba compiles (functions x argument types)", str(b["compiles"]), str(a["compiles"]),
         ""],
        ["distinct functions compiled", str(b["functions"]), str(a["functions"]), ""],
    ]
    return [
        f"**{headline(d)}.** Cold first analysis (the benchmark analysis in a fresh process "
        f"with an empty cache folder: numba's import, the compile, the native object, the "
        f"analysis), the tree at `{d['before_commit']}` and this one alternating, "
        f"{d['runs']} runs each under `nice -n 10`, medians; load average "
        f"{d['load'][0]:.1f}-{d['load'][1]:.1f} on this machine during the runs. The "
        "helpers that only compiled code calls are compiled once per argument types, not "
        "once per literal constant they are called with (`urmx.jitcache`), and the loop "
        "with its shim is compiled to machine code once, not twice (`urmx.native`), which "
        "took 18.4 s to 13.9 s of CPU on 2026-11-27; the runs of plain steps of capacity "
        "searches added since (two generated functions, about 5 s) live in a second native "
        "object (`march-capacity`), compiled on a first capacity search only, so the first "
        "analysis here does not compile them. "
        "The first analysis' peaks are " + ("bit for bit equal." if d["same_peaks"] else
                                            "**not** equal between the two trees."),
        "",
        *table(["", d["before_commit"], "now", "ratio"], rows),
        "",
    ]


if __name__ == "__main__":
    data = run(runs=int(sys.argv[1]) if len(sys.argv) > 1 else None,
               echo=lambda m: print(m, file=sys.stderr))
    print("\n".join(render(data)))
