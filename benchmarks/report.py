"""Run benchmark sections, save each as JSON and write ``reports/performance.md`` from
every saved section."""

from __future__ import annotations

import inspect
import json
import os
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np

from urmx.errors import InputError
from urmx.markdown import table

from . import sections as registry
from .common import SectionSkipped, machine_info

HEADER = ("Regenerate with `urmx bench all --paper` (about 25 minutes on a 2-core "
          "machine, most of it the reference solver in the work-precision study; "
          "`--window 10` about halves that; the parts: `urmx bench "
          "kernel|records|study|hard|guard`; `urmx bench render` rewrites this file from the "
          "saved sections). Timings are medians "
          "over repeats, in one process unless stated; a *core* is one process. Each "
          "section lists the machine and the load it was measured under; numbers taken "
          "on a loaded machine are noisy.")


def name(section: ModuleType) -> str:
    """A section's name: its module's."""
    return section.__name__.rpartition(".")[2]


def by_name() -> dict[str, ModuleType]:
    """The registered sections by name, in report order."""
    return {name(s): s for s in registry.SECTIONS}


def resolve(names: list[str], paper: bool = False) -> list[str]:
    """Section names of command-line names: ``all`` (every section not marked
    ``IN_ALL = False``), a group of `GROUPS`, or a section; ``paper`` adds the paper
    timing after the grid scaling when that runs (or when ``all`` does)."""
    known = by_name()
    out: list[str] = []
    for n in names:
        if n == "all":
            picked = [k for k, s in known.items() if getattr(s, "IN_ALL", True)]
        elif n in registry.GROUPS:
            picked = registry.GROUPS[n]
        elif n in known:
            picked = [n]
        else:
            raise InputError(f"unknown benchmark {n!r} (known: all, render, "
                             f"{', '.join([*registry.GROUPS, *known])})")
        out += [p for p in picked if p not in out]
    if paper and "grid_scaling" in out and "paper" not in out:
        out.insert(out.index("grid_scaling") + 1, "paper")
    return out


def _call(fn: Callable, *args, **options):
    """``fn(*args, **options)`` with only the options `fn` names as parameters."""
    params = inspect.signature(fn).parameters
    return fn(*args, **{k: v for k, v in options.items() if k in params})


def _json_default(o):
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.floating):
        return float(o)
    if isinstance(o, np.bool_):
        return bool(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)


def save_section(folder: Path, section: str, data: dict, info: dict, quick: bool) -> Path:
    """Write one section's measurement as ``<folder>/<section>.json``."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{section}.json"
    payload = {"machine": info, "quick": quick, "data": data}
    path.write_text(json.dumps(payload, indent=1, default=_json_default), encoding="utf-8")
    return path


def load_sections(folder: Path) -> dict:
    """The saved sections of `folder` (``{name: {"machine", "quick", "data"}}``), in report
    order; registered sections not saved yet are left out."""
    out = {}
    for n in by_name():
        p = Path(folder) / f"{n}.json"
        if p.is_file():
            out[n] = json.loads(p.read_text(encoding="utf-8"))
    return out


def render(sections: dict, figures_dir: str = "performance") -> str:
    """The Markdown of ``reports/performance.md`` from saved sections (no measuring)."""
    L: list[str] = ["# Performance: speed against error", "", HEADER, ""]
    if not sections:
        return "\n".join(L + ["No measurements yet.", ""])
    info = next(iter(sections.values()))["machine"]
    L += ["## Machine", ""]
    L += table(["", ""], [
        ["CPU", info["cpu"]], ["cores", info["cores"]], ["RAM", f"{info['ram_gb']} GB"],
        ["machine class", f"`{info['machine_class']}`"], ["Python", info["python"]],
        ["numpy / scipy / numba", f"{info['numpy']} / {info['scipy']} / {info['numba']}"],
        ["dask / distributed", f"{info['dask']} / {info['distributed']}"],
        ["urmx", f"{info['urmx']}, commit `{info['commit']}`"]])
    L.append("")
    rows = []
    for n, s in sections.items():
        m = s["machine"]
        rows.append([n, m["date"], ", ".join(str(x) for x in m["load_average"] or []),
                     "QUICK (reduced)" if s["quick"] else "full", f"`{m['commit']}`"])
    L += table(["section", "measured (UTC)", "load average (1, 5, 15 min)", "sizes", "commit"],
               rows)
    L.append("")
    if any(s["quick"] for s in sections.values()):
        L += ["> **Sections marked QUICK were run at reduced sizes to check the machinery; "
              "they are not the acceptance measurement.**", ""]
    modules = by_name()
    L += ["## Targets", ""]
    L += table(["target", "measured", "verdict"],
               [r for n, s in sections.items() if hasattr(modules[n], "targets")
                for r in modules[n].targets(s["data"])])
    L.append("")
    for n, s in sections.items():
        L += _call(modules[n].render, s["data"], figures_dir=figures_dir)
    return "\n".join(L) + "\n"


def write_report(out: str | os.PathLike) -> Path:
    """Render every section saved next to `out` (in `out` without ``.md``) into `out`."""
    out = Path(out)
    folder = out.with_suffix("")
    text = render(load_sections(folder), folder.name)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text, encoding="utf-8")
    return out


def run_sections(names: list[str], out: str | os.PathLike = "reports/performance.md",
                 quick: bool = False, echo: Callable[[str], None] = print,
                 window: float | None = 20.0) -> Path:
    """Run sections by name, save each as JSON in ``<out without .md>/`` and rewrite the
    report from every saved section (sections not run keep their last measurement, as do
    sections that raise `SectionSkipped`: the reason is echoed in one line).

    `window`: seconds of each record in the work-precision study (None: whole records)."""
    out = Path(out)
    folder = out.with_suffix("")
    modules = by_name()
    for n in names:
        if n not in modules:
            raise InputError(f"unknown benchmark section {n!r} (known: {', '.join(modules)})")
    for n in names:
        t = time.perf_counter()
        echo(f"urmx bench: {n} ...")
        try:
            data = _call(modules[n].run, quick, figures=folder, echo=echo, window=window)
        except SectionSkipped as exc:
            echo(f"urmx bench: {n} skipped: {exc}")
            continue
        save_section(folder, n, data, machine_info(), quick)
        echo(f"urmx bench: {n} done in {time.perf_counter() - t:.1f} s")
        write_report(out)
    return write_report(out)
