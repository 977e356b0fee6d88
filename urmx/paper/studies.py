"""The paper's four studies and :func:`run_paper`, the library call behind ``urmx paper``:
the catalog studies of the paper run into one folder on one cluster."""

from __future__ import annotations

import os
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

from ..config import records_dir
from ..kernel import warm_up
from ..study.clients import get_client, owning
from ..study.engine import run_study

#: the catalog studies of the paper, in the order `urmx paper` runs them
#: (`urmx.reports.paper` reads their archives)
STUDIES = ("paper-single-storey", "paper-multi-storey", "verification",
           "verification-intensity")


def run_paper(out: str | os.PathLike = "results", scheduler: Any = None,
              wrap: Callable[[Path, Callable[[], Any]], Any] | None = None,
              say: Callable[[str], Any] | None = None, **options: Any) -> list[Path]:
    """Run the paper's studies (:data:`STUDIES`) into ``<out>/<study>.nc`` on one cluster
    (``urmx paper``); returns the archives' paths, which `urmx.reports.paper.write_report`
    makes the paper's report of.

    Parameters
    ----------
    out : path
        Folder of the archives (created if needed); a study whose archive is complete is
        not run again (`urmx.run_study` resumes).
    scheduler : optional
        As for `urmx.run_study`; one client serves all four studies (``"serial"``: none).
    wrap : callable, optional
        ``wrap(path, run)`` calls ``run()``, the run of the study writing `path` (the
        command line says there what an interrupted run keeps); default: ``run()``.
    say : callable, optional
        Told the study about to run (``name -> path``).
    **options
        Any other keyword of `urmx.run_study` (progress, batch_size, records_dir, command,
        force, max_cells, max_gb).
    """
    out = Path(out)
    records_dir(options.get("records_dir"))  # a missing folder is said before a cluster
    archives = []
    client = get_client(scheduler, warm_up) if scheduler != "serial" else (None, False)
    with owning(*client) as client:
        for name in STUDIES:
            path = out / f"{name}.nc"
            if say is not None:
                say(f"{name} -> {path}")
            run = partial(run_study, name, out=path,
                          scheduler=client if client else "serial", **options)
            (wrap or (lambda _, run: run()))(path, run)
            archives.append(path)
    return archives
