"""The paper's numbers: ``catalog/paper.toml`` read as a :class:`Paper`, and Table V's
significant frequency range of each record from the records manifest.

Nothing in urmx.paper types a paper number: texts are generated from these files and from
the archives.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

from .. import records
from ..catalog import CatalogError, catalog_dir
from ..errors import MissingFileError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

@dataclass(frozen=True)
class Paper:
    """The contents of ``catalog/paper.toml`` (see that file for every key and unit)."""

    data: dict
    path: Path | None = None

    def __getitem__(self, key: str) -> Any:
        return self.data[key]

    @property
    def cor(self) -> float:
        return float(self.data["parametric"]["cor"])

    @property
    def record(self) -> str:
        """The record of Figs. 6-8 and Table VI."""
        return str(self.data["parametric"]["response_record"])

    @property
    def height(self) -> float:
        """Height of the wall of Fig. 8 and Table VI. [m]"""
        return float(self.data["parametric"]["fig8_height"])

    @property
    def panel_records(self) -> list[str]:
        return list(self.data["parametric"]["panel_records"])

    @property
    def timber(self) -> list[str]:
        return list(self.data["parametric"]["timber"])

    @property
    def stiff(self) -> str:
        return str(self.data["parametric"]["stiff"])

    @property
    def pinned(self) -> str:
        return str(self.data["parametric"]["pinned"])


def load_paper(path: str | os.PathLike | None = None) -> Paper:
    """Read ``catalog/paper.toml`` (or ``path``)."""
    return _load_paper(str(path) if path is not None else str(catalog_dir() / "paper.toml"))


@lru_cache(maxsize=4)
def _load_paper(path: str) -> Paper:
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise MissingFileError(f"{path}: no such file (the paper's numbers)") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CatalogError(f"{path}: cannot be read as a TOML file "
                           f"({getattr(exc, 'strerror', None) or exc})") from None
    try:
        return Paper(tomllib.loads(text), Path(path))
    except tomllib.TOMLDecodeError as exc:
        raise CatalogError(f"{path}: not valid TOML: {exc}") from None


def significant_frequency(manifest: dict | None = None) -> dict[str, tuple[float, float]]:
    """Table V's significant frequency range of every paper record, from the records
    manifest's ``paper_frequency_range_hz`` (``{record id: (low, high)}`` [Hz])."""
    if manifest is None:
        manifest = records.manifest()
    out = {}
    for rid, entry in manifest.items():
        text = entry.get("paper_frequency_range_hz")
        if text:
            lo, hi = (float(x) for x in str(text).split("-"))
            out[rid] = (lo, hi)
    return out


def records_manifest() -> dict:
    """The records manifest (:func:`urmx.records.manifest`), ``{}`` where it is missing or
    cannot be read (the stand-in notes and the stated intensities then stay empty)."""
    try:
        return records.manifest()
    except (FileNotFoundError, ValueError):
        return {}
