"""The `Kind` record: the names and functions a study kind declares (the protocol is
described in `urmx.study.kinds`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Kind:
    """A study kind: its names and functions (the protocol: `urmx.study.kinds`)."""

    name: str
    unit: str
    outputs: tuple[str, ...]
    task: Callable[..., dict]
    run: Callable[..., dict]
    assemble: Callable[..., Any]
    table: str | None = None
    combines: tuple[str, ...] = ()
    parse: Callable[[Any], Any] | None = None
    dims: Callable[[Any], dict[str, list]] | None = None
    reopen: Callable[[Any], Any] | None = None
    identity: Callable[[Any, dict], dict[str, list]] | None = None
    extras: Callable[[Any], dict[tuple[int, ...], str]] | None = None
    fills: dict[str, tuple[Any, Any]] = field(default_factory=dict)
    archived: dict[str, str] = field(default_factory=dict)
    cell_bytes: Callable[[Any], float] | None = None
    counts: Callable[[Any], dict[str, int] | None] | None = None
    keys: tuple[str, ...] = ()  # the keys of its [study.<table>] (docs/study-files.md)
    warm_up: Callable[[], None] | None = None  # loads its integrator (the kernel's warm_up)
    dt_above: float = 0.0  # a record's time step must exceed it (its integrator's window)
    #: the dimension along which each cell depends on the cell before it (the IDA kinds'
    #: ``wall``: a warm-started capacity search); None: independent cells
    chain: str | None = None
    #: what the chaining means (folded into the chained cells' keys, `urmx.study.cells`)
    chain_tag: Any = None
    #: the outputs of a cell its successor in the chain needs (`urmx.study.batches.Batch`)
    chained: tuple[str, ...] = ()
    #: what assemble needs of the study and records alone, computed while the cells run
    prepare: Callable[[Any, dict], Any] | None = None

    def cell_dims(self, study: Any) -> dict[str, list]:
        """The kind's cell dimensions of `study` (``dims``, default ``study.dims``)."""
        return self.dims(study) if self.dims is not None else study.dims

    def fill(self, name: str) -> tuple[Any, Any]:
        """(value, dtype) of output `name` in a cell with no result (default NaN, float64)."""
        return self.fills.get(name, (float("nan"), "float64"))
