"""Collapse fragility with modelling uncertainty: the lognormal fit of the collapse
capacities of one wall and diaphragm over its records for each sample (record-to-record),
over records and samples together (total), and the parts of the total dispersion.

With ``C[s, r]`` the capacity of sample ``s`` under record ``r``:

- ``median[s]``, ``dispersion[s]``: the fit over the records of sample ``s`` (the model
  held at one sample: the record-to-record fragility of that model);
- ``total_median``, ``total_dispersion``: the fit over every (sample, record), which
  includes what we do not know of the model (FEMA P695 adds a modelling dispersion to
  the record-to-record one; here it is computed);
- ``record_dispersion``: the root mean square of ``dispersion[s]`` (record-to-record, the
  model known); ``model_dispersion``: the standard deviation of ``ln median[s]`` (the
  model's part). Their root sum of squares is close to ``total_dispersion`` when the
  records' and the model's effects add in the log.

Fits are by maximum likelihood with censoring (`urmx.fragility.fit_lognormal`), in closed
form when no capacity is censored (the mean and population standard deviation of the
logs, which the likelihood's maximum is).
"""

from __future__ import annotations

import math

import numpy as np

from ..fragility import fit_lognormal


def lognormal_fit(capacities, censored=None) -> tuple[float, float]:
    """(median, dispersion) of the lognormal fit of capacities (NaN entries left out);
    (NaN, NaN) where no fit exists (fewer than two distinct uncensored capacities).

    Parameters
    ----------
    capacities : array_like
        Collapse intensities. [units of the intensity]
    censored : array_like of bool, optional
        True where the capacity is a lower bound.
    """
    x = np.asarray(capacities, dtype=float).ravel()
    c = np.zeros(x.shape, bool) if censored is None else \
        np.asarray(censored, dtype=float).ravel() == 1
    keep = np.isfinite(x)
    x, c = x[keep], c[keep]
    if np.unique(x[~c]).size < 2 or np.any(x <= 0):
        return math.nan, math.nan
    if not c.any():
        lx = np.log(x)
        return float(math.exp(lx.mean())), float(lx.std())
    f = fit_lognormal(x, c)
    return f.median, f.dispersion


def modelling_fit(capacities, censored=None) -> dict[str, np.ndarray | float]:
    """The fits of a (sample, record) table of one wall and diaphragm (module docstring).

    Parameters
    ----------
    capacities : array_like, shape (samples, records)
        Collapse intensities (NaN where not run). [units of the intensity]
    censored : array_like of bool, shape (samples, records), optional
        1 (or True) where the capacity is censored.

    Returns
    -------
    dict
        ``median`` and ``dispersion`` per sample (arrays), ``total_median``,
        ``total_dispersion``, ``record_dispersion`` and ``model_dispersion`` (floats).
    """
    cap = np.asarray(capacities, dtype=float)
    cen = np.zeros(cap.shape) if censored is None else np.asarray(censored, dtype=float)
    fits = [lognormal_fit(cap[s], cen[s]) for s in range(cap.shape[0])]
    median = np.array([f[0] for f in fits])
    disp = np.array([f[1] for f in fits])
    total = lognormal_fit(cap, cen)
    ok = np.isfinite(median) & np.isfinite(disp)
    return {"median": median, "dispersion": disp, "total_median": total[0],
            "total_dispersion": total[1],
            "record_dispersion": float(np.sqrt(np.mean(disp[ok] ** 2))) if ok.any()
            else math.nan,
            "model_dispersion": float(np.std(np.log(median[ok]), ddof=1)) if ok.sum() > 1
            else math.nan}
