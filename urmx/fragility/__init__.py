"""Collapse fragility of one wall: its rocking mechanism, intensity measures, the
collapse-capacity search, lognormal fits with their confidence, and collapse risk at a site,
in numpy (and scipy for the fits), with no study, dask or xarray in it.

The collapse capacity of a wall under a record is the smallest intensity at which the
wall collapses when the record is scaled up (:func:`collapse_capacity`,
`urmx.fragility.capacity`). Over a record library the capacities give a lognormal collapse
fragility, fitted by maximum likelihood with censoring (:func:`fit_lognormal`), or from
counts of collapses at a few intensity levels (:func:`fit_multiple_stripe`,
`urmx.fragility.fits`), each with bootstrap intervals of its median and dispersion. The
intensity measures (``im``: ``pga``, ``pgv``, ``sa_wall``, ``sa_diaphragm``, ``sa_avg``,
``scale``) are `urmx.fragility.intensity`; ``sa_wall`` is taken at the wall's effective
rocking period (`urmx.fragility.mechanism`), ``sa_avg`` over the periods of the wall and its
diaphragm. :func:`collapse_rate` integrates a fragility over a site's hazard curve into a
mean annual frequency and a probability of collapse (`urmx.fragility.risk`).

A study of one capacity per (wall, diaphragm, record, cor) cell is the IDA study kind
(`urmx.study.kinds.ida`, a ``[study.ida]`` table), which runs this package on each batch;
this package knows nothing of studies.
"""

from __future__ import annotations

import numpy as np

from ..kernel import run as kernel
from ..kernel import warm_up_capacity as warm_kernel
from ..model import Wall
from ..records.measures import dominant_frequency
from ..records.record import Record, as_record
from .capacity import (
    DEFAULT_IM,
    HINT_EXPONENT,
    MARGIN,
    MAX_STRIDE,
    RATIO_TARGET,
    RTOL,
    START_FRACTION,
    STEP,
    CollapseCapacity,
    cell_capacity,
    collapse_capacity,
    search,
)
from .fits import (
    CONFIDENCE,
    RESAMPLES,
    LognormalFit,
    bootstrap_lognormal,
    fit_lognormal,
    fit_multiple_stripe,
    stripe_counts,
)
from .intensity import (
    DAMPING,
    IM_ATTRS,
    IMS,
    MAX_INTENSITY,
    RECORD_IMS,
    SA_AVG_PERIODS,
    check_im,
    record_intensities,
    record_intensity,
    record_measures,
    sa_avg_periods,
    sa_avg_range,
    spectral_intensities,
)
from .mechanism import (
    DESIGN_FRACTION,
    diaphragm_period,
    rocking_period,
    static_acceleration,
    trilinear,
)
from .risk import (
    CollapseRisk,
    DesignSpectrum,
    HazardCurve,
    collapse_rate,
    design_sa,
    read_hazard,
    read_spectrum,
)

__all__ = [
    "collapse_capacity", "cell_capacity", "CollapseCapacity", "search", "MARGIN", "HINT_EXPONENT",
    "fit_lognormal",
    "fit_multiple_stripe", "stripe_counts", "LognormalFit", "record_intensity",
    "record_intensities", "spectral_intensities", "rocking_period", "static_acceleration",
    "diaphragm_period", "trilinear", "Record", "as_record", "check_im", "warm_up", "IMS",
    "IM_ATTRS", "MAX_INTENSITY", "DEFAULT_IM", "RTOL", "STEP", "MAX_STRIDE", "RATIO_TARGET",
    "START_FRACTION", "DAMPING", "DESIGN_FRACTION", "RECORD_IMS", "record_measures",
    "sa_avg_range", "sa_avg_periods", "SA_AVG_PERIODS", "bootstrap_lognormal", "CONFIDENCE",
    "RESAMPLES", "collapse_rate", "CollapseRisk", "HazardCurve", "read_hazard",
    "DesignSpectrum", "read_spectrum", "design_sa",
]


def warm_up() -> None:
    """Run every compiled function a collapse-capacity batch uses once (the kernel, the
    response and Fourier spectra), so numba compiles them or loads them from its on-disk
    cache now; ``client.run(warm_up)`` does it on every dask worker before timing."""
    warm_kernel()
    wall = Wall(0.23, 3.68, 2 / 3, 20000.0, top_mass=12000.0, top_stiffness=815e3,
                top_damping=0.12)
    t = np.arange(500) * 0.01
    acc = np.sin(2 * np.pi * 1.5 * t) * np.exp(-t)
    unit = float(record_intensities(acc, 0.01, "sa_wall", [wall])[0])
    cell_capacity(kernel, wall, acc, 0.01, unit, "sa_wall", 0.8, "scale", 0.1, 2.0, 50.0)
    record_intensities(acc, 0.01, "pgv", [wall])
    dominant_frequency(acc, 0.01)
