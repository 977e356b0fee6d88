"""Studies: a study file -> batches on dask -> one labelled Dataset -> a netCDF archive, for
every study kind; this package's public names, each loaded from its module on first use.

A study (`urmx.catalog.load_study`) is a grid over ``wall``, ``diaphragm``, ``record``,
``cor`` and any of ``scale``, ``impact``, ``damping``; its kind (`urmx.study.kinds`, the one
place kinds are registered) says what each cell computes: the default time-history grid
(`urmx.study.kinds.grid`: one analysis per cell) or the kind a ``[study.<kind>]`` table
names. The kind-blind engine runs them all:

- `urmx.study.engine`: :func:`run_study`, :func:`run_grid`, :func:`batch_tasks`, the compute
  loop (:func:`compute`);
- `urmx.study.batches`: :class:`Batch`, the blocks of cells work is cut into;
- `urmx.study.parts`: batch keys (:func:`task_key`), the part store of resumable archives
  (:class:`PartStore`) and the lock (:class:`Lock`);
- `urmx.study.clients`: dask clients (:func:`local_client`, :func:`close_client`,
  :func:`get_client`, :func:`check_scheduler`);
- `urmx.study.progress`: :class:`Progress` on stderr;
- `urmx.study.dataset`: the status vocabulary (:data:`STATUS`), the shared coordinates
  (:func:`grid_coords`) and global attributes (:func:`global_attrs`);
- `urmx.study.archive`: :func:`open_study`;
- `urmx.study.summary`: :func:`info` (what an archive holds and how it was made) and
  :func:`diff` (what differs between two archives), ``urmx info`` and ``urmx diff``;
- `urmx.study.samples`: :func:`resolve_records`, a study's records (manifest ids and the
  study file's own record files) as `urmx.records.Record`, with their provenance;
- `urmx.study.limits`: what a study may hold (``MAX_VALUES`` values a dimension).

The names are loaded on first use so that `urmx.catalog` can reach the kinds (to parse a
study's ``[study.<kind>]`` table) without importing the engine, which imports the catalog.
"""

from __future__ import annotations

import importlib

_PUBLIC = {
    "run_study": "engine", "run_grid": "engine", "batch_tasks": "engine", "compute": "engine",
    "Batch": "batches",
    "task_key": "parts", "PartStore": "parts", "Lock": "parts",
    "check_scheduler": "clients", "local_client": "clients", "get_client": "clients",
    "close_client": "clients",
    "Progress": "progress",
    "STATUS": "dataset", "NOT_RUN": "dataset", "VALID": "dataset", "MISSING": "dataset",
    "grid_coords": "dataset", "global_attrs": "dataset", "status_names": "dataset",
    "open_study": "archive",
    "info": "summary", "diff": "summary", "format_info": "summary", "format_diff": "summary",
    "resolve_records": "samples", "RecordData": "samples",
    "run_batch": "kinds.grid", "BATCH_OUTPUTS": "kinds.grid",
}
_SUBMODULES = ("engine", "batches", "parts", "clients", "progress", "dataset", "archive",
               "samples", "kinds", "summary", "limits")
__all__ = sorted(_PUBLIC)


def __getattr__(name: str):
    if name in _PUBLIC:
        return getattr(importlib.import_module(f"urmx.study.{_PUBLIC[name]}"), name)
    if name in _SUBMODULES:
        return importlib.import_module(f"urmx.study.{name}")
    raise AttributeError(f"module 'urmx.study' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_PUBLIC, *_SUBMODULES})
