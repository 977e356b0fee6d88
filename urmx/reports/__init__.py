"""Reports: figures and ``REPORT.md`` from study archives, one writer per study kind, chosen
by the archive's kind (:data:`REPORTS`); this module is the one place report writers are
registered, as `urmx.study.kinds` is the one place kinds are.

A study kind ``K`` with a report of its own is ``reports/K.py`` holding
``write_report(archive, out_dir, **options) -> Path`` (archive: a path or a Dataset) and
one line in :data:`REPORTS`. An archive of a kind without a line here (and one of no
study, ``urmx simulate``) gets the grid's report (`urmx.reports.grid`: tables and a figure
per output, which suits any archive). The paper's archives (`urmx.reports.paper`) make
one report together. The other modules: `urmx.reports.common` (what the reports share),
`urmx.reports.ida_risk` (the IDA report's measure and risk sections; ``urmx risk``),
`urmx.reports.records` (``urmx records report``), `urmx.reports.assessment` (``urmx assess
report``), `urmx.reports.predictors` (the wall population's predictors).
"""

from __future__ import annotations

import inspect
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import xarray as xr

from ..errors import InputError
from ..study.archive import open_study
from ..study.summary import kind_of
from . import grid, ida, paper, sampling

#: study kind -> its report writer, ``write_report(archive, out_dir, **options) -> Path``
REPORTS: dict[str, Callable[..., Path]] = {
    "grid": grid.write_report,
    "ida": ida.write_report,
    "sampling": sampling.write_report,
    "sampling-ida": sampling.write_report,
}
#: the writer of a kind without one of its own, and of an archive of no study
DEFAULT = "grid"


def writer(ds: xr.Dataset) -> Callable[..., Path]:
    """The report writer of an archive's kind (`urmx.study.summary.kind_of`)."""
    return REPORTS.get(kind_of(ds) or DEFAULT, REPORTS[DEFAULT])


def report_folders(archives: list, out: str | os.PathLike | None = None
                   ) -> tuple[list[tuple[Any, xr.Dataset]], Path | None,
                              list[tuple[Any, xr.Dataset, Path]]]:
    """Where ``urmx report`` writes: (the paper's archives, loaded; the paper report's
    folder or None; [(archive, Dataset, folder)] of every other archive, opened lazily).

    The paper report goes to `out` (default ``reports/paper``). Any other archive gets its
    own folder: `out` when it is the only archive given, else ``<out or reports>/<file
    name without .nc>`` (the study name for a Dataset).
    """
    opened = [(a, a if isinstance(a, xr.Dataset) else open_study(a)) for a in archives]
    mine = [(a, ds.load()) for a, ds in opened if paper.study_kind(ds) is not None]
    own = []
    for a, ds in opened:
        if paper.study_kind(ds) is None:
            stem = Path(a).stem if not isinstance(a, xr.Dataset) else \
                str(ds.attrs.get("study_name", "study"))
            own.append((a, ds, Path(out) if out is not None and len(opened) == 1
                        else Path(out if out is not None else "reports") / stem))
    return mine, (Path(out if out is not None else "reports/paper") if mine else None), own


def write_one(archive: Any, ds: xr.Dataset, out_dir: str | os.PathLike,
              **options: Any) -> Path:
    """The report of one archive (`archive` as given, `ds` opened) by its kind's writer;
    `options` (``hazard``, ``years`` ...) only where that writer takes them."""
    write = writer(ds)
    taken = inspect.signature(write).parameters
    wrong = [k for k, v in options.items() if v is not None and k not in taken]
    if wrong:
        raise InputError(f"{archive if not isinstance(archive, xr.Dataset) else 'Dataset'}: "
                         f"--{wrong[0]} does not apply to the report of a "
                         f"{kind_of(ds) or 'simulate'} archive")
    return write(archive, out_dir, **{k: v for k, v in options.items() if v is not None})


def write_reports(archives, out: str | os.PathLike | None = None,
                  **options: Any) -> list[Path]:
    """``urmx report``: the paper report of the paper's archives and each other archive's
    report by its kind (:func:`writer`), in the folders of :func:`report_folders`; returns
    the ``REPORT.md`` paths."""
    if isinstance(archives, (str, os.PathLike, xr.Dataset)):
        archives = [archives]
    mine, folder, own = report_folders(list(archives), out)
    paths = [paper.write_report([ds for _, ds in mine], folder)] if mine else []
    return paths + [write_one(a, ds, where, **options) for a, ds, where in own]
