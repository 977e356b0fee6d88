"""The cells of a study and their identities: what decides each cell's result, hashed, so
that finished work is found per cell whatever the batches were.

A cell is one point of its kind's grid (``Kind.cell_dims``: wall, diaphragm, record, cor
and the study's or the kind's other dimensions). Its identity, ``cell_key`` (64 bits), is a
hash of everything that decides its result:

- per dimension, what the cell's value there means: the wall's parameters (not its id); the
  diaphragm's stiffness, damping, the supports it makes and the building's diaphragm mass;
  the record's samples (their digest), time step and scale factor; the value itself for cor,
  scale, impact, damping and any other dimension (a kind may say more, ``Kind.identity``);
- once per study: the kind's name and settings, the study's tail, ``t_rest`` (the rest time
  of held joints, MODEL.md section 4; left out at its default, so that keys made before it
  stay: a cell run under another t_rest never has the key of one run under the default)
  and default impact law,
  the kernel's name, `urmx.jitcache.SOURCE_HASH` and the urmx version;
- whether the kind keeps extra arrays for the cell (``Kind.extras``: a grid's kept time
  histories), so that a cell computed without them is not taken for one with them;
- for a kind whose cells form chains (``Kind.chain``: a dimension along which each cell
  starts from the result of the cell before it, e.g. a search warm-started from the
  previous wall the study pairs with the record; `urmx.study.kinds.Kind`),
  the keys of every cell before it in its chain: the key of a chain's first cell is its
  own, the next one's folds its own into the key before it (salted with what the kind
  says the chain means, ``Kind.chain_tag``: the search's warm-start margin). A cell is
  thus never taken for one computed from another hint; a study extended by a wall at the
  end of its list keeps its cells, one extended in the middle computes the walls after
  the new one again.

Speed: each dimension's values are hashed once (SHA-256 of their JSON; a float dimension's
values by a bijective 64-bit mix of their bits, vectorised), and a cell's key folds its
dimensions' hashes with that mix (splitmix64's finaliser), in numpy: the keys of 10^6 cells
take about 0.05 s, and no per-cell Python runs. Two cells with different inputs get the same
key with probability 2^-64 per pair: for n new cells matched against m stored ones, below
n m / 1.8e19 (5e-8 at 10^6 x 10^6).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from .. import jitcache
from ..model import T_REST
from ..provenance import release
from .parts import kernel_name

_C1, _C2 = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31 = np.uint64(30), np.uint64(27), np.uint64(31)


def mix(x: np.ndarray) -> np.ndarray:
    """splitmix64's finaliser on uint64 arrays: a bijection that spreads every input bit."""
    with np.errstate(over="ignore"):
        x = x ^ (x >> _S30)
        x = x * _C1
        x = x ^ (x >> _S27)
        x = x * _C2
        return x ^ (x >> _S31)


def digest64(value: Any) -> int:
    """The first 64 bits of the SHA-256 of `value`'s JSON (sorted keys; other objects as
    their ``str``)."""
    text = json.dumps(value, sort_keys=True, default=str)
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:8], "little")


def _plain(value: Any) -> Any:
    """A kind's settings as plain values: its ``to_dict()`` where it has one (settings
    added later leave out their defaults there, so earlier keys stay), else a dataclass as
    its dict."""
    if callable(getattr(value, "to_dict", None)):
        return value.to_dict()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return dataclasses.asdict(value)
    return value


def dimension_identity(study: Any, records: dict, name: str) -> list | None:
    """What each value of one of the shared dimensions means for a result (None: the value
    itself)."""
    if name == "wall":
        return [spec.wall.to_dict() for spec in study.walls]
    if name == "diaphragm":
        mass = study.catalog.building.diaphragm_mass
        return [{"stiffness": d.stiffness, "damping": d.damping,
                 "supports": study.supports_of(d), "diaphragm_mass": mass}
                for d in study.diaphragms]
    if name == "record":
        return [{"digest": records[r].digest, "dt": records[r].dt,
                 "scale_factor": records[r].scale_factor} for r in study.records]
    return None


def _hashes(name: str, values: list, identity: list | None) -> np.ndarray:
    """One uint64 per value of a dimension."""
    salt = np.uint64(digest64(["dimension", name]))
    if identity is None and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                for v in values):
        bits = np.asarray(values, dtype=np.float64).view(np.uint64)
        return mix(mix(bits ^ salt))
    items = values if identity is None else identity
    return np.array([digest64([name, v]) for v in items], dtype=np.uint64)


class Cells:
    """The cells of one study for its kind: their dimensions, which of them the study runs,
    and their keys (module docstring).

    Parameters
    ----------
    study : urmx.study.file.Study
    kind : urmx.study.kinds.Kind
    records : dict of urmx.records.Record
        The study's records by id (their digests are part of the keys).
    kernel : callable, optional
        The integrator (its name is part of the keys; None: `urmx.kernel.run`).
    """

    def __init__(self, study: Any, kind: Any, records: dict, kernel: Callable | None = None):
        self.study, self.kind = study, kind
        self.dims = kind.cell_dims(study)
        self.names = list(self.dims)
        self.shape = tuple(len(v) for v in self.dims.values())
        self.size = math.prod(self.shape)
        self.strides = tuple(math.prod(self.shape[i + 1:]) for i in range(len(self.shape)))
        own = kind.identity(study, records) if kind.identity is not None else {}
        self.hashes = [
            _hashes(n, v, own[n] if n in own else dimension_identity(study, records, n))
            for n, v in self.dims.items()]
        base = {"kind": kind.name, "settings": _plain(study.settings), "tail": study.tail,
                "impact": None if "impact" in self.dims else study.impact,
                "dims": self.names, "kernel": kernel_name(kernel), "urmx": release(),
                "kernel_source": jitcache.SOURCE_HASH}
        if study.t_rest != T_REST:  # (the default left out: keys made before it stay)
            base["t_rest"] = study.t_rest
        self.base = np.array([digest64(base)], dtype=np.uint64)
        #: the code the cells are computed by (in their keys; a parts folder's ``code``)
        self.code = {k: base[k] for k in ("kernel", "kernel_source", "urmx")}
        self.extras = self._extras()
        self.record_axis = self.names.index("record")
        #: the records' time steps [s], in the study's order (`urmx.study.batches.Cut` runs
        #: the records of one step together: a wall's kernel tables are per step)
        self.record_dt = [float(records[r].dt) for r in study.records]
        self._pairs: np.ndarray | None = None
        chain = getattr(kind, "chain", None)
        #: the axis of the kind's chains (None: the cells are independent)
        self.chain = self.names.index(chain) if chain else None

    def _extras(self) -> dict[int, str]:
        """Flat index -> label of the cells whose run keeps extra arrays."""
        if self.kind.extras is None:
            return {}
        return {self.flat_of(index): label
                for index, label in self.kind.extras(self.study).items()}

    def flat_of(self, index: tuple[int, ...]) -> int:
        """The flat (C-order) index of one cell given by its index on each dimension.

        Parameters
        ----------
        index : tuple of int
            The cell's index on each dimension.
        """
        return int(sum(i * s for i, s in zip(index, self.strides, strict=True)))

    def flat(self, block: list) -> np.ndarray:
        """Flat indices of a block's cells (a list of index lists, one per dimension), in
        the block's shape.

        Parameters
        ----------
        block : list of list of int
            The block's index list on each dimension.
        """
        grids = np.ix_(*[np.asarray(ix, dtype=np.int64) for ix in block])
        return sum((g * s for g, s in zip(grids, self.strides, strict=True)),
                   np.zeros((1,) * len(block), dtype=np.int64))

    def keys(self, block: list) -> np.ndarray:
        """The keys of a block's cells, in the block's shape (uint64); for a chained kind,
        each folded with the keys of the cells before it in its chain (module docstring).

        Parameters
        ----------
        block : list of list of int
            The block's index list on each dimension.
        """
        if self.chain is None:
            return self._own_keys(block)
        ax = self.chain
        upto = int(max(block[ax], default=-1)) + 1
        full = [*block[:ax], list(range(upto)), *block[ax + 1:]]
        own, runs = self._own_keys(full), self.runs(full)
        salt = np.uint64(digest64(["chain", getattr(self.kind, "chain_tag", None)]))
        out = np.empty_like(own)
        shape = list(own.shape)
        shape[ax] = 1
        last, first = np.zeros(shape, np.uint64), np.ones(shape, dtype=bool)
        for i in range(upto):
            k = np.take(own, [i], axis=ax)
            k = np.where(first, k, mix(mix(last ^ salt) ^ k))
            ran = np.take(runs, [i], axis=ax)
            last, first = np.where(ran, k, last), first & ~ran
            out[(slice(None),) * ax + (i,)] = np.squeeze(k, axis=ax)
        return np.take(out, np.asarray(block[ax], dtype=np.int64), axis=ax)

    def _own_keys(self, block: list) -> np.ndarray:
        """The keys of a block's cells from their own inputs alone (block shape)."""
        k = self.base
        for hashes, ix in zip(self.hashes, block, strict=True):
            k = mix(k[..., None] ^ hashes[np.asarray(ix, dtype=np.int64)])
        k = k.reshape(tuple(len(ix) for ix in block))
        if self.extras:
            flat = self.flat(block)
            salted = np.isin(flat, np.fromiter(self.extras, dtype=np.int64))
            k = np.where(salted, mix(k ^ np.uint64(digest64("extras"))), k)
        return k

    def runnable(self) -> np.ndarray:
        """Whether the study runs each (wall, record) pair (its ``pairs``), shape (walls,
        records)."""
        if self._pairs is None:
            s = self.study
            self._pairs = np.array([[s.paired(w.id, r) for r in s.records] for w in s.walls],
                                   dtype=bool).reshape(len(s.walls), len(s.records))
        return self._pairs

    def runs(self, block: list) -> np.ndarray:
        """Whether the study runs each cell of a block (block shape).

        Parameters
        ----------
        block : list of list of int
            The block's index list on each dimension.
        """
        iw, ir = self.names.index("wall"), self.record_axis
        sub = self.runnable()[np.ix_(np.asarray(block[iw], dtype=np.int64),
                                     np.asarray(block[ir], dtype=np.int64))]
        if ir < iw:
            sub = sub.T
        shape = [1] * len(block)
        shape[iw], shape[ir] = len(block[iw]), len(block[ir])
        return np.broadcast_to(sub.reshape(shape), tuple(len(ix) for ix in block))


# ---- slabs: the grid in boxes that are contiguous in C order -------------------------------

def slab_shape(shape: tuple[int, ...], budget: int) -> tuple[int, ...]:
    """The shape of the boxes :func:`slabs` cuts a grid into: the trailing dimensions whole
    while they fit `budget` cells, the next one cut to fit, the leading ones one index."""
    out = [1] * len(shape)
    room = max(1, int(budget))
    for axis in range(len(shape) - 1, -1, -1):
        take = min(shape[axis], room)
        out[axis] = max(1, take)
        if take < shape[axis]:
            break
        room //= max(1, shape[axis])
    return tuple(out)


def slabs(shape: tuple[int, ...], budget: int) -> Iterator[tuple[list, int, int]]:
    """The grid of `shape` as boxes of :func:`slab_shape`, in C order: each as (index
    ranges per dimension, first flat index, last flat index + 1); a box is a contiguous
    range of flat indices."""
    box = slab_shape(shape, budget)
    counts = [math.ceil(n / b) for n, b in zip(shape, box, strict=True)]
    strides = [math.prod(shape[i + 1:]) for i in range(len(shape))]
    for at in np.ndindex(*counts):
        ranges = [range(i * b, min(n, (i + 1) * b)) for i, b, n in zip(at, box, shape,
                                                                         strict=True)]
        first = sum(r.start * s for r, s in zip(ranges, strides, strict=True))
        yield ranges, first, first + math.prod(len(r) for r in ranges)
