"""Studies: a study file -> batches on dask -> one labelled Dataset -> a netCDF archive, for
every study kind; this package's public names, each loaded from its module on first use.

A study (`urmx.study.file.load_study`: a study file read and checked) is a grid over
``wall``, ``diaphragm``, ``record``, ``cor`` and any of ``scale``, ``impact``, ``damping``;
its kind (`urmx.study.kinds`, the one place kinds are registered) says what each cell
computes: the default time-history grid
(`urmx.study.kinds.grid`: one analysis per cell) or the kind a ``[study.<kind>]`` table
names. The kind-blind engine runs them all:

- `urmx.study.engine`: :func:`run_study`, :func:`run_grid`, :func:`batch_tasks`, the compute
  loop (:func:`compute`);
- `urmx.study.limits`: a study's size before it runs (:func:`size_of`, :func:`check_size`,
  :data:`MAX_CELLS`, :data:`MAX_GB`) and what one dimension may hold (:data:`MAX_VALUES`);
- `urmx.study.cells`: the cells of a study and their identities (:class:`Cells`);
- `urmx.study.batches`: :class:`Batch`, the blocks of cells work is cut into (:class:`Cut`);
- `urmx.study.parts`: the part store of resumable archives (:class:`PartStore`) and the
  lock (:class:`Lock`);
- `urmx.study.sources`: where each cell's result lies, cells taken over from an earlier
  archive, and the gathering of results into the study's arrays;
- `urmx.study.clients`: dask clients (:func:`local_client`, :func:`close_client`,
  :func:`get_client`, :func:`check_scheduler`);
- `urmx.study.progress`: :class:`Progress` on stderr;
- `urmx.study.dataset`: the status vocabulary (:data:`STATUS`), the shared coordinates
  (:func:`grid_coords`) and global attributes (:func:`global_attrs`);
- `urmx.study.archive`: :func:`open_study`;
- `urmx.study.summary`: :func:`info` (what an archive holds and how it was made) and
  :func:`diff` (what differs between two archives), ``urmx info`` and ``urmx diff``;
- `urmx.study.table`: :func:`to_dataframe`, an archive as one row per cell (``urmx
  export``);
- `urmx.study.samples`: :func:`resolve_records`, a study's records (manifest ids and the
  study file's own record files) as `urmx.records.Record`, with their provenance.

The names are loaded on first use, so that importing one module of the package (a kind on
a worker) does not import the engine.
"""

from __future__ import annotations

import importlib

_PUBLIC = {
    "run_study": "engine", "run_grid": "engine", "batch_tasks": "engine", "compute": "engine",
    "last_run": "engine", "RunStats": "engine",
    "size_of": "limits", "check_size": "limits", "SizeError": "limits",
    "MAX_CELLS": "limits", "MAX_GB": "limits", "MAX_VALUES": "limits",
    "Cells": "cells",
    "Batch": "batches", "Cut": "batches",
    "PartStore": "parts", "Lock": "parts",
    "check_scheduler": "clients", "local_client": "clients", "get_client": "clients",
    "close_client": "clients",
    "Progress": "progress",
    "STATUS": "dataset", "NOT_RUN": "dataset", "VALID": "dataset", "MISSING": "dataset",
    "grid_coords": "dataset", "global_attrs": "dataset", "status_names": "dataset",
    "open_study": "archive",
    "info": "summary", "diff": "summary", "format_info": "summary", "format_diff": "summary",
    "resolve_records": "samples", "RecordData": "samples",
    "to_dataframe": "table",
    "run_batch": "kinds.grid", "BATCH_OUTPUTS": "kinds.grid",
    "load_study": "file", "study_path": "file", "Study": "file",
}
_SUBMODULES = ("file", "engine", "limits", "cells", "batches", "parts", "sources", "clients",
               "progress", "dataset", "archive", "samples", "kinds", "summary", "table")
__all__ = sorted(_PUBLIC)


def __getattr__(name: str):
    if name in _PUBLIC:
        return getattr(importlib.import_module(f"urmx.study.{_PUBLIC[name]}"), name)
    if name in _SUBMODULES:
        return importlib.import_module(f"urmx.study.{name}")
    raise AttributeError(f"module 'urmx.study' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_PUBLIC, *_SUBMODULES})
