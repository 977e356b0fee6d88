"""Reductions of study archives, one module per study kind: `urmx.analysis.grid` (peaks,
instability, histories, resonance of a time-history grid; its public names are also this
package's, as `urmx.analysis` was that module), `urmx.analysis.ida` (capacities, fits,
measures and risk of an IDA archive), `urmx.analysis.sampling` (sensitivity and spread of a
sampling study) and `urmx.analysis.predictors` (which wall and diaphragm properties predict
the capacity over a wall population)."""

from .grid import *  # noqa: F403 - `urmx.analysis.<name>` of the module it was
from .grid import MissingDataError  # noqa: F401 - named for readers and linters
