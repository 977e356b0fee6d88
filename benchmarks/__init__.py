"""The benchmark suite of urmx: speed against error, written to ``reports/performance.md``.

Not part of the installed package (only the CI regression guard is, `urmx.guard`). Run it
from the source checkout::

    urmx bench all --paper          # or: python -m benchmarks all --paper
    urmx bench kernel --quick       # one part at reduced sizes, to check the machinery
    urmx bench render               # rewrite the report from the saved sections

Each report section is a module of :mod:`benchmarks.sections` (``run(quick) -> dict``,
saved as JSON in ``reports/performance/``, and ``render(dict) -> list[str]``); the report
is rendered from the saved JSON alone. Nothing here is a test: the numbers depend on the
machine and its load, so the report carries the machine, the versions and the load
average of each run.
"""

from __future__ import annotations

import os
from pathlib import Path

from .report import load_sections, render, resolve, run_sections, write_report

__all__ = ["run", "run_sections", "render", "write_report", "load_sections", "resolve"]


def run(names: list[str], out: str | os.PathLike = "reports/performance.md",
        quick: bool = False, paper: bool = False, window: float | None = 20.0) -> Path:
    """What ``urmx bench NAME ...`` does: ``render`` rewrites the report from the saved
    sections; any other names (``all``, a group, sections) are measured first."""
    if list(names) == ["render"]:
        return write_report(out)
    return run_sections(resolve(list(names), paper), out, quick=quick, window=window)
