"""Limits a study is checked against before anything is built: how many values one of its
dimensions may hold.

A range ``{start, stop, step}`` is counted from its three numbers before its values are
made (`urmx.catalog.load_study`), so a step typed too small (1e-9 for 1e-2) is refused at
once with the file, key and line, instead of filling the memory.
"""

from __future__ import annotations

#: most values one dimension of a study may hold (a ``{start, stop, step}`` range included)
MAX_VALUES = 10**7
