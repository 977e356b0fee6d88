"""Batches: the blocks of cells a study's work is cut into, each run by one worker call.

A batch covers, for every dimension of its kind's cells, a list of indices (a block of the
grid), within one record: the record's samples travel to the worker once per record, not
once per batch. :func:`cut` cuts the cells the way every kind runs, over every dimension
(wall, diaphragm, record, cor, scale, impact, damping and the kind's own): records
outermost, those of one time step together; within a record, the walls the study pairs
with it and every other dimension are cut into blocks of about ``batch_size`` cells, the
innermost dimensions taken whole while they fit and the next one cut into even pieces.
Only the cells still to run are cut: a block holding finished cells (found per cell,
`urmx.study.cells`) is halved along its longest side until every block is all to run, so
a resumed run computes no finished cell whatever the batches of the run before were.

A kind whose cells form chains (``Kind.chain``, a dimension along which each cell's result
depends on the cell before it, as a warm-started search's does) is cut
without splitting a chain: the chain's dimension is taken whole in every block (the
others cut to about ``batch_size`` cells), and a block holding finished cells is halved
along its other dimensions first and then cut along the chain only at finished cells, so
that every block's predecessors are either in the block, before their successors, or
finished before the run started (their results travel with the task, `Batch.before`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class Batch:
    """A block of cells: for each dimension of the kind's cells (in their order), the indices
    the batch covers; its cells' keys (`urmx.study.cells.Cells.keys`, block shape) and its
    key (a hash of those, `urmx.study.parts.batch_key`), set when it is made."""

    block: dict[str, list[int]]
    key: str = ""
    cells: np.ndarray | None = field(default=None, repr=False)
    #: a chained kind's outputs of the cells just before the block along the chain (the
    #: block's shape with one index on the chain's dimension; NaN where the block starts its
    #: chain), set when it is made (`urmx.study.engine`); None for other kinds
    before: dict[str, np.ndarray] | None = field(default=None, repr=False)

    @property
    def record(self) -> int:
        """Index of the batch's one record."""
        (index,) = self.block["record"]
        return index

    @property
    def walls(self) -> list[int]:
        """Indices of the batch's walls."""
        return self.block["wall"]

    @property
    def size(self) -> int:
        """Number of cells (what progress counts)."""
        return math.prod(len(v) for v in self.block.values())

    @property
    def shape(self) -> tuple[int, ...]:
        """The block's shape over the kind's dimensions."""
        return tuple(len(v) for v in self.block.values())

    def index(self, *trailing: Any) -> tuple:
        """Index of the block in an array over the kind's dimensions (then `trailing`
        indices, e.g. a slice over a per-cell axis): ``array[batch.index()] = values``."""
        return np.ix_(*self.block.values()) + trailing


def extents(shape: tuple[int, ...], batch_size: int) -> tuple[int, ...]:
    """Block lengths over a grid of `shape` for about `batch_size` cells a block: the
    innermost dimensions whole while they fit, the next cut into even pieces, the outer
    ones one index."""
    out = [1] * len(shape)
    room = max(1, int(batch_size))
    for axis in range(len(shape) - 1, -1, -1):
        n = shape[axis]
        if n <= room:
            out[axis] = n
            room //= n
            continue
        pieces = math.ceil(n / room)
        out[axis] = math.ceil(n / pieces)
        break
    return tuple(out)


def chain_extents(shape: tuple[int, ...], batch_size: int, axis: int) -> tuple[int, ...]:
    """Block lengths as :func:`extents`, with dimension `axis` (a chain) always whole: the
    other dimensions cut to about ``batch_size / shape[axis]`` cells a block, the number of
    chains rounded to the nearest (at least one: 16 cells of 9-cell chains make blocks of 2
    chains, 18 cells, not 1; a block of a few heavy cells cost the cluster more in
    messages and parts than in work)."""
    rest = list(shape)
    rest[axis] = 1
    chains = max(1, int(int(batch_size) / max(1, shape[axis]) + 0.5))
    out = list(extents(tuple(rest), chains))
    out[axis] = shape[axis]
    return tuple(out)


def _starts(n: int, length: int) -> np.ndarray:
    return np.arange(0, n, length)


def _counts(todo: np.ndarray, lengths: tuple[int, ...]) -> np.ndarray:
    """Cells to run in each block of a sub-grid cut into blocks of `lengths`."""
    counts = todo.astype(np.int64)
    for axis, length in enumerate(lengths):
        counts = np.add.reduceat(counts, _starts(todo.shape[axis], length), axis=axis)
    return counts


def _runs(todo: np.ndarray) -> list[tuple[int, int]]:
    """The maximal runs [a, b) of True in a 1-D flag array."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], todo.astype(np.int8), [0]])))
    return list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))


def _split(ranges: list[range], todo: np.ndarray, chain: int | None = None
           ) -> Iterator[list[range]]:
    """The blocks of all-to-run cells in a block (`todo` its cells' flags): the block, or
    its halves along the longest side, recursively; with a `chain` axis, halved along the
    other axes first, then cut along the chain at finished cells only."""
    if todo.all():
        yield ranges
        return
    if not todo.any():
        return
    sizes = list(todo.shape)
    if chain is not None:
        sizes[chain] = 0
        if max(sizes) <= 1:  # one chain: its runs of cells to run
            r = ranges[chain]
            for a, b in _runs(todo.reshape(-1)):
                yield [*ranges[:chain], range(r.start + a, r.start + b), *ranges[chain + 1:]]
            return
    axis = int(np.argmax(sizes))
    half = todo.shape[axis] // 2
    r = ranges[axis]
    for part, sub in ((range(r.start, r.start + half), np.take(todo, range(half), axis)),
                      (range(r.start + half, r.stop),
                       np.take(todo, range(half, todo.shape[axis]), axis))):
        yield from _split([*ranges[:axis], part, *ranges[axis + 1:]], sub, chain)


class Cut:
    """The cells still to run of a study, cut into batches (module docstring).

    Parameters
    ----------
    cells : urmx.study.cells.Cells
        The study's cells.
    batch_size : int
        Target number of cells a batch. [1]
    done : ndarray of bool, optional
        Flat over the grid: cells already finished (default none).
    """

    def __init__(self, cells: Any, batch_size: int, done: np.ndarray | None = None):
        self.cells, self.batch_size, self.done = cells, batch_size, done
        self.chain = getattr(cells, "chain", None)  # the axis of a chained kind's chains

    def _records(self) -> Iterator[tuple[list[np.ndarray], np.ndarray, tuple[int, ...]]]:
        """Per record with cells to run: (index arrays of its sub-grid per dimension, its
        to-run flags, block lengths)."""
        c = self.cells
        pairs = c.runnable()
        iw = c.names.index("wall")
        # records of one time step together (stably): each worker builds a wall's kernel
        # tables once per step (they are per wall and step, `urmx.kernel.tables`), not once
        # per change of step
        for r in sorted(range(c.shape[c.record_axis]), key=lambda r: c.record_dt[r]):
            walls = np.flatnonzero(pairs[:, r])
            if not len(walls):
                continue
            axes = [np.arange(n) for n in c.shape]
            axes[iw], axes[c.record_axis] = walls, np.array([r])
            shape = tuple(len(a) for a in axes)
            if self.done is None:
                todo = np.ones(shape, dtype=bool)
            else:
                todo = ~self.done[c.flat(axes).ravel()].reshape(shape)
            yield axes, todo, (extents(shape, self.batch_size) if self.chain is None else
                               chain_extents(shape, self.batch_size, self.chain))

    def counts(self) -> tuple[int, int]:
        """(blocks of the regular cut that hold nothing to run, all its blocks)."""
        finished = total = 0
        for _, todo, lengths in self._records():
            counts = _counts(todo, lengths)
            total += counts.size
            finished += int((counts == 0).sum())
        return finished, total

    def __iter__(self) -> Iterator[Batch]:
        """The batches, in order; each block holds only cells to run."""
        names = self.cells.names
        for axes, todo, lengths in self._records():
            counts = _counts(todo, lengths)
            for at in zip(*np.nonzero(counts), strict=True):
                ranges = [range(i * n, min(len(a), (i + 1) * n))
                          for i, n, a in zip(at, lengths, axes, strict=True)]
                sub = todo[tuple(slice(r.start, r.stop) for r in ranges)]
                for part in _split(ranges, sub, self.chain):
                    yield Batch({k: axes[d][r.start:r.stop].tolist()
                                 for d, (k, r) in enumerate(zip(names, part, strict=True))})
