"""Modelling uncertainty: the sampler of a sampling study (its parameters, distributions and
seeded designs), what a sample does to a wall, sensitivity indices, and the collapse
fragility over records and samples together; numpy and scipy (SALib for Sobol' indices),
with no study, dask or xarray in it.

- `urmx.uncertainty.distributions`: ``uniform``, ``normal``, ``lognormal``, ``choice``
  (:func:`parse_distribution`, :class:`Distribution`);
- `urmx.uncertainty.sampler`: the parameters a study can sample (`PARAMETERS`), the
  ``[study.sampling]`` table (:func:`parse_sampling`, :class:`Sampling`, its seeded
  :meth:`Sampling.draw`), a sample applied to a wall (:func:`apply`) and the load-time
  check of every sample (:func:`check_samples`);
- `urmx.uncertainty.sensitivity`: partial rank correlations (:func:`prcc`), Sobol' indices
  (:func:`sobol_indices`), the record/model split of a spread (:func:`variance_split`);
- `urmx.uncertainty.spread`: the lognormal fits per sample and over records and samples
  together (:func:`modelling_fit`).

The sampling study kind that runs them is `urmx.study.kinds.sampling`; its report is
`urmx.reports.sampling`.
"""

from __future__ import annotations

from .distributions import Distribution, ParameterError, parse_distribution
from .sampler import (
    METHODS,
    PARAMETERS,
    Sampling,
    apply,
    check_samples,
    coordinate_name,
    parse_sampling,
    sample_values,
    unit_design,
)
from .sensitivity import R2_THRESHOLD, prcc, sobol_indices, variance_shares, variance_split
from .spread import lognormal_fit, modelling_fit

__all__ = [
    "Distribution", "ParameterError", "parse_distribution", "METHODS", "PARAMETERS",
    "Sampling", "apply", "check_samples", "coordinate_name", "parse_sampling",
    "sample_values", "unit_design", "prcc", "sobol_indices", "variance_split",
    "variance_shares", "R2_THRESHOLD",
    "lognormal_fit", "modelling_fit",
]
