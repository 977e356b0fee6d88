"""The sampling study: the catalog's ``uncertainty-ida`` (the parametric walls with the
paper's own ranges of COR, PMR, crack height, diaphragm frequency and damping, and both
impact laws, over the FEMA P695 far-field set) on 2 local dask worker processes, timed as
``urmx run`` runs it: the cluster's start and the run, the number of collapse capacities
and analyses, and the load of the machine; with the workers' CPU time, which gives the
time on a quiet machine (two cores to itself).

Not part of ``all`` (a few minutes on 2 cores); ask for it by name: ``urmx bench
uncertainty`` (``--quick``: 2 walls x 2 diaphragms x 4 records x 8 samples, to check the
machinery). The full run keeps its archive as ``results/uncertainty-ida.nc``, from which
``urmx uncertainty-report results/uncertainty-ida.nc`` writes ``reports/uncertainty/``.
"""

from __future__ import annotations

import os
import resource
import tempfile
import time
from pathlib import Path

from urmx.markdown import table

from ..common import verdict

IN_ALL = False
STUDY = "uncertainty-ida"
ARCHIVE = Path("results") / "uncertainty-ida.nc"
TARGET_MINUTES = 10.0  # "finishes in minutes": the whole study on 2 quiet cores [min]


def _load() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


def _quick_study(tmp: Path) -> Path:
    from urmx.study.file import study_path

    text = study_path(STUDY).read_text(encoding="utf-8")
    start, end = text.index("records = ["), text.index("]\ncor =") + 2
    text = (text[:start] + 'records = ["p695-01-mul009", "p695-09-dzc270", "p695-12-clwln", '
            '"p695-18-rio270"]\n' + text[end:])
    text = text.replace('walls = ["s08", "s12", "s16", "s20", "s24"]', 'walls = ["s08", "s24"]')
    text = text.replace('diaphragms = ["D1", "D4", "D1/both", "D4/both"]',
                        'diaphragms = ["D1", "D4/both"]')
    text = text.replace("samples = 48", "samples = 8")
    path = tmp / "quick-uncertainty.toml"
    path.write_text(text, encoding="utf-8")
    return path


def _cpu(client) -> float:
    """User and system CPU seconds of the client's worker processes (each asked for its
    own usage: a function of the standard library, which every worker can import, unlike
    this module)."""
    usage = client.run(resource.getrusage, resource.RUSAGE_SELF).values()
    return sum(r[0] + r[1] for r in usage)  # ru_utime + ru_stime


def time_study(study, out: Path) -> dict:
    """Start 2 local workers (timed), run the study into `out` on them (timed, with the
    workers' CPU seconds), as ``urmx run`` does."""
    from urmx.fragility import warm_up
    from urmx.study import close_client, local_client, run_study

    data: dict = {"load_start": _load()}
    t = time.perf_counter()
    warm_up()
    client = local_client(2)
    client.run(warm_up)
    data["startup_seconds"] = time.perf_counter() - t
    try:
        cpu0 = _cpu(client)
        load0, t = _load(), time.perf_counter()
        ds = run_study(study, out=out, scheduler=client, progress=False,
                       command=f"urmx bench uncertainty ({study.name})")
        data["run_seconds"] = time.perf_counter() - t
        data["worker_cpu_seconds"] = _cpu(client) - cpu0
        data["run_load"] = [load0, _load()]
    finally:
        close_client(client)
    n = ds.analyses
    data.update({
        "study": study.name, "walls": int(ds.wall.size), "diaphragms": int(ds.diaphragm.size),
        "records": int(ds.record.size), "samples": int(ds.sample.size),
        "parameters": [str(p) for p in ds.parameter.values],
        "method": ds.attrs["sampling_method"], "cells": int(n.count()),
        "analyses": int(n.sum()), "analyses_per_capacity": float(n.mean()),
        "censored": int(ds.censored.sum()), "event_limits": int(ds.event_limits.sum()),
        "rtol": ds.attrs["ida_rtol"], "archive_mb": out.stat().st_size / 1e6})
    data["quiet_seconds"] = data["worker_cpu_seconds"] / 2 + data["startup_seconds"]
    return data


def run(quick: bool, echo=print) -> dict:
    """Measure the section (``quick``: a 128-cell version of the study)."""
    return run_sampling(quick, _quick_study, STUDY, ARCHIVE, "samples", echo)


def run_sampling(quick: bool, quick_study, study_file: Path, archive: Path, unit: str,
                 echo=print, then=None) -> dict:
    """Time a sampling study (`time_study`): the catalog's `study_file` into `archive`, or
    with ``quick`` the study `quick_study(tmp)` writes into a temporary folder; `then(data,
    out)` adds to the data while the archive `out` still exists."""
    from urmx.study.file import load_study

    with tempfile.TemporaryDirectory() as tmp:
        if quick:
            study, out = load_study(quick_study(Path(tmp))), Path(tmp) / "quick.nc"
        else:
            study, out = load_study(study_file), archive
            out.parent.mkdir(parents=True, exist_ok=True)
        echo(f"  {study.name}: {study.settings.size} {unit} on 2 local workers -> {out}")
        data = time_study(study, out)
        if then is not None:
            then(data, out)
        return data


def targets(data: dict) -> list[list[str]]:
    """Rows (target, measured, verdict) of the report's targets table."""
    quiet = data["quiet_seconds"] / 60
    return [[f"`{data['study']}` (sampling study) on 2 quiet cores < {TARGET_MINUTES:g} min",
             f"{quiet:.1f} min estimated ({data['analyses']} analyses; "
             f"{(data['run_seconds'] + data['startup_seconds']) / 60:.1f} min measured on the "
             "shared machine)", verdict(quiet < TARGET_MINUTES)]]


def render(data: dict) -> list[str]:
    """Markdown lines of the section, from the saved dict alone."""
    total = data["run_seconds"] + data["startup_seconds"]
    return [
        "## Sampling study (modelling uncertainty)",
        "",
        f"`urmx bench uncertainty`: the catalog study `{data['study']}` run as `urmx run` "
        f"runs it, on 2 local worker processes. {data['walls']} walls x {data['diaphragms']} "
        f"diaphragms x {data['records']} records x {data['samples']} samples "
        f"({data['method']}; sampled: {', '.join(data['parameters'])}) = {data['cells']} "
        f"collapse capacities (rtol {data['rtol']:g}), {data['analyses']} analyses "
        f"({data['analyses_per_capacity']:.2f} a capacity), {data['censored']} censored, "
        f"{data['event_limits']} analyses stopped by the event bound; archive "
        f"{data['archive_mb']:.1f} MB.",
        "",
        *table(["measure", "value"], [
            ["cluster start (2 workers, compiled code loaded)",
             f"{data['startup_seconds']:.1f} s"],
            ["the run (batches, parts, archive)",
             f"{data['run_seconds']:.1f} s ({data['analyses'] / data['run_seconds']:.0f} "
             f"analyses/s); load {data['run_load'][0]} -> {data['run_load'][1]}"],
            ["in all, on this shared machine", f"{total:.1f} s ({total / 60:.1f} min)"],
            ["CPU time of the 2 workers", f"{data['worker_cpu_seconds']:.1f} s "
             f"({data['analyses'] / data['worker_cpu_seconds']:.0f} analyses per CPU second)"],
            ["estimate on 2 quiet cores (CPU time / 2 + start)",
             f"{data['quiet_seconds']:.1f} s ({data['quiet_seconds'] / 60:.1f} min)"]]),
        "",
        "The machine was shared with other work while this ran (see the load): the "
        "estimate for a quiet machine divides the workers' CPU time by the two cores.",
        "",
    ]
