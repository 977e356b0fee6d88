"""Collapse risk of a wall at a site: a lognormal collapse fragility integrated over a hazard
curve (:func:`collapse_rate`), and the margin of a median capacity over a design spectrum
(:func:`design_sa`), numpy only.

The mean annual frequency of collapse is ``lambda_c = integral P(C | x) |d lambda(x)|``
(Cornell, Jalayer, Hamburger & Foutch 2002, J. Struct. Eng. 128(4)), computed as the
expectation of the hazard over the capacity, ``integral f_C(x) lambda(x) dx``, on 4001
points spanning the fragility's median times ``exp(+-8 beta)``. The hazard curve is
interpolated linearly in ``(ln x, ln lambda)``; beyond its ends it is extended along its end
segments (a power law), and the share of ``lambda_c`` that comes from there is reported
(``CollapseRisk.tail_share``): where it is large, the curve does not reach the intensities
that collapse the wall. The probability of collapse in ``years`` is
``1 - exp(-lambda_c years)`` (Poisson occurrences).

Files. A hazard curve is a CSV file of two columns, intensity and mean annual frequency
of exceedance, whose header names the measure and the units of each column::

    # any comment lines (the source of the numbers)
    pga [g],annual_rate [1/yr]
    0.1,0.0213
    ...

The measure is one of `urmx.fragility.RECORD_IMS` (``pga``, ``pgv``, ``sa_wall``,
``sa_diaphragm``, ``sa_avg``) or ``sa(T)``, the 5 %-damped Sa at a fixed period T [s]
(``sa(0.3) [g]``), in its units (`urmx.fragility.IM_ATTRS`: m s-2, m s-1) or, for an
acceleration, in ``g`` (standard gravity, 9.80665 m s-2); it must be the fit's measure.

Computed or extrapolated. A comment line ``# computed_to = 0.6`` (in the intensity
column's units) says up to which intensity the curve is computed; the rows beyond it are
an extrapolation (the illustrative curve: a power law beyond the standard's 2500-year
point). Without it the whole file counts as computed. Every rate comes with the share of
it from ground motions beyond that intensity (``CollapseRisk.extrapolated_share``; beyond
the file's last row the curve is extended along its end segment, which is extrapolation
too), and its deaggregation by intensity (`deaggregate`): the share of the rate from
ground motions in each band of return periods of the intensity (`BAND_PERIODS`), i.e.
``integral over the band of P(C | x) |d lambda(x)|``.

OpenQuake. :func:`read_hazard` also reads the engine's ``hazard_curve-*.csv`` outputs
(``oq engine --export-outputs``; the layout of ``openquake/calculators/export/hazard.py``,
``export_hcurves_by_imt_csv``): a first comment line holding ``investigation_time=...``
and ``imt='PGA'`` (or ``SA(0.3)``, ``AvgSA``, ``PGV``), a header ``lon,lat[,depth],
poe-<iml>,...`` and one row per site of probabilities of exceedance in the investigation
time, converted to annual rates ``-ln(1 - poe) / investigation_time`` (Poisson). PGA, SA
and AvgSA are in g, PGV in cm/s. One site is read (``site=``, default the first row);
levels whose probability is 0 or 1 are left out (no rate). Every level of an engine file
is computed: ``computed_to`` is its last level. ``AvgSA`` is taken as urmx's ``sa_avg``:
the engine's ``avg_periods`` must be the wall's range (`urmx.fragility.sa_avg_range`),
which the file does not state.

A design spectrum is a CSV file ``period [s],sa [g]`` (or ``sa [m s-2]``) of the 5 %-damped
spectral acceleration against period, interpolated linearly in period.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, MissingFileError, got, path_argument
from ..records.readers import STANDARD_GRAVITY
from .intensity import IM_ATTRS, RECORD_IMS

YEARS = 50.0  # default exposure time of `collapse_rate` [yr]
SPAN = 8.0  # the integral covers the median times exp(+-SPAN dispersion)
POINTS = 4001  # points of the integral
RATE_UNITS = ("1/yr", "yr-1", "1/year", "a-1")
#: return periods [yr] of the intensities bounding the deaggregation's bands
BAND_PERIODS = (100.0, 500.0, 2500.0, 10000.0)
_SA_T = re.compile(r"^sa\(\s*([0-9.eE+-]+)\s*\)$")
_COMPUTED = re.compile(r"^#\s*computed_to\s*=\s*([0-9.eE+-]+)\s*$")
_HEADER = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*(?:\(\s*[0-9.eE+-]+\s*\))?)\s*\[\s*([^\]]*?)"
                     r"\s*\]\s*$")


@dataclass(frozen=True)
class HazardCurve:
    """Intensity against mean annual frequency of exceedance.

    Attributes
    ----------
    intensity : ndarray
        Increasing, positive. [units]
    rate : ndarray
        Decreasing, positive. [1/yr]
    im, units : str or None
        The measure and its units (None for a pair of arrays).
    source : str
        The file, or ``"arrays"``.
    computed_to : float or None
        The last intensity the file marks as computed (beyond: extrapolated); None: all
        of it. [units]
    """

    intensity: np.ndarray
    rate: np.ndarray
    im: str | None = None
    units: str | None = None
    source: str = "arrays"
    computed_to: float | None = None


@dataclass(frozen=True)
class CollapseRisk:
    """Result of :func:`collapse_rate`.

    Attributes
    ----------
    rate : float
        Mean annual frequency of collapse. [1/yr]
    probability : float
        Probability of at least one collapse in `years`. [1]
    years : float
        Exposure time. [yr]
    tail_share : float
        Share of `rate` from capacities beyond the hazard curve's intensities (its end
        segments extended). [1]
    im, units : str or None
        The measure and units of the hazard curve and the fit.
    extrapolated_share : float
        Share of `rate` from ground motions beyond the last intensity the hazard file
        marks as computed (module docstring). [1]
    bands : tuple of (float, float, float)
        The deaggregation: (low, high, share) per band of intensity (`deaggregate`).
        [units], [units], [1]
    """

    rate: float
    probability: float
    years: float
    tail_share: float
    im: str | None = None
    units: str | None = None
    extrapolated_share: float = math.nan
    bands: tuple = ()


def _read_rows(path: Path, what: str) -> tuple[list[tuple[str, str]], list[tuple[int, list]]]:
    """The (name, units) of each column of a two-column CSV file's header and its numeric
    rows (line number, values); errors name the file and line."""
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except FileNotFoundError:
        raise MissingFileError(f"{what} {str(path)!r} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{what} {str(path)!r} cannot be read: {exc}") from None
    header, rows = None, []
    for k, raw in enumerate(lines, start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        cells = [c.strip() for c in line.split(",")]
        if len(cells) != 2:
            raise InputError(f"{path}:{k}: {what} rows have two columns; got {line!r}")
        if header is None:
            found = [_HEADER.match(c) for c in cells]
            if not all(found):
                raise InputError(f"{path}:{k}: the header must name each column and its units, "
                                 f"like 'pga [g],annual_rate [1/yr]'; got {line!r}")
            header = [(m.group(1), m.group(2)) for m in found]
            continue
        try:
            values = [float(c) for c in cells]
        except ValueError:
            raise InputError(f"{path}:{k}: {line!r} is not two numbers") from None
        rows.append((k, values))
    if header is None or len(rows) < 2:
        raise InputError(f"{what} {str(path)!r} needs a header and at least two rows")
    return header, rows


def measure(name: str, where: str = "hazard curve") -> str:
    """The canonical name of an intensity measure: one of `RECORD_IMS`, or ``sa(T)`` with
    T written as ``%g`` (``sa(0.30)`` -> ``sa(0.3)``); anything else is refused."""
    name = name.strip()
    if name in RECORD_IMS:
        return name
    m = _SA_T.match(name.lower())
    if m:
        try:
            period = float(m.group(1))
        except ValueError:
            period = math.nan
        if math.isfinite(period) and period > 0:
            return f"sa({period:g})"
    raise InputError(f"{where}: the first column must be an intensity measure "
                     f"({', '.join(RECORD_IMS)}, or sa(T) with the period T in s); got "
                     f"{name!r}")


def measure_units(im: str) -> str:
    """The SI units of a measure (`measure`): m s-2 for sa(T)."""
    return "m s-2" if im.startswith("sa(") else IM_ATTRS[im][0]


def _to_si(im: str, units: str, where: str) -> float:
    """Factor from `units` to the SI units of measure `im` (g for accelerations)."""
    si = measure_units(im)
    if units == si:
        return 1.0
    if units == "g" and si == "m s-2":
        return STANDARD_GRAVITY
    raise InputError(f"{where}: units {units!r} of {im!r}: use {si!r}"
                     + (" or 'g'" if si == "m s-2" else ""))


def _monotone(x: np.ndarray, rows: list, what: str, rising: bool, where: str) -> None:
    step = np.diff(x) if rising else -np.diff(x)
    if np.any(~np.isfinite(x)) or np.any(x <= 0):
        k = int(np.argmax(~np.isfinite(x) | (x <= 0)))
        raise InputError(f"{where}:{rows[k][0]}: {what} {float(x[k])!r} must be positive and "
                         "finite")
    if np.any(step <= 0):
        k = int(np.argmax(step <= 0)) + 1
        raise InputError(f"{where}:{rows[k][0]}: {what} must {'rise' if rising else 'fall'} "
                         f"from row to row; got {float(x[k - 1])!r} then {float(x[k])!r}")


def read_hazard(path: str | os.PathLike, site: int = 0) -> HazardCurve:
    """A hazard curve from a CSV file, plain or the OpenQuake engine's (module docstring),
    in the measure's SI units.

    Parameters
    ----------
    path : str or path-like
    site : int
        The row (site) of an OpenQuake file (0: the first).

    Raises
    ------
    urmx.errors.InputError
        A header without measure or units, an unknown measure or units, a row that is not
        two numbers, intensities that do not rise or rates that do not fall.
    """
    path_argument("read_hazard", "path", path)
    path = Path(path)
    try:
        first = next((ln for ln in path.read_text(encoding="utf-8").splitlines()
                      if ln.strip()), "")
    except FileNotFoundError:
        raise MissingFileError(f"hazard curve {str(path)!r} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"hazard curve {str(path)!r} cannot be read: {exc}") from None
    if first.lstrip().startswith("#") and "investigation_time" in first:
        return read_openquake(path, site)
    header, rows = _read_rows(path, "hazard curve")
    (name, units), (rname, runits) = header
    im = measure(name, str(path))
    if runits not in RATE_UNITS:
        raise InputError(f"{path}: the second column ({rname}) must be a mean annual "
                         f"frequency of exceedance in '1/yr'; got units {runits!r}")
    data = np.array([v for _, v in rows])
    factor = _to_si(im, units, str(path))
    intensity = data[:, 0] * factor
    _monotone(intensity, rows, "intensity", True, str(path))
    _monotone(data[:, 1], rows, "annual rate", False, str(path))
    computed = None
    for line in path.read_text(encoding="utf-8").splitlines():
        m = _COMPUTED.match(line.strip())
        if m:
            try:
                computed = float(m.group(1)) * factor
            except ValueError:
                raise InputError(f"{path}: {line.strip()!r}: computed_to must be a "
                                 "number") from None
    return HazardCurve(intensity, data[:, 1], im, measure_units(im), str(path), computed)


#: OpenQuake's intensity measure types: urmx's name and the factor of the engine's units
_OQ_IMT = {"PGA": ("pga", STANDARD_GRAVITY), "PGV": ("pgv", 0.01),
           "AVGSA": ("sa_avg", STANDARD_GRAVITY)}


def read_openquake(path: str | os.PathLike, site: int = 0) -> HazardCurve:
    """A hazard curve from an OpenQuake engine ``hazard_curve-*.csv`` file (module
    docstring): the site in row `site`, probabilities of exceedance in the investigation
    time turned into annual rates."""
    path = Path(path)
    lines = [ln for ln in path.read_text(encoding="utf-8").splitlines() if ln.strip()]
    meta = lines[0]
    t = re.search(r"investigation_time\s*=\s*([0-9.eE+-]+)", meta)
    imt = re.search(r"imt\s*=\s*['\"]?([A-Za-z]+(?:\([0-9.]+\))?)", meta)
    if t is None or imt is None:
        raise InputError(f"{path}:1: an OpenQuake hazard curve names investigation_time=... "
                         f"and imt='...' in its first line; got {meta.strip()!r}")
    years = float(t.group(1))
    name = imt.group(1)
    if name.upper() in _OQ_IMT:
        im, factor = _OQ_IMT[name.upper()]
    elif name.upper().startswith("SA("):
        im, factor = measure(name.lower(), str(path)), STANDARD_GRAVITY
    else:
        raise InputError(f"{path}:1: imt {name!r} is not one urmx computes (PGA, PGV, "
                         "SA(T), AvgSA)")
    head = [c.strip() for c in lines[1].split(",")]
    cols = [k for k, c in enumerate(head) if c.startswith("poe-")]
    if len(cols) < 2:
        raise InputError(f"{path}:2: the header needs poe-<level> columns; got {lines[1]!r}")
    if not 0 <= site < len(lines) - 2:
        raise InputError(f"{path}: site {site} is not a row (the file has "
                         f"{len(lines) - 2} sites)")
    cells = lines[2 + site].split(",")
    try:
        levels = np.array([float(head[k][4:]) for k in cols])
        poe = np.array([float(cells[k]) for k in cols])
    except (ValueError, IndexError):
        raise InputError(f"{path}:{3 + site}: {lines[2 + site]!r} is not a row of "
                         "probabilities for the header's levels") from None
    keep = (poe > 0) & (poe < 1)
    if keep.sum() < 2:
        raise InputError(f"{path}: fewer than two levels with a probability of exceedance "
                         "between 0 and 1")
    rate = -np.log1p(-poe[keep]) / years
    rows = [(3 + site, None)] * int(keep.sum())
    _monotone(levels[keep], rows, "intensity", True, str(path))
    _monotone(rate, rows, "annual rate", False, str(path))
    x = levels[keep] * factor
    return HazardCurve(x, rate, im, measure_units(im), str(path), float(x[-1]))


def scaled_curve(curve: HazardCurve, factor: float, im: str) -> HazardCurve:
    """The curve of another spectral measure whose uniform-hazard ordinates are `factor`
    times this one's at every return period (a code spectrum scaled by its return period
    factor, as NZS 1170.5 does: Sa(T) = Ch(T) Z R N): the intensities (and `computed_to`)
    times `factor`, the rates unchanged."""
    return HazardCurve(curve.intensity * factor, curve.rate, im, measure_units(im),
                       f"{curve.source} scaled x{factor:.4g} to {im}",
                       None if curve.computed_to is None else curve.computed_to * factor)


def _curve(hazard, fit) -> HazardCurve:
    """The hazard curve of a path or a pair, checked against the fit's measure."""
    if isinstance(hazard, HazardCurve):
        curve = hazard
    elif isinstance(hazard, (str, os.PathLike)):
        curve = read_hazard(hazard)
    elif isinstance(hazard, (tuple, list)) and len(hazard) == 2:
        x, lam = (np.asarray(v, dtype=float).ravel() for v in hazard)
        if x.size != lam.size or x.size < 2:
            raise InputError(f"hazard: intensity and annual_rate need the same length >= 2 "
                             f"(got {x.size} and {lam.size})")
        rows = [(k, None) for k in range(x.size)]
        _monotone(x, rows, "intensity", True, "hazard (entry)")
        _monotone(lam, rows, "annual rate", False, "hazard (entry)")
        curve = HazardCurve(x, lam, getattr(fit, "im", None), getattr(fit, "units", None))
    else:
        raise InputError(f"hazard must be a CSV file or a pair (intensity, annual_rate) of "
                         f"arrays, not {type(hazard).__name__}")
    fim, funits = getattr(fit, "im", None), getattr(fit, "units", None)
    try:
        fim = measure(fim) if fim is not None else None
    except InputError:
        pass  # a measure of no hazard curve (the scale factor): refused just below
    if curve.im is not None and fim is not None and (curve.im, curve.units) != (fim, funits):
        raise InputError(f"{curve.source}: the hazard curve is in {curve.im} [{curve.units}], "
                         f"the fragility in {fim} [{funits}]: they must be the same measure")
    return curve


def collapse_rate(fit, hazard, years: float = YEARS) -> CollapseRisk:
    """Mean annual frequency and probability of collapse of a lognormal fragility over a
    hazard curve (module docstring).

    Parameters
    ----------
    fit : LognormalFit
        The fragility (anything with ``median`` and ``dispersion``; its ``im`` and ``units``,
        when set, must be the hazard curve's). [units of the intensity]
    hazard : str, path or (array_like, array_like)
        A hazard curve CSV file (module docstring), or ``(intensity, annual_rate)`` in the
        fit's units and [1/yr].
    years : float
        Exposure time of the probability. [yr]

    Returns
    -------
    CollapseRisk
        ``rate`` [1/yr], ``probability`` [1] in `years`, ``tail_share`` [1], its
        deaggregation ``bands`` and ``extrapolated_share`` [1] (`deaggregate`).
    """
    if not (hasattr(fit, "median") and hasattr(fit, "dispersion")):
        raise InputError(f"collapse_rate: fit must be a fragility with median and dispersion "
                         f"(urmx.fragility.fit_lognormal), got {got(fit)}")
    try:
        years = float(years)
    except (TypeError, ValueError):
        raise InputError(f"years={years!r} must be a number of years") from None
    if not (math.isfinite(years) and years > 0):
        raise InputError(f"years={years!r} must be a positive number of years")
    median, beta = float(fit.median), float(fit.dispersion)
    if not (math.isfinite(median) and median > 0 and math.isfinite(beta) and beta > 0):
        raise InputError(f"the fragility needs a positive median and dispersion; got "
                         f"{median!r}, {beta!r}")
    curve = _curve(hazard, fit)
    rate, tail = rates(curve, np.array([median]), np.array([beta]))
    bands, extrapolated = deaggregate(curve, median, beta)
    return CollapseRisk(float(rate[0]), float(-np.expm1(-rate[0] * years)), years,
                        float(tail[0]), curve.im, curve.units, extrapolated, bands)


def rates(curve: HazardCurve, median, dispersion,
          points: int = POINTS) -> tuple[np.ndarray, np.ndarray]:
    """Mean annual frequencies of collapse [1/yr] and their tail shares [1] of many
    lognormal fragilities (`median` [units of the curve] and `dispersion` [1], arrays of one
    shape) over one hazard curve, vectorised (module docstring)."""
    m = np.asarray(median, dtype=float)[..., None]
    b = np.asarray(dispersion, dtype=float)[..., None]
    lx, ll = np.log(curve.intensity), np.log(curve.rate)
    z = np.linspace(-SPAN, SPAN, int(points))
    u = np.log(m) + z * b
    log_rate = np.interp(u, lx, ll)
    lo, hi = u < lx[0], u > lx[-1]
    log_rate = np.where(lo, ll[0] + (u - lx[0]) * (ll[1] - ll[0]) / (lx[1] - lx[0]), log_rate)
    log_rate = np.where(hi, ll[-1] + (u - lx[-1]) * (ll[-1] - ll[-2]) / (lx[-1] - lx[-2]),
                        log_rate)
    f = np.exp(-0.5 * z * z + log_rate) / math.sqrt(2 * math.pi)  # density in z
    dz = z[1] - z[0]
    total = (np.sum(f, -1) - 0.5 * (f[..., 0] + f[..., -1])) * dz
    out = np.where(lo | hi, f, 0.0)
    tail = (np.sum(out, -1) - 0.5 * (out[..., 0] + out[..., -1])) * dz
    with np.errstate(invalid="ignore", divide="ignore"):
        return total, np.where(total > 0, tail / total, 0.0)


def _log_rate(curve: HazardCurve, u: np.ndarray) -> np.ndarray:
    """ln lambda at ln-intensities `u`: linear in (ln x, ln lambda), extended along the end
    segments."""
    lx, ll = np.log(curve.intensity), np.log(curve.rate)
    out = np.interp(u, lx, ll)
    out = np.where(u < lx[0], ll[0] + (u - lx[0]) * (ll[1] - ll[0]) / (lx[1] - lx[0]), out)
    return np.where(u > lx[-1], ll[-1] + (u - lx[-1]) * (ll[-1] - ll[-2])
                    / (lx[-1] - lx[-2]), out)


def band_edges(curve: HazardCurve, periods=BAND_PERIODS) -> np.ndarray:
    """The intensities whose annual rate of exceedance is 1 / `periods` [yr] on the curve
    (extended along its end segments when needed), increasing. [units]"""
    lx, ll = np.log(curve.intensity), np.log(curve.rate)
    target = -np.log(np.asarray(periods, dtype=float))
    # ln lambda falls with ln x: invert segment by segment, extending the end segments
    inner = np.interp(-target, -ll, lx)
    lo = lx[0] + (target - ll[0]) * (lx[1] - lx[0]) / (ll[1] - ll[0])
    hi = lx[-1] + (target - ll[-1]) * (lx[-1] - lx[-2]) / (ll[-1] - ll[-2])
    u = np.where(target > ll[0], lo, np.where(target < ll[-1], hi, inner))
    return np.exp(u)


def deaggregate(curve: HazardCurve, median: float, dispersion: float,
                periods=BAND_PERIODS, points: int = POINTS) -> tuple[tuple, float]:
    """Where a collapse rate comes from: the shares of ``integral P(C | x) |d lambda(x)|``
    from ground motions in each band of intensity between the intensities of return
    periods `periods` (`band_edges`; the first band from 0, the last to infinity), and the
    share from intensities beyond the curve's ``computed_to`` (its last row when None).

    Returns
    -------
    (tuple of (float, float, float), float)
        ``((low, high, share), ...)`` [units], [units], [1], and the extrapolated share [1].
    """
    from scipy.special import ndtr

    z = np.linspace(-SPAN, SPAN, int(points))
    u = math.log(median) + z * dispersion
    lam = np.exp(_log_rate(curve, u))
    mid = 0.5 * (u[1:] + u[:-1])
    part = ndtr((mid - math.log(median)) / dispersion) * (lam[:-1] - lam[1:])
    part = np.r_[part, lam[-1]]  # beyond the grid every ground motion collapses the wall
    where = np.r_[mid, u[-1]]
    total = float(part.sum())
    edges = np.r_[0.0, band_edges(curve, periods), np.inf]
    x = np.exp(where)
    bands = tuple((float(lo), float(hi), float(part[(x >= lo) & (x < hi)].sum() / total))
                  for lo, hi in zip(edges[:-1], edges[1:], strict=True))
    last = curve.intensity[-1] if curve.computed_to is None else curve.computed_to
    return bands, float(part[x > last].sum() / total)


@dataclass(frozen=True)
class DesignSpectrum:
    """5 %-damped spectral acceleration against period.

    Attributes
    ----------
    period : ndarray
        Increasing, >= 0. [s]
    sa : ndarray
        [m s-2]
    source : str
    """

    period: np.ndarray
    sa: np.ndarray
    source: str = "arrays"


def read_spectrum(path: str | os.PathLike) -> DesignSpectrum:
    """A design spectrum from a CSV file ``period [s],sa [g]`` (or ``sa [m s-2]``).

    Parameters
    ----------
    path : str or path-like
        The CSV file.

    Raises
    ------
    urmx.errors.InputError
        A bad header, a row that is not two numbers, periods that do not rise, a Sa that is
        not positive.
    """
    path_argument("read_spectrum", "path", path)
    path = Path(path)
    header, rows = _read_rows(path, "design spectrum")
    (pname, punits), (sname, sunits) = header
    if (pname, punits) != ("period", "s") or sname != "sa":
        raise InputError(f"{path}: the header must be 'period [s],sa [g]' (or sa [m s-2]); "
                         f"got {pname} [{punits}],{sname} [{sunits}]")
    factor = _to_si("sa_wall", sunits, str(path))
    data = np.array([v for _, v in rows])
    if np.any(data[:, 0] < 0) or np.any(np.diff(data[:, 0]) <= 0):
        k = int(np.argmax(np.r_[data[0, 0] < 0, np.diff(data[:, 0]) <= 0]))
        raise InputError(f"{path}:{rows[k][0]}: periods must be >= 0 and rise from row to "
                         f"row; got {float(data[k, 0])!r}")
    if np.any(~np.isfinite(data[:, 1])) or np.any(data[:, 1] <= 0):
        k = int(np.argmax(~np.isfinite(data[:, 1]) | (data[:, 1] <= 0)))
        raise InputError(f"{path}:{rows[k][0]}: sa {float(data[k, 1])!r} must be positive")
    return DesignSpectrum(data[:, 0], data[:, 1] * factor, str(path))


def design_sa(spectrum, period) -> np.ndarray:
    """The design spectral acceleration at `period` [s] (linear in period between the
    spectrum's rows). [m s-2]

    Parameters
    ----------
    spectrum : DesignSpectrum, str or path
        The spectrum or its CSV file.
    period : float or array_like
        Within the spectrum's periods. [s]
    """
    s = spectrum if isinstance(spectrum, DesignSpectrum) else read_spectrum(spectrum)
    t = np.asarray(period, dtype=float)
    out = (t < s.period[0]) | (t > s.period[-1]) | ~np.isfinite(t)
    if np.any(out):
        raise InputError(f"period {float(t[out].flat[0])!r} s is outside the design spectrum "
                         f"{s.source} ({s.period[0]:g}-{s.period[-1]:g} s)")
    return np.interp(t, s.period, s.sa)
