"""The paper's layer: its numbers, the building fitted to them, its tables beside urmx's,
every finding of its Sections 6-7 as a criterion that can fail, and its four studies.

The paper's numbers live in one data file, ``catalog/paper.toml`` (:func:`load_paper`); the
significant frequency range of each record (Table V) is the records manifest's
``paper_frequency_range_hz``. Nothing here types a paper number: texts are generated from
those files and from the archives.

One module a concept; this face re-exports their public names (import them from here):

- ``studies``: :data:`STUDIES` and :func:`run_paper`, the library call of ``urmx paper``;
- ``numbers``: :class:`Paper`, :func:`load_paper`, :func:`significant_frequency`;
- ``calibration``: :func:`calibrate`, :func:`calibration_report`, :func:`table4`: the
  parametric building fitted to Table IV's frequencies and Table VI's instability
  displacement;
- ``tables``: :func:`table3`, :func:`table6`: the paper's tables beside urmx's;
- ``criteria``: :func:`statements`, :func:`findings`: one row per statement of Sections
  6-7, with its criterion, the measured value, the verdict and, where urmx disagrees, the
  measured cause (a re-run of the criterion with the other D5 model or another record) or
  "not known";
- ``shake_table``: :func:`verification`, :func:`intensity`: per test wall, the paper's best
  COR against the sweep, with the stand-in record's intensity and what the source says
  about the table input.

Submodules import each other directly, never this face.
"""

from __future__ import annotations

from .calibration import Calibration, calibrate, calibration_report, sdof_frequency, table4
from .criteria import (
    ALMOST_CONSTANT,
    IRREGULAR,
    MAGNITUDE_BAND,
    MANY,
    NO_RELATION,
    RATIO_FACTOR,
    SIGNIFICANT_FALL,
    SMALL_SHARE,
    Context,
    Finding,
    findings,
    statements,
)
from .numbers import Paper, load_paper, records_manifest, significant_frequency
from .shake_table import intensity, verification
from .studies import STUDIES, run_paper
from .tables import FAMILY1, TABLE3_QUANTITIES, table3, table6

__all__ = [
    "ALMOST_CONSTANT", "FAMILY1", "IRREGULAR", "MAGNITUDE_BAND", "MANY", "NO_RELATION",
    "RATIO_FACTOR", "SIGNIFICANT_FALL", "SMALL_SHARE", "STUDIES", "TABLE3_QUANTITIES",
    "Calibration", "Context", "Finding", "Paper", "calibrate", "calibration_report",
    "findings", "intensity", "load_paper", "records_manifest", "run_paper", "sdof_frequency",
    "significant_frequency", "statements", "table3", "table4", "table6", "verification",
]
