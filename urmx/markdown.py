"""Markdown tables and numbers for the report writers (paper report, fragility report, records,
calibration, benchmarks)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np


def row(cells: Sequence) -> str:
    """One table row: ``| a | b |`` (an empty cell is ``| |``)."""
    return "|" + "|".join(f" {c} " if str(c) else " " for c in cells) + "|"


def table(header: Sequence, rows: Iterable[Sequence]) -> list[str]:
    """A Markdown table as lines: the header, the separator and one line per row.

    Parameters
    ----------
    header : sequence
        Column headings (any objects; formatted with `str`).
    rows : iterable of sequences
        Cells of each row, as many as the header.

    Returns
    -------
    list of str
        No blank line after the table; the caller separates blocks.
    """
    return [row(header), "|" + "---|" * len(header), *(row(r) for r in rows)]


def number(value, digits: int = 3) -> str:
    """A number for a table cell: `digits` significant digits, ``-`` for NaN, ``inf`` and
    ``-inf`` as such."""
    value = float(value)
    if not np.isfinite(value):
        return "inf" if value > 0 else ("-" if np.isnan(value) else "-inf")
    return f"{value:.{digits}g}"
