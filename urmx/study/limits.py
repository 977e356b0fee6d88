"""The size of a study, computed from its definition before any grid or array is built, and
the limits above which a run stops before any work.

The limits (:data:`MAX_CELLS`, :data:`MAX_GB`) are the defaults of ``urmx run --max-cells /
--max-gb`` and of `urmx.run_study`. :data:`MAX_VALUES` bounds one dimension: a range
``{start, stop, step}`` is counted from its three numbers before its values are made
(`urmx.study.file.load_study`), so a step typed too small (1e-9 for 1e-2) is refused at once
with the file, key and line, instead of filling the memory.

Why these defaults: the engine keeps 8 bytes per cell of the grid in the main process for
the whole run (where each finished cell's result lies, `urmx.study.cells`) and about 25
bytes per cell for a moment while it matches finished cells, so 2e7 cells cost about
0.2-0.5 GB there, and a grid of 2e7 analyses is about 3 hours of work on 100 cores at the
measured 15-30 ms per analysis and core (``reports/performance.md``, scale section). An
archive of 20 GB (about 1.5e8 grid cells, 133 bytes each uncompressed) is what a laptop
still opens; larger studies are for a cluster, run with the limits raised on purpose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from .. import catalog
from ..errors import InputError

#: the most cells a study may have unless the run raises the limit (``--max-cells``)
MAX_CELLS = 20_000_000
#: the largest archive (uncompressed estimate) a run writes unless raised (``--max-gb``) [GB]
MAX_GB = 20.0
#: most values one dimension of a study may hold (a ``{start, stop, step}`` range included;
#: counted where the study file is read, `urmx.catalog.dimension_values`)
MAX_VALUES = catalog.MAX_VALUES


class SizeError(InputError):
    """A study is larger than the run's limits; the message gives its size and the way on."""


@dataclass(frozen=True)
class Size:
    """The size of a study for its kind.

    Parameters
    ----------
    cells : int
        Cells of the grid (the product of the kind's dimension sizes). [1]
    runs : int
        Cells the study runs (those its pairs do not leave out). [1]
    bytes : float
        The archive's size without compression: every cell's outputs and its identity. [B]
    unit : str
        What a cell is (the kind's progress unit: analyses, cells).
    """

    cells: int
    runs: int
    bytes: float
    unit: str

    @property
    def gb(self) -> float:
        """The archive's size. [GB]"""
        return self.bytes / 1e9


def _paired(study: Any) -> int:
    """How many (wall, record) pairs the study runs, without building them."""
    if study.pairs is None:
        return len(study.walls) * len(study.records)
    records = set(study.records)
    return sum(len(records.intersection(study.pairs.get(w.id, ()))) for w in study.walls)


def size_of(study: Any, kind: Any) -> Size:
    """The size of `study` for its kind `kind` (`urmx.study.kinds.Kind`), from the sizes of
    the kind's dimensions alone (nothing of the grid is built).

    The archive's bytes are the kind's ``cell_bytes(study)`` per cell (its outputs as
    stored, default 8 bytes per output) plus the 8-byte cell identity (``cell_key``).

    Parameters
    ----------
    study : urmx.study.file.Study
        The study, as loaded from its file.
    kind : urmx.study.kinds.Kind
        Its kind.
    """
    sizes = {k: len(v) for k, v in kind.cell_dims(study).items()}
    cells = math.prod(sizes.values())
    others = math.prod(n for k, n in sizes.items() if k not in ("wall", "record"))
    runs = others * _paired(study) if {"wall", "record"} <= set(sizes) else cells
    per_cell = kind.cell_bytes(study) if kind.cell_bytes is not None \
        else 8.0 * len(kind.outputs)
    return Size(cells, runs, float(cells) * (per_cell + 8.0), kind.unit)


def check_size(study: Any, kind: Any, max_cells: float | None = MAX_CELLS,
               max_gb: float | None = MAX_GB) -> Size:
    """The study's :func:`size_of`, or a `SizeError` when it passes a limit (None: no limit).

    Parameters
    ----------
    study : urmx.study.file.Study
        The study, as loaded from its file.
    kind : urmx.study.kinds.Kind
        Its kind.
    max_cells : float or None
        Most cells a study may have; None: no limit. [1]
    max_gb : float or None
        Largest archive, uncompressed; None: no limit. [GB]

    Raises
    ------
    SizeError
        More cells than `max_cells`, or an archive larger than `max_gb`, with the size and
        how to proceed in the message.
    urmx.errors.InputError
        A limit that is not a positive number.
    """
    for name, value in (("max_cells", max_cells), ("max_gb", max_gb)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float))
                                  or not value > 0):
            raise InputError(f"{name}={value!r} must be a positive number (or None: no limit)")
    size = size_of(study, kind)
    over = []
    if max_cells is not None and size.cells > max_cells:
        over.append(f"{size.cells:,} cells (limit {max_cells:,.0f}, --max-cells)")
    if max_gb is not None and size.gb > max_gb:
        over.append(f"an archive of about {size.gb:,.1f} GB (limit {max_gb:g} GB, --max-gb)")
    if over:
        raise SizeError(
            f"study {study.name!r} is too large to start: {' and '.join(over)}; it runs "
            f"{size.runs:,} {size.unit}. Make the grid coarser or split the study, or raise "
            "the limit (urmx run --max-cells N --max-gb G; run_study(max_cells=..., "
            "max_gb=...)) to run it as it is")
    return size
