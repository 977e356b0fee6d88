"""Batches: the blocks of cells a study's work is cut into, each run by one worker call.

A batch covers, for every dimension of its kind's cells, a list of indices (a block of the
grid), within one record: the record's samples travel to the worker once per record, not
once per batch. :func:`by_walls` cuts the way every kind here does: one record and one
diaphragm a batch, the record's walls grouped so that a batch holds about ``batch_size``
cells, over every value of the other dimensions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

#: the dimensions a batch is cut along by :func:`by_walls`; it covers every value of the others
CUT = ("wall", "diaphragm", "record")


@dataclass
class Batch:
    """A block of cells: for each dimension of the kind's cells (in their order), the indices
    the batch covers; and its key (`urmx.study.parts.task_key`), set with its task."""

    block: dict[str, list[int]]
    key: str = ""

    @property
    def record(self) -> int:
        """Index of the batch's one record."""
        (index,) = self.block["record"]
        return index

    @property
    def diaphragm(self) -> int:
        """Index of the batch's one diaphragm."""
        (index,) = self.block["diaphragm"]
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


def by_walls(study: Any, dims: dict[str, list], batch_size: int) -> list[Batch]:
    """Batches of one record and one diaphragm, the walls the study pairs with the record
    grouped by ``max(1, batch_size // n)`` (``n`` the cells of one wall: the product of the
    sizes of the dimensions not in `CUT`), records outermost, then diaphragms.

    Parameters
    ----------
    study : urmx.catalog.Study
        The study (its walls, diaphragms, records and pairs).
    dims : dict
        The kind's cell dimensions and their values, in order; they include `CUT`.
    batch_size : int
        Target number of cells a batch. [1]
    """
    inner = math.prod(len(v) for k, v in dims.items() if k not in CUT)
    per = max(1, batch_size // inner)
    every = {k: list(range(len(v))) for k, v in dims.items() if k not in CUT}
    out = []
    for ir, rid in enumerate(study.records):
        walls = [iw for iw, w in enumerate(study.walls) if study.paired(w.id, rid)]
        for idp in range(len(study.diaphragms)):
            for i in range(0, len(walls), per):
                block = {"wall": walls[i:i + per], "diaphragm": [idp], "record": [ir], **every}
                out.append(Batch({k: block[k] for k in dims}))
    return out
