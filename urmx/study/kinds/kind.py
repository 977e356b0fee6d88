"""The `Kind` record: the names and functions a study kind declares (the protocol is
described in `urmx.study.kinds`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Kind:
    """A study kind: its names and functions (the protocol: `urmx.study.kinds`)."""

    name: str
    unit: str
    outputs: tuple[str, ...]
    tasks: Callable[..., list]
    run: Callable[..., dict]
    assemble: Callable[..., Any]
    table: str | None = None
    combines: tuple[str, ...] = ()
    parse: Callable[[Any], Any] | None = None
    dims: Callable[[Any], dict[str, list]] | None = None
    reopen: Callable[[Any], Any] | None = None
    counts: Callable[[Any], dict[str, int] | None] | None = None
    keys: tuple[str, ...] = ()  # the keys of its [study.<table>] (docs/study-files.md)

    def cell_dims(self, study: Any) -> dict[str, list]:
        """The kind's cell dimensions of `study` (``dims``, default ``study.dims``)."""
        return self.dims(study) if self.dims is not None else study.dims
