"""`urmx paper` end to end from a cold start: a fresh Python process (imports, numba cache
loads, a new local cluster, the paper's studies, the reports), writing into a temporary folder.

Not part of ``all`` (it takes a while and reruns the paper): ask for it by name or with
``--paper``. Its lines follow the grid-scaling section of the report."""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ..common import verdict

IN_ALL = False
TARGET_PAPER = 60.0  # seconds, from a cold start


def run(quick: bool) -> dict:
    """Time one `urmx paper` (the same at any size: `quick` changes nothing)."""
    with tempfile.TemporaryDirectory(prefix="urmx-bench-paper-") as tmp:
        dest = Path(tmp)
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


def targets(p: dict) -> list[list[str]]:
    """Rows (target, measured, verdict) of the report's targets table."""
    return [[f"`urmx paper` < {TARGET_PAPER:.0f} s from a cold start",
             f"{p['seconds']:.1f} s (exit {p['returncode']})", verdict(p["met"])]]


def render(p: dict) -> list[str]:
    """The paper timing, as a paragraph after the grid-scaling section."""
    L = [f"`urmx paper` end to end from a cold start (a fresh process: imports, numba "
         f"cache, a new LocalCluster, the paper's studies, the reports): **{p['seconds']:.1f} s**"
         f", exit code {p['returncode']} (target < {TARGET_PAPER:.0f} s: "
         f"{verdict(p['met'])}).", ""]
    if p["returncode"]:
        L += ["```", p["stderr_tail"], "```", ""]
    return L
