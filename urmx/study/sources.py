"""Where each cell's result lies (a part of the parts folder, or a batch result held in
memory), finding finished cells by their keys, taking cells over from an earlier archive, and
gathering the results into the study's arrays, slab by slab, so that an archive is written
without ever holding all results in memory.

The main process keeps two int32 per cell of the grid (the part holding the cell's result
and the cell's place in it) and nothing of the results themselves; the archive's arrays are
dask arrays whose chunks (slabs of about `SLAB` cells, contiguous in the grid's C order) each
read the parts they need when they are written.
"""

from __future__ import annotations

import operator
import uuid
from collections import OrderedDict
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import RunError
from .cells import Cells, slab_shape, slabs
from .parts import PartStore, batch_key, load_part

#: cells a slab of the archive holds (1 MiB per float64 output): the unit of gathering and
#: writing, and the netCDF chunk of the per-cell variables
SLAB = 2 ** 17
#: cells a part taken over from an archive holds
REUSED_PART = 2 ** 16
CACHE = 64  # parts held at once while gathering
#: bytes of the parts saved last that are also kept in memory, so that gathering them at the
#: end of a run reads no file (all of a small study's parts: a few MB)
RECENT_BYTES = 16 * 2 ** 20


def flatten(arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """A part's arrays with one leading axis of cells (the shape of ``cell_key`` folded)."""
    cells = arrays["cell_key"]
    n, ndim = cells.size, cells.ndim
    return {k: (v.reshape(n, *v.shape[ndim:]) if not k.startswith("extra.") else v)
            for k, v in arrays.items()}


class Sources:
    """The parts holding the results of a study's cells, and where each cell is in them.

    Parameters
    ----------
    cells : urmx.study.cells.Cells
        The study's cells.
    store : urmx.study.parts.PartStore, optional
        The parts folder (None: results are held in memory, a run without an archive).
    """

    def __init__(self, cells: Cells, store: PartStore | None):
        self.cells, self.store, self.kind = cells, store, cells.kind
        self.src = np.full(cells.size, -1, dtype=np.int32)
        self.off = np.zeros(cells.size, dtype=np.int32)
        self.parts: list[Any] = []  # a file name, or the arrays of a part held in memory
        self.trailing: dict[str, tuple[int, ...]] = {}
        self.extra_parts: dict[int, int] = {}  # key of a cell with extra arrays -> its part
        self._cache: OrderedDict = OrderedDict()
        self._recent: OrderedDict = OrderedDict()  # pid -> arrays of a part just saved
        self._recent_bytes = 0

    # ---- adding parts ------------------------------------------------------------------

    def register(self, where: Path | None, arrays: dict[str, np.ndarray]) -> int:
        """Add a part: its file (its `arrays` are then not kept), or None to hold its
        `arrays` in memory; its number."""
        pid = len(self.parts)
        flat = flatten(arrays)
        self.parts.append(str(where) if where is not None else flat)
        for name in self.kind.outputs:
            shape = flat[name].shape[1:]
            old = self.trailing.get(name, shape)
            self.trailing[name] = tuple(max(a, b) for a, b in zip(old, shape, strict=True))
        for k in flat:
            if k.startswith("extra."):
                self.extra_parts[int(k.split(".")[1], 16)] = pid
        return pid

    def place(self, pid: int, flat: np.ndarray) -> None:
        """Say that part `pid` holds the cells at grid positions `flat`, in its order."""
        flat = np.asarray(flat).ravel()
        self.src[flat] = pid
        self.off[flat] = np.arange(flat.size, dtype=np.int32)

    def add(self, key: str, arrays: dict[str, np.ndarray], flat: np.ndarray) -> None:
        """Keep a finished batch (`arrays`: the kind's outputs and ``cell_key``; saved as a
        part, or held in memory without a parts folder) and place its cells at grid
        positions `flat`."""
        where = None
        if self.store is not None:
            where = self.store.save(key, {k: v for k, v in arrays.items() if k != "cell_key"},
                                    arrays["cell_key"])
        pid = self.register(where, arrays)
        self.place(pid, flat)
        if where is not None:
            self._keep_recent(pid, arrays)

    def _keep_recent(self, pid: int, arrays: dict[str, np.ndarray]) -> None:
        """Hold a part just saved in memory as well (its arrays as :meth:`_load` would read
        them back: the file is a lossless copy), the oldest let go beyond `RECENT_BYTES`."""
        flat = flatten({k: np.asarray(v, dtype=np.uint64) if k == "cell_key" else
                        np.asarray(v) for k, v in arrays.items()})
        size = sum(v.nbytes for v in flat.values())
        if size > RECENT_BYTES:
            return
        self._recent[pid] = flat
        self._recent_bytes += size
        while self._recent_bytes > RECENT_BYTES:
            _, old = self._recent.popitem(last=False)
            self._recent_bytes -= sum(v.nbytes for v in old.values())

    def match(self, found: list[tuple[int, np.ndarray]]) -> int:
        """Place the cells of parts whose grid positions are not known, by their keys
        (`found`: (part, its cells' keys)); the number of the study's cells now placed."""
        if not found:
            return 0
        keys = np.concatenate([k.ravel() for _, k in found])
        pids = np.concatenate([np.full(k.size, p, dtype=np.int32) for p, k in found])
        offs = np.concatenate([np.arange(k.size, dtype=np.int32) for _, k in found])
        order = np.argsort(keys, kind="stable")
        keys, pids, offs = keys[order], pids[order], offs[order]
        placed = 0
        for box, a, b in slabs(self.cells.shape, SLAB):
            want = self.cells.keys(box).ravel()
            pos = np.minimum(np.searchsorted(keys, want), keys.size - 1)
            hit = (keys[pos] == want) & self.cells.runs(box).ravel() & (self.src[a:b] < 0)
            hit &= self._has_extras(want, a, b)
            self.src[a:b][hit] = pids[pos[hit]]
            self.off[a:b][hit] = offs[pos[hit]]
            placed += int(hit.sum())
        return placed

    def _has_extras(self, keys: np.ndarray, a: int, b: int) -> np.ndarray:
        """False for the cells in [a, b) that need extra arrays no part holds."""
        ok = np.ones(b - a, dtype=bool)
        for flat in self.cells.extras:
            if a <= flat < b:
                ok[flat - a] = int(keys[flat - a]) in self.extra_parts
        return ok

    # ---- what is found -----------------------------------------------------------------

    def done(self) -> np.ndarray:
        """Flat flags of the cells whose result is found."""
        return self.src >= 0

    def missing(self) -> int:
        """Cells the study runs whose result is not found."""
        return sum(int((self.cells.runs(box).ravel() & (self.src[a:b] < 0)).sum())
                   for box, a, b in slabs(self.cells.shape, SLAB))

    # ---- gathering -----------------------------------------------------------------------

    def _load(self, pid: int) -> dict[str, np.ndarray]:
        where = self.parts[pid]
        if isinstance(where, dict):
            return where
        if pid in self._recent:
            return self._recent[pid]
        if pid in self._cache:
            self._cache.move_to_end(pid)
            return self._cache[pid]
        arrays = load_part(Path(where), None, self.kind.outputs)
        if arrays is None:
            raise RunError(f"part file {where!r} cannot be read back (damaged since it was "
                           "saved?): run again to compute its cells anew")
        self._cache[pid] = arrays = flatten(arrays)
        if len(self._cache) > CACHE:
            self._cache.popitem(last=False)
        return arrays

    def gather(self, box: list[range], a: int, b: int) -> dict[str, np.ndarray]:
        """Every output (and ``cell_key``: 0 where the study runs no cell) over one slab of
        the grid (`box`, flat indices a to b), the kind's fill where no result is."""
        n = b - a
        out = {}
        for name in self.kind.outputs:
            value, dtype = self.kind.fill(name)
            out[name] = np.full((n, *self.trailing.get(name, ())), value, dtype=dtype)
        src, off = self.src[a:b], self.off[a:b]
        order = np.argsort(src, kind="stable")
        ids, starts = np.unique(src[order], return_index=True)
        ends = np.append(starts[1:], n)
        for pid, i0, i1 in zip(ids, starts, ends, strict=True):
            if pid < 0:
                continue
            part, where = self._load(int(pid)), order[i0:i1]
            take = off[where]
            for name in self.kind.outputs:
                v = part[name][take]
                out[name][(where, *(slice(0, t) for t in v.shape[1:]))] = v
        keys = self.cells.keys(box).ravel()
        out["cell_key"] = np.where(self.cells.runs(box).ravel(), keys, np.uint64(0))
        shape = tuple(len(r) for r in box)
        return {k: v.reshape(*shape, *v.shape[1:]) for k, v in out.items()}

    def values(self, flat: np.ndarray, name: str) -> np.ndarray:
        """Output `name` (a per-cell scalar) of the cells at grid positions `flat`, as
        float64 (NaN where no result is found)."""
        out = np.full(np.size(flat), np.nan)
        for i, f in enumerate(np.asarray(flat).ravel()):
            if self.src[f] >= 0:
                out[i] = self._load(int(self.src[f]))[name][self.off[f]]
        return out

    def eager(self) -> dict[str, np.ndarray]:
        """Every output over the whole grid, in memory."""
        return self.gather([range(n) for n in self.cells.shape], 0, self.cells.size)

    def lazy(self) -> dict[str, Any]:
        """Every output over the whole grid as a dask array: one chunk per slab, each
        gathered from the parts when it is computed (all outputs of a slab by one task)."""
        import dask.array as da
        from dask.highlevelgraph import HighLevelGraph

        shape = self.cells.shape
        box = slab_shape(shape, SLAB)
        chunks = tuple((b,) * (n // b) + ((n % b,) if n % b else ())
                       for n, b in zip(shape, box, strict=True))
        counts = tuple(len(c) for c in chunks)
        token = uuid.uuid4().hex
        gname = f"urmx-gather-{token}"
        gather = {(gname, i): (self.gather, list(r), a, b)
                  for i, (r, a, b) in enumerate(slabs(shape, SLAB))}
        out = {}
        for name in (*self.kind.outputs, "cell_key"):
            trailing = self.trailing.get(name, ())
            dtype = np.dtype(np.uint64 if name == "cell_key" else self.kind.fill(name)[1])
            aname = f"urmx-cells-{name}-{token}"
            layer = {(aname, *np.unravel_index(i, counts), *(0,) * len(trailing)):
                     (operator.getitem, (gname, i), name) for i in range(len(gather))}
            graph = HighLevelGraph({gname: gather, aname: layer}, {gname: set(), aname: {gname}})
            out[name] = da.Array(graph, aname, (*chunks, *((t,) for t in trailing)),
                                 dtype=dtype)
        return out

    def extras(self) -> dict[str, dict[str, np.ndarray]]:
        """The extra arrays of the study's cells that keep them, by the kind's label."""
        out = {}
        for flat, label in self.cells.extras.items():
            index = np.unravel_index(flat, self.cells.shape)
            key = int(self.cells.keys([[int(i)] for i in index]).ravel()[0])
            if not self.cells.runs([[int(i)] for i in index]).all():
                continue
            part = self._load(self.extra_parts[key])
            prefix = f"extra.{key:016x}."
            out[label] = {k[len(prefix):]: v for k, v in part.items() if k.startswith(prefix)}
        return out


# ---- cells taken over from an earlier archive of the study -----------------------------------

def _cell_values(archive: Any, name: str, dims: list[str], box: list[range]) -> np.ndarray:
    """An archive variable over one slab of its grid, one row per cell (then its own
    trailing axes); variables over fewer of the cell dimensions are broadcast."""
    var = archive[name]
    present = [d for d in dims if d in var.dims]
    trailing = [d for d in var.dims if d not in dims]
    sel = var.isel({d: slice(r.start, r.stop) for d, r in zip(dims, box, strict=True)
                    if d in var.dims}).transpose(*present, *trailing)
    arr = np.asarray(sel.values)
    inner = arr.shape[len(present):]
    arr = arr.reshape(*[len(r) if d in var.dims else 1 for d, r in zip(dims, box, strict=True)],
                      *inner)
    arr = np.broadcast_to(arr, (*(len(r) for r in box), *inner))
    return arr.reshape(-1, *inner)


def _matches(sources: Sources, old: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(grid positions, archive positions) of the cells still missing whose keys the
    archive holds; cells that keep extra arrays are left out (an archive keeps them
    resampled, not as computed)."""
    cells = sources.cells
    order = np.argsort(old, kind="stable")
    ordered = old[order]
    new_at, old_at = [], []
    for box, a, b in slabs(cells.shape, SLAB):
        want = cells.keys(box).ravel()
        pos = np.minimum(np.searchsorted(ordered, want), old.size - 1)
        hit = (ordered[pos] == want) & cells.runs(box).ravel() & (sources.src[a:b] < 0)
        for flat in cells.extras:
            if a <= flat < b:
                hit[flat - a] = False
        new_at.append(np.flatnonzero(hit) + a)
        old_at.append(order[pos[hit]])
    new, at = np.concatenate(new_at), np.concatenate(old_at)
    by_old = np.argsort(at, kind="stable")
    return new[by_old], at[by_old]


def take_over(sources: Sources, archive: Any) -> int:
    """Take over from `archive` (an earlier archive of the study, an open xarray Dataset)
    every cell still missing whose key it holds: its results are copied into parts (so a
    run stopped later resumes from them, and the archive can be replaced); the number of
    cells taken over (0 when the archive has no ``cell_key`` over the kind's dimensions or
    lacks an output)."""
    cells, kind = sources.cells, sources.kind
    names = {n: kind.archived.get(n, n) for n in kind.outputs}
    if "cell_key" not in archive.variables or list(archive["cell_key"].dims) != cells.names \
            or any(v not in archive.variables for v in names.values()):
        return 0
    old = np.asarray(archive["cell_key"].values, dtype=np.uint64).ravel()
    new, at = _matches(sources, old)
    pending: list[tuple[np.ndarray, np.ndarray, dict]] = []
    for box, a, b in slabs(archive["cell_key"].shape, SLAB):
        i0, i1 = np.searchsorted(at, [a, b])
        if i0 == i1:
            continue
        local = at[i0:i1] - a
        values = {n: _cell_values(archive, v, cells.names, box)[local] for n, v in names.items()}
        pending.append((new[i0:i1], old[at[i0:i1]], values))
        if sum(len(p[0]) for p in pending) >= REUSED_PART:
            _flush(sources, pending)
    _flush(sources, pending)
    return int(new.size)


def _flush(sources: Sources, pending: list) -> None:
    """Save the cells taken over so far as one part."""
    if not pending:
        return
    flat = np.concatenate([p[0] for p in pending])
    keys = np.concatenate([p[1] for p in pending])
    arrays = {}
    for name in sources.kind.outputs:
        rows = [p[2][name] for p in pending]
        width = tuple(max(r.shape[i] for r in rows) for i in range(1, rows[0].ndim))
        value, dtype = sources.kind.fill(name)
        out = np.full((len(flat), *width), value, dtype=np.result_type(dtype, *rows))
        at = 0
        for r in rows:
            out[(slice(at, at + len(r)), *(slice(0, n) for n in r.shape[1:]))] = r
            at += len(r)
        arrays[name] = out
    arrays["cell_key"] = keys
    sources.add(batch_key("reused-", keys), arrays, flat)
    pending.clear()
