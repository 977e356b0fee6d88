"""The kernel regression guard behind ``urmx bench guard`` (run by ``.ci/run``, < 60 s).

:func:`measure` times `urmx.kernel.run` on the benchmark wall under El Centro x 0.5 and
takes its largest relative peak error against the scipy reference; it also times, in
fresh processes, the cold first analysis (an empty numba cache: the compile a new install
pays) and the warm one (the cache loaded from disk). :func:`verdict` fails when the error
exceeds `MAX_ERROR`, the time is `SLOWDOWN` times the figure stored for this machine class
in ``benchmarks/baseline.toml``, or a start-up time is `START_SLOWDOWN` times its figure.
To guard more, add a figure to what :func:`measure` returns and a row to `CHECKS`.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import platform
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .config import checkout, need_checkout
from .model import Wall

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib
from . import kernel

SLOWDOWN, START_SLOWDOWN = 3.0, 2.0  # limits on the kernel's and the start-up slowdown
MAX_ERROR = 1e-9  # ... and on its relative peak error against the reference
REFERENCE_RTOL = 1e-11
BASELINE = Path("benchmarks") / "baseline.toml"  # in the source checkout
# the peak outputs whose error is measured (MODEL.md section 10)
PEAKS = ("peak_crack_displacement", "peak_top_displacement", "peak_base_displacement",
         "peak_lower_drift", "peak_upper_drift", "peak_top_acceleration",
         "peak_crack_acceleration", "peak_base_acceleration", "instability_ratio_lower",
         "instability_ratio_upper")


def benchmark_wall(**changes: Any) -> Wall:
    """The benchmark wall: b 0.23 m, h 4.14 m, crack at 2/3, m 30 t, rigid base, top
    diaphragm 815 kN/m with 20 t and 12 % damping, PMR 75 (`changes` replace fields)."""
    w = Wall(thickness=0.23, height=4.14, crack_ratio=2.0 / 3.0, mass=30000.0,
             bottom_stiffness="rigid", bottom_mass=0.0, top_stiffness=815e3, top_mass=20000.0,
             top_damping=0.12, pmr=75.0)
    return w.replace(**changes) if changes else w


def load_record(record_id: str, window: float | None = None) -> tuple[np.ndarray, float, float]:
    """(samples [m s-2], dt [s], manifest scale factor) of a manifest record
    (`urmx.records.as_record`: unscaled samples, the scale factor beside them), optionally
    only its first `window` seconds."""
    from .records.record import as_record  # (the guard's start-up process stays light)

    rec = as_record(record_id)
    ag = rec.acceleration
    if window is not None:
        ag = ag[:int(round(window / rec.dt)) + 1]
    return ag, rec.dt, rec.scale_factor


def median_time(fn: Callable[[], Any], repeat: int = 5, min_time: float = 0.0,
                setup: Callable[[], Any] | None = None, max_repeat: int = 10000) -> dict:
    """Median wall time [s] of `fn()` over at least `repeat` calls and `min_time` seconds
    (`setup()` runs before each call, untimed), with ``min``, ``max`` and ``repeats``."""
    times: list[float] = []
    start = time.perf_counter()
    while len(times) < repeat or (time.perf_counter() - start < min_time
                                  and len(times) < max_repeat):
        setup and setup()
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    a = np.array(times)
    return {"median": float(np.median(a)), "min": float(a.min()), "max": float(a.max()),
            "repeats": len(times)}


def rel_error(res: dict, ref: dict, names=PEAKS) -> dict:
    """Relative error of each peak output of `res` against `ref` (0 when both are 0), their
    maximum under ``"max"`` and the name of the worst under ``"worst"``."""
    errs = {}
    for k in names:
        a, b = float(res[k]), float(ref[k])
        finite = math.isfinite(a) and math.isfinite(b)
        errs[k] = 0.0 if a == b else abs(a - b) / max(abs(b), 1e-300) if finite else math.inf
    worst = max(errs, key=errs.get)
    return {"max": errs[worst], "worst": worst, "each": errs}


def machine_class() -> str:
    """The key of the stored baseline: architecture and core count (``x86_64-2cpu``)."""
    return f"{platform.machine() or 'unknown'}-{os.cpu_count() or 1}cpu"


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``, else `platform.processor`)."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        lines = []
    names = [ln.split(":", 1)[1].strip() for ln in lines if ln.startswith("model name")]
    return names[0] if names else platform.processor() or "unknown"


def git_commit() -> str:
    """Short commit of the checkout, with ``(urmx/ modified)`` when the package differs."""
    root = checkout()  # None for an installed urmx (its folder may be in another repository)

    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=root, capture_output=True,
                              text=True, timeout=10).stdout.strip() if root else ""
    try:
        head, dirty = git("rev-parse", "--short=12", "HEAD"), git("status", "--porcelain", "urmx")
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return (head or "unknown") + (" (urmx/ modified)" if dirty else "")


def read_baseline(path: Path) -> dict:
    """The stored figures by machine class (empty when the file does not exist)."""
    return tomllib.loads(path.read_text(encoding="utf-8")) if path.is_file() else {}


def write_baseline(path: Path, cls: str, entry: dict) -> None:
    """Store `entry` (flat str/float/int values) under `cls`, keeping the other classes."""
    data = read_baseline(path)
    data[cls] = entry
    lines = ["# Stored figures of `urmx bench guard`, one table per machine class",
             "# (architecture-cores). Rewrite a class with `urmx bench guard --update` on a",
             "# quiet machine of that class.", ""]
    for key in sorted(data):
        lines.append(f'["{key}"]')
        lines += [f"{k} = {json.dumps(v) if isinstance(v, str) else repr(v)}"
                  for k, v in data[key].items()]
        lines.append("")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines), encoding="utf-8")


# a first analysis in a fresh process: its time and the whole process's, import included
_START = ("import sys, time; t0 = time.perf_counter(); import numpy as np; from urmx import "
          "kernel; from urmx.guard import benchmark_wall; t = np.arange(501) * 0.01; t1 = "
          "time.perf_counter(); kernel.run(benchmark_wall(), 3 * np.sin(12.57 * t) * np.exp(-t)"
          ", 0.01); t2 = time.perf_counter(); print(t2 - t1, t2 - t0)")


def start_up(cold: bool) -> dict:
    """Time a first analysis in a fresh Python process, ``cold`` with an empty numba cache
    (it compiles the kernel), else with the installed cache (it loads it) [s]."""
    import tempfile

    env = dict(os.environ)
    with tempfile.TemporaryDirectory() as tmp:
        if cold:
            env["NUMBA_CACHE_DIR"] = tmp
        proc = subprocess.run([sys.executable, "-c", _START], capture_output=True, text=True,
                              env=env, timeout=1800)
    if proc.returncode != 0:
        raise RuntimeError(f"the start-up measurement failed: {proc.stderr.strip()[-500:]}")
    first, total = (float(x) for x in proc.stdout.split()[-2:])
    return {"first_analysis": first, "process": total}


def measure(quick: bool = False) -> dict:
    """The guard's measurement: warm median time [s] of the kernel on the benchmark wall
    under El Centro x 0.5, its max relative peak error against the reference, and the cold
    (compile) and warm (cache load) first analyses of fresh processes."""
    wall = benchmark_wall()
    ag, dt, sf = load_record("elcentro", 5.0 if quick else None)
    t0 = time.perf_counter()
    res = kernel.run(wall, ag, dt, scale=sf)  # includes numba compilation on a fresh install
    first = time.perf_counter() - t0
    t = median_time(lambda: kernel.run(wall, ag, dt, scale=sf), repeat=5,
                    min_time=0.3 if quick else 2.0)
    from .reference import run as run_reference  # scipy.integrate: 0.5 s of an import

    ref = run_reference(wall, ag, dt, scale=sf, rtol=REFERENCE_RTOL)
    err = rel_error(res, ref)
    return {"machine_class": machine_class(), "seconds": t["median"], "first_call": first,
            "repeats": t["repeats"], "events": res["events"],
            "reference_events": ref["events"], "error": err["max"], "worst": err["worst"],
            "samples": int(ag.size), "compile_seconds": start_up(True)["first_analysis"],
            "warm_start_seconds": start_up(False)["process"]}


CHECKS = (("seconds", SLOWDOWN, "kernel", 1e3, "ms"),
          ("compile_seconds", START_SLOWDOWN, "cold first analysis (compile)", 1.0, "s"),
          ("warm_start_seconds", START_SLOWDOWN, "warm start (process and first analysis)",
           1.0, "s"))


def verdict(measured: dict, baseline: dict | None) -> tuple[bool, list[str]]:
    """(passed, messages) of one measurement against the stored entry of its machine
    class (None: an unknown class, whose speed is not judged)."""
    ok = measured["error"] <= MAX_ERROR
    msgs = [f"{'ok' if ok else 'FAIL'}: kernel error vs reference {measured['error']:.3g} "
            + (f"<= {MAX_ERROR:g}" if ok else f"> {MAX_ERROR:g} ({measured['worst']})")]
    if baseline is None:
        return ok, msgs + [f"no stored figure for machine class {measured['machine_class']!r}: "
                           "speed not judged (store one with `urmx bench guard --update`)"]
    for key, limit, what, unit, name in CHECKS:
        if key not in baseline or key not in measured:
            msgs.append(f"no stored or measured figure for the {what}: not judged")
            continue
        ratio = measured[key] / baseline[key]
        line = (f"{what} {unit * measured[key]:.3f} {name} vs stored "
                f"{unit * baseline[key]:.3f} {name}: {ratio:.2f}x")
        ok = ok and ratio <= limit
        msgs.append(f"FAIL: {line} (> {limit:g}x slower)" if ratio > limit
                    else f"ok: {line} (limit {limit:g}x)")
    return ok, msgs


def run(update: bool = False, baseline_path: str | os.PathLike | None = None,
        quick: bool = False, echo: Callable[[str], None] = print) -> dict:
    """Measure and judge; with `update` first store the measurement as the baseline of
    this machine class. Returns the measurement with ``passed``, ``messages``,
    ``baseline`` and ``guard_seconds``."""
    # an installed urmx has no stored figures (speed not judged) and stores none
    root = need_checkout("guard --update") if update and not baseline_path else checkout()
    path = Path(baseline_path) if baseline_path else root / BASELINE if root else None
    t0 = time.perf_counter()
    m = measure(quick)
    if update:
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else -1.0
        write_baseline(path, m["machine_class"], {
            **{k: m[k] for k, *_ in CHECKS if k in m}, "error": m["error"],
            "events": m["events"], "samples": m["samples"], "cpu": cpu_model(),
            "commit": git_commit(),
            "date": _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat(),
            "load_average": round(load, 2)})
    stored = read_baseline(path).get(m["machine_class"]) if path else None
    ok, msgs = verdict(m, stored)
    m.update(passed=ok, messages=msgs, baseline=stored, guard_seconds=time.perf_counter() - t0)
    echo(f"urmx bench guard [{m['machine_class']}]: kernel {1e3 * m['seconds']:.3f} ms per "
         f"analysis ({1 / m['seconds']:.0f} /s, {m['events']} events, median of "
         f"{m['repeats']}; first call {m['first_call']:.2f} s), error vs reference rtol "
         f"{REFERENCE_RTOL:g} {m['error']:.3g} ({m['worst']}); cold first analysis "
         f"{m.get('compile_seconds', math.nan):.1f} s, warm start "
         f"{m.get('warm_start_seconds', math.nan):.2f} s")
    for line in msgs + ([f"stored as the baseline of {m['machine_class']} in {path}"]
                        if update else []):
        echo("  " + line)
    echo(f"  guard took {m['guard_seconds']:.1f} s: {'PASS' if ok else 'FAIL'}")
    return m
