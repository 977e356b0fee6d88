"""Start-up cost against an earlier kernel, side by side in one run: the cold first
analysis (an empty numba cache in a fresh process: the compile a new install pays), the
warm ``urmx simulate`` of the README (the cache loaded from disk, imports included), and
the steady state of the benchmark analysis, also against a second, later kernel
(`MAIN_COMMIT`, steady state only). The earlier kernels are exported from the repository's
history into a temporary folder (``git archive``, no worktree), so all are measured on the
same machine at the same time: absolute times differ between machines (an AMD and an Intel
host here differ by 1.8x on the same code), ratios much less."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from urmx.config import project_root
from urmx.markdown import table

from .. import compile_time
from ..common import ask, export_commit

IN_ALL = False
BASELINE_COMMIT = "0615fbe"  # the kernel before the held joints and the start-up work
# the kernel before contact functions at zero were searched for their first fall (issue 24)
MAIN_COMMIT = "8b38483"
TARGETS = {"cold": 0.25, "simulate": 0.40, "steady": 0.95, "reference": 5000.0,
           "steady_main": 0.95}
SIMULATE = ["simulate", "catalog/examples/benchmark-wall.toml", "elcentro", "--scale", "0.5"]

_COLD = r"""
import sys, time, json
sys.path.insert(0, sys.argv[1])
import numpy as np
from urmx import kernel, Wall
ag = np.loadtxt(sys.argv[2]).ravel() / 100.0
w = Wall(thickness=0.23, height=4.14, crack_ratio=2 / 3, mass=30000.0, top_mass=20000.0,
         top_stiffness=815e3, top_damping=0.12, pmr=75.0)
t0, c0 = time.perf_counter(), time.process_time()
kernel.run(w, ag, 0.02, scale=0.5)
print(json.dumps({"wall": time.perf_counter() - t0, "cpu": time.process_time() - c0}))
"""

# the steady state: a long-lived process per kernel that runs blocks of analyses on demand;
# both processes of a pair are pinned to the same core, so that a block of one kernel and
# the next block of the other meet the same host (a neighbour on the other core, the
# frequency of this one) and their ratio cancels it
_STEADY = r"""
import sys, time, json, os
if hasattr(os, "sched_setaffinity") and int(sys.argv[3]) >= 0:
    os.sched_setaffinity(0, {int(sys.argv[3])})
sys.path.insert(0, sys.argv[1])
import numpy as np
from urmx import kernel, Wall
ag = np.loadtxt(sys.argv[2]).ravel() / 100.0
w = Wall(thickness=0.23, height=4.14, crack_ratio=2 / 3, mass=30000.0, top_mass=20000.0,
         top_stiffness=815e3, top_damping=0.12, pmr=75.0)
for _ in range(20):
    kernel.run(w, ag, 0.02, scale=0.5)
print("ready", flush=True)
for line in sys.stdin:
    ts = []
    for _ in range(int(line)):
        t = time.perf_counter()
        kernel.run(w, ag, 0.02, scale=0.5)
        ts.append(time.perf_counter() - t)
    ts.sort()
    print(json.dumps({"min": ts[0], "median": ts[len(ts) // 2]}), flush=True)
"""
#: analyses per block, blocks per kernel and pair, and process pairs (full run; quick: 1/4)
BLOCK, ROUNDS, PAIRS = 20, 40, 6


def _block(proc: subprocess.Popen, name: str, n: int) -> dict:
    """One block of n analyses from the steady-state process of kernel `name`: its
    {"min", "median"} (`benchmarks.common.ask`: a process that has ended is named with its
    exit status)."""
    return ask(proc, f"steady-state process of {name}", str(n))


def _steady(trees: dict, record: str, quick: bool, echo) -> dict:
    """Blocks of the benchmark analysis alternating between the kernels' processes (one
    per kernel, all pinned to one core), set by set; returns each kernel's blocks
    ({"min", "median"} per block) in round order."""
    out: dict = {name: [] for name in trees}
    pairs, rounds = (2, 10) if quick else (PAIRS, ROUNDS)
    cores = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else []
    for p in range(pairs):
        core = cores[p % len(cores)] if cores else -1  # (-1: not pinned)
        procs = {name: subprocess.Popen(
            [sys.executable, "-c", _STEADY, str(tree), record, str(core)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True) for name, tree in
            trees.items()}
        try:
            for proc in procs.values():
                if proc.stdout.readline().strip() != "ready":
                    raise RuntimeError("a steady-state process did not start")
            names = list(trees)
            for r in range(rounds):
                for name in (names if r % 2 == 0 else names[::-1]):
                    out[name].append(_block(procs[name], name, BLOCK))
        finally:
            for proc in procs.values():
                with contextlib.suppress(BrokenPipeError):  # (a process that has ended)
                    proc.stdin.close()
                proc.wait(timeout=60)
        echo(f"startup: steady set {p + 1}/{pairs} on core {core}")
    return out


_CLI = ("import sys; sys.path.insert(0, sys.argv.pop(1)); from urmx.cli import main; "
        "sys.exit(main())")


def _json(args: list[str], env: dict | None = None) -> dict:
    out = subprocess.run([sys.executable, *args], capture_output=True, text=True, env=env,
                         timeout=3600)
    if out.returncode:
        raise RuntimeError(out.stderr[-800:])
    return json.loads(out.stdout.strip().splitlines()[-1])


def run(quick: bool, echo=print) -> dict:
    from urmx import kernel, reference
    from urmx.guard import benchmark_wall, load_record, median_time

    root = project_root()
    record = str(Path(os.environ.get("URMX_RECORDS", "")) / "elcentro1940"
                 / "elcentro_S00E_1940.dat")
    rounds = 1 if quick else 2
    tmp = Path(tempfile.mkdtemp(prefix="urmx-startup-"))
    base = export_commit(BASELINE_COMMIT, tmp / "baseline")
    main = export_commit(MAIN_COMMIT, tmp / "main")
    trees = {"now": root, "baseline": base}
    res: dict = {k: {"cold": [], "simulate": [], "steady": []} for k in [*trees, "main"]}
    try:
        for _ in range(rounds):  # cold first analysis, alternating
            for name, tree in trees.items():
                with tempfile.TemporaryDirectory() as cache:
                    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
                    res[name]["cold"].append(_json(["-c", _COLD, str(tree), record], env))
                echo(f"startup: cold {name} {res[name]['cold'][-1]}")
        for tree in [*trees.values(), main]:  # fill each tree's cache before warm runs
            subprocess.run([sys.executable, "-c", _CLI, str(tree), *SIMULATE], cwd=tree,
                           capture_output=True, timeout=3600)
        for _ in range(3 if quick else 7):  # warm `urmx simulate`, alternating
            for name, tree in trees.items():
                t = time.perf_counter()
                out = subprocess.run([sys.executable, "-c", _CLI, str(tree), *SIMULATE],
                                     cwd=tree, capture_output=True, text=True, timeout=600)
                res[name]["simulate"].append(time.perf_counter() - t)
                if out.returncode:
                    raise RuntimeError(out.stderr[-800:])
        steady = _steady({**trees, "main": main}, record, quick, echo)
        for name in res:
            res[name]["steady"] = steady[name]
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    wall = benchmark_wall()
    ag, dt, sf = load_record("elcentro")
    k = median_time(lambda: kernel.run(wall, ag, dt, scale=sf), repeat=5, min_time=1.0)
    r = median_time(lambda: reference.run(wall, ag, dt, scale=sf, rtol=1e-8), repeat=1)
    now, old, last = res["now"], res["baseline"], res["main"]
    out = {
        "baseline_commit": BASELINE_COMMIT, "main_commit": MAIN_COMMIT, "rounds": rounds,
        "raw": res,
        "steady_pairs": 2 if quick else PAIRS,
        "cold": {"now": min(x["wall"] for x in now["cold"]),
                 "baseline": min(x["wall"] for x in old["cold"])},
        "simulate": {"now": statistics.median(now["simulate"]),
                     "baseline": statistics.median(old["simulate"])},
        "steady": {"now": min(x["min"] for x in now["steady"]),
                   "baseline": min(x["min"] for x in old["steady"]),
                   "now_median": statistics.median(x["median"] for x in now["steady"]),
                   "baseline_median": statistics.median(x["median"] for x in old["steady"])},
        "reference": {"kernel": k["median"], "reference": r["median"],
                      "speedup": r["median"] / k["median"]},
    }
    out["ratios"] = {
        "cold": out["cold"]["now"] / out["cold"]["baseline"],
        "simulate": out["simulate"]["now"] / out["simulate"]["baseline"],
        "steady": out["steady"]["baseline"] / out["steady"]["now"],
        "steady_median": out["steady"]["baseline_median"] / out["steady"]["now_median"],
        # each round's two blocks ran back to back on one core: their ratio cancels the
        # host's drifts
        "steady_rounds": _rounds(now["steady"], old["steady"]),
        "main": min(x["min"] for x in last["steady"]) / min(x["min"] for x in now["steady"]),
        "main_rounds": _rounds(now["steady"], last["steady"]),
    }
    out["first_compile"] = compile_time.run(quick, echo)  # before and after issue 41's work
    echo(f"startup: ratios {out['ratios']}, reference {out['reference']['speedup']:.0f}x; "
         f"{compile_time.headline(out['first_compile'])}")
    return out


def _rounds(now: list, other: list) -> float:
    """Median over rounds of the speed ratio of the round's two blocks (their medians):
    they ran back to back on one core, so the ratio cancels the host's drifts."""
    return statistics.median(b["median"] / n["median"] for n, b in zip(now, other,
                                                                       strict=True))


def targets(d: dict) -> list[list[str]]:
    r = d["ratios"]
    return [
        ["cold first analysis <= 0.25 of the kernel at " + d["baseline_commit"],
         f"{r['cold']:.3f}", "met" if r["cold"] <= TARGETS["cold"] else "missed"],
        ["warm `urmx simulate` <= 0.40 of the kernel at " + d["baseline_commit"],
         f"{r['simulate']:.3f}", "met" if r["simulate"] <= TARGETS["simulate"] else "missed"],
        ["steady state >= 0.95 of the kernel at " + d["baseline_commit"] + " (speed ratio: "
         "median of per-round ratios; of the minima)",
         f"{r.get('steady_rounds', r['steady']):.3f}; {r['steady']:.3f}",
         "met" if min(r.get("steady_rounds", r["steady"]), r["steady"]) >= TARGETS["steady"]
         else "missed"],
        ["steady state >= 5000x the reference at rtol 1e-8",
         f"{d['reference']['speedup']:.0f}x",
         "met" if d["reference"]["speedup"] >= TARGETS["reference"] else "missed"],
    ] + ([[f"steady state >= 0.95 of the kernel at {d['main_commit']} (speed ratio: median "
           "of per-round ratios; of the minima)",
           f"{r['main_rounds']:.3f}; {r['main']:.3f}",
           "met" if min(r["main_rounds"], r["main"]) >= TARGETS["steady_main"]
           else "missed"]] if "main_rounds" in r else [])


def render(d: dict) -> list[str]:
    c, s, t, ref = d["cold"], d["simulate"], d["steady"], d["reference"]
    n_pairs = d.get("steady_pairs", 1)
    n_rounds = len(d["raw"]["now"]["steady"]) // n_pairs
    rows = [
        ["cold first analysis (empty numba cache, fresh process) [s]", f"{c['now']:.1f}",
         f"{c['baseline']:.1f}", f"{d['ratios']['cold']:.3f}"],
        ["warm `urmx " + " ".join(SIMULATE) + "` [s]", f"{s['now']:.2f}",
         f"{s['baseline']:.2f}", f"{d['ratios']['simulate']:.3f}"],
        ["benchmark analysis, steady state, min [ms]", f"{1e3 * t['now']:.3f}",
         f"{1e3 * t['baseline']:.3f}", f"{d['ratios']['steady']:.3f} (speed)"],
        ["benchmark analysis, steady state, median [ms]", f"{1e3 * t['now_median']:.3f}",
         f"{1e3 * t['baseline_median']:.3f}", f"{d['ratios']['steady_median']:.3f} (speed)"],
    ]
    if "steady_rounds" in d["ratios"]:
        rows.append(["benchmark analysis, median over rounds of the per-round speed ratio "
                     "(each round's two blocks back to back on one core)", "", "",
                     f"{d['ratios']['steady_rounds']:.3f} (speed)"])
    main = d.get("main_commit")
    kernels = 3 if main else 2
    lines = [
        f"Measured side by side in one run against the kernel at commit "
        f"`{d['baseline_commit']}`" + (f" and, in the steady state, at `{main}`" if main
                                      else "")
        + " (exported from the repository's history into a temporary folder): cold first "
        f"analyses alternating ({d['rounds']} each, the minimum), warm `urmx simulate` "
        f"alternating (median); steady state: {n_pairs} sets of {kernels} long-lived "
        f"processes (one per kernel, all pinned to the same core, a set per core in turn), "
        f"each set running {n_rounds} rounds of a block of {BLOCK} analyses per kernel, back "
        f"to back in alternating order; the minimum over all analyses, the median of the "
        f"block medians, and the median over rounds of the ratio of the round's two block "
        f"medians.",
        "",
        *table(["", "now", d["baseline_commit"], "ratio"], rows),
        "",
    ]
    if main:
        m = d["raw"]["main"]["steady"]
        m_min = min(x["min"] for x in m)
        m_med = statistics.median(x["median"] for x in m)
        lines += [
            f"Against `{main}` (the kernel before contact functions at zero were searched "
            f"for their first fall, issue 24), in the same sets:",
            "",
            *table(["", "now", main, "ratio"], [
                ["benchmark analysis, steady state, min [ms]", f"{1e3 * t['now']:.3f}",
                 f"{1e3 * m_min:.3f}", f"{d['ratios']['main']:.3f} (speed)"],
                ["benchmark analysis, steady state, median [ms]",
                 f"{1e3 * t['now_median']:.3f}", f"{1e3 * m_med:.3f}",
                 f"{m_med / t['now_median']:.3f} (speed)"],
                ["benchmark analysis, median over rounds of the per-round speed ratio", "",
                 "", f"{d['ratios']['main_rounds']:.3f} (speed)"]]),
            "",
            *COUNTS,
            "",
        ]
    return [
        *lines,
        *(compile_time.render(d["first_compile"]) if "first_compile" in d else []),
        f"The benchmark analysis takes {1e3 * ref['kernel']:.3f} ms against "
        f"{ref['reference']:.2f} s for the scipy reference at rtol 1e-8: "
        f"{ref['speedup']:.0f}x.",
        "",
        *CHOICES,
    ]


#: instructions per analysis counted by cachegrind (not by this section: valgrind runs
#: the kernel about 50x slower), before and after issue 24's search
COUNTS = [
    "Counted, not timed (valgrind's cachegrind; the machine was shared and noisy): per "
    "benchmark analysis, as the difference between 81 analyses and 1 in one process, both "
    "kernels compiled for the CPU valgrind presents (haswell) outside valgrind and stored "
    "under the key valgrind computes, OpenBLAS single-threaded (its spinning threads had "
    "made the counts vary by 8 %), `PYTHONHASHSEED=0`, two runs each (they agree to "
    "0.03 %). The kernel at `8b38483`: 6.81 M instructions, 2.40 M data reads, 0.75 M data "
    "writes, 15.7 k L1 instruction misses. This kernel: 7.19 M (+5.6 %), 2.54 M, 0.77 M, "
    "24.3 k. Of the difference, the test that settles most functions at zero (c1 > "
    "sum |c_j|, four partial sums: 629 functions in the 592 events of this analysis) and "
    "its bookkeeping take about 0.31 M, the full search (polynomial, concavity, geometric "
    "scan: 21 functions) 0.07 M. The first version of the search (every function "
    "classified on every sub-step) took 7.82-7.94 M, 47-50 k instruction misses and ran at "
    "0.86-0.90 of `8b38483`'s speed; a serial sum in the test alone cost 10 % of the time "
    "for 1 % of the instructions.",
]

#: what each compile-time choice bought, measured when it was made (on this machine, cold
#: first analysis in a fresh process with an empty cache, and the steady state interleaved
#: with the previous state; the commits say the same)
CHOICES = [
    "What each compile-time choice measured when it was taken (this machine; cold first "
    "analysis in a fresh process with an empty numba cache; steady state interleaved with "
    "the state before the change):",
    "",
    *table(["choice", "cold compile", "steady state", "commit"], [
        ["piece tables (propagators of every held state x family x branch) built in numpy, "
         "not in compiled code; the integration loop called directly instead of through a "
         "wrapper that numba compiled and optimised again", "~90 -> ~25 CPU s",
         "unchanged (tables 2e-15 from the compiled ones)", "a876cd3"],
        ["only the entry points cached on disk (their cached code holds their callees)",
         "less written and loaded", "unchanged", "06cb95f"],
        ["helpers compiled without Python wrappers (`no_cpython_wrapper`; only compiled "
         "code calls them)", "-9 %", "unchanged", "998923d"],
        ["helpers inlined by LLVM (`forceinline`) instead of numba's IR inliner "
         "(`inline='always'`)", "21 -> 14 s", "same (ratio 1.00-1.03)", "869c7c5"],
        ["event-site trackers as a call instead of inlined (tried, reverted)", "-",
         "10 % slower (2 calls per event, 11 array arguments)", "5114605"],
        ["`NUMBA_OPT` lower, loop vectorisation off, `noalias` hints (tried, not taken)",
         "no gain", "no gain or slower", "-"],
        ["the loop as a native object, loaded by llvmlite without numba: a small LLVM shim "
         "reads the loop's arguments from two blocks (array addresses and shapes, scalars) "
         "and calls numba's optimised loop unchanged; no Python wrapper over 51 arrays to "
         "compile (`urmx/native.py`)", "17.8 -> 16.2 s",
         "same (loop call 0.545-0.563 vs 0.539-0.562 ms interleaved; `run()` overhead 11.1 "
         "vs 11.1 us; results bit for bit equal)", "5a1bac9"],
        ["the same with the loop taking the blocks and making its array views itself "
         "(tried, replaced)", "13.3-14.3 s",
         "2-4 % slower (0.566-0.589 ms: the loop grew from 42 to 48 KB, more spills)",
         "ca41fbd"],
        ["the loop behind a numba-compiled wrapper (tried, not taken)",
         "14-18 s", "2-4 % slower (the loop optimised a second time in the wrapper's module)",
         "-"],
        ["the event set-up and the event handler (`active_events`, `handle_event`) inlined "
         "into the loop instead of called: each call passed 11-14 arrays (7-13 words each) "
         "for every event", "18 s",
         "faster (paired 1.047 against the loop before, minima 1.000; cachegrind per "
         "analysis: 6.99 M instructions against 7.04 M, data references 3.17 M against "
         "3.46 M, L1 instruction misses 15.8 k against 18.9 k); results bit for bit equal",
         "189de63"],
        ["the work arrays as views into one 64-byte-aligned buffer instead of one allocation "
         "each (tried, not taken)", "-",
         "no gain (paired 1.011-1.017, minima 0.986-1.000 against the separate arrays)", "-"],
        ["the peak trackers' end values and the test for an interior extremum without a "
         "branch per tracker (tried, not taken)", "-", "no gain (paired 0.988, minima 0.965)",
         "-"],
        ["the Taylor series inlined at its four call sites (tried, not taken)", "17 s",
         "slower (paired 0.960, minima 0.977)", "-"],
        ["`NUMBA_OPT=2`; the loop and SLP vectorisers off (tried, not taken)", "15-17 s",
         "slower (paired 0.955 and 0.950)", "-"],
        ["the tracker, propagator and event-row helpers on padded loops only (one copy "
         "each instead of an n = 2 and a padded one: 119 KB of object code against 122 KB; "
         "tried, not taken)", "17 s", "8 % slower (paired 0.921, minima 0.926)", "-"],
        ["helpers (no Python wrapper) compiled once per argument types instead of once per "
         "literal constant they are called with (`urmx.jitcache`: 93 numba compiles of 53 "
         "functions -> 58; loop object 152 -> 133 KB); issue 41", "CPU 19.5-20.9 -> "
         "13.8-16.0 s (load 3.5-4.2)", "same (paired 0.983-1.008, median 1.001 over 5 runs "
         "of 6 x 40 rounds; results of 144 analyses, 50,029 events, bit for bit equal)",
         "e979b54, 54637a9"],
        ["the shim added to the loop's module before numba optimises and compiles it, and "
         "the object numba's JIT makes of it kept (`urmx.native._compile_with_shim`): one "
         "code generation of the whole loop instead of two; object 133 -> 130 KB; issue 41",
         "about -1 s", "same (paired 1.001, 0.989, 1.009; minima 1.008, 0.996, 1.011; "
         "results bit for bit equal)", "f04b891, 4edd446"],
        ["no machine code for the helpers' numba libraries during the native compile (only "
         "their optimised IR, which the loop links in; tried, not taken)",
         "a further -1.5 to -2 s CPU", "5-14 % slower (paired 0.86-0.95: MCJIT's code "
         "generation rewrites a library's IR in place before its callers link it in, and "
         "the loop was optimised from the other IR)", "-"],
        ["no module-level optimisation of a forceinline helper's own library (its IR is "
         "optimised again once inlined; tried, not taken)", "about -1 s CPU",
         "paired 0.973 and 0.986, minima 1.004-1.006", "-"],
    ]),
    "",
    "Where the steady state lost on a busy host. Before the event path was inlined (at "
    "`8b1e74c`), the loop was as fast as the kernel at `0615fbe` on a quiet core (the "
    "minima within 5 % in every run that day), but its medians fell 5-10 % behind when the "
    "host was busy. Counted by valgrind's cachegrind (both kernels compiled for the CPU "
    "valgrind presents, haswell, through `NUMBA_CPU_NAME`/`NUMBA_CPU_FEATURES`; one "
    "analysis counted as the difference "
    "between 81 and 1 analyses in one process, `PYTHONHASHSEED=0`, two runs each), the loop "
    "executed 7-11 % more instructions than the earlier kernel (7.03-7.05 M per analysis "
    "against 6.32-6.57 M; data references 3.46 M against 3.37-3.41 M; L1 data misses "
    "3.9-4.1 k against 4.0-4.2 k) and missed the L1 instruction cache 50 % more often "
    "(18.9 k against 12.4-12.6 k). By function (callgrind, per analysis): the loop with its "
    "inlined helpers 5.06 M instructions, the Taylor series 1.08 M, the root finder 0.41 M, "
    "the event set-up after each of the 592 events 0.31 M (about 530 instructions each) and "
    "the event handler 0.18 M. Both excesses likely come from the held joints' generality spread "
    "over the event path (release rows, held-state geometry) and from more code (75 KB of "
    "loop and helpers); an instruction-cache miss costs little on a quiet core and more "
    "when another tenant fills the shared caches, the likely reason why the medians lagged "
    "more than the minima. Shrinking the code by giving up the n = 2 loops cost more than "
    "it saved. Inlining the event set-up and handler brought the data references to "
    "3.17 M (below the earlier kernel's), the instruction misses to 15.8 k and the "
    "instructions to 6.99 M (still 6-11 % more); the run above meets the target with it.",
    "",
    "A warm `urmx simulate` no longer imports numba: before, every process paid importing "
    "numba (0.15-0.35 s here) and numba's refresh of its target context when it loads the "
    "first function from its cache (0.45-0.65 s, which imports `scipy.linalg.cython_blas` "
    "through `numba.np.arraymath`), before any urmx code ran. Now it imports llvmlite's "
    "binding (about 0.06 s) and loads the loop's object code (about 5 ms).",
]
