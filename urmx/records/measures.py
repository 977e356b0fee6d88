"""Ground-motion measures: peaks, Arias intensity, durations, spectra.

Numpy/numba cores (``_nigam_jennings_peaks``, ``_fas``) with a labelled xarray shell.
All quantities SI; "g" appears only in labels. Units and long names come from the
variable registry (``urmx/variables.toml``).
"""

from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError, got, numbers_argument
from ..jitcache import jit
from ..variables import attrs, stamp
from .readers import STANDARD_GRAVITY, check_finite
from .record import Record, as_record

if TYPE_CHECKING:  # xarray is imported where a result is built: reading a record stays light
    import xarray as xr

#: default periods of the response spectrum [s]
DEFAULT_PERIODS = np.unique(np.concatenate([np.geomspace(0.02, 10.0, 120), [0.05, 0.1, 0.2,
                                                                           0.5, 1.0, 2.0]]))

#: default frequency grid of the smoothed Fourier spectrum [Hz]
DEFAULT_FREQUENCIES = np.geomspace(0.05, 50.0, 300)


def as_trace(record):
    """An :class:`obspy.Trace` from a Trace (returned as it is), a
    `urmx.records.record.Record` or an ``(array, dt)`` pair of acceleration samples
    [m s-2] and their time step [s] (checked by `urmx.records.record.as_record`)."""
    if hasattr(record, "stats") and hasattr(record, "data"):
        return record
    if isinstance(record, Record) or (isinstance(record, (tuple, list)) and len(record) == 2):
        from obspy import Trace

        rec = as_record(record)
        return Trace(data=rec.acceleration, header={"delta": rec.dt})
    raise InputError(f"expected an obspy Trace or an (array, dt) pair, not "
                     f"{type(record).__name__}")


def _series(trace):
    """(acceleration, dt) of a trace: a positive time step [s] and finite samples, or an
    error naming the trace (and the first NaN sample's index)."""
    if not (hasattr(trace, "stats") and hasattr(trace, "data")):
        raise InputError(f"trace must be an obspy Trace (urmx.records.read, load), got "
                         f"{got(trace)}")
    dt = float(trace.stats.delta)
    if not (np.isfinite(dt) and dt > 0):
        raise InputError(f"trace {trace.id!r} has time step {dt!r} s; it must be positive")
    return check_finite(trace.data, f"trace {trace.id!r}", dt), dt


def _check_damping(damping) -> float:
    """A damping ratio in (0, 1) [1], or an InputError naming the value."""
    try:
        z = float(damping)
    except (TypeError, ValueError):
        raise InputError(f"damping={damping!r} must be a ratio in (0, 1)") from None
    if not 0.0 < z < 1.0:
        raise InputError(f"damping={damping!r} must be a ratio in (0, 1) (0.05 = 5 % of "
                         "critical)")
    return z


def velocity(acceleration, dt: float) -> np.ndarray:
    """Ground velocity by the trapezoidal rule from rest, numpy only (no Trace). [m s-1]"""
    return _cumtrapz(np.asarray(acceleration, dtype=float), float(dt))


def _cumtrapz(y, dt):
    out = np.empty_like(y)
    out[0] = 0.0
    np.cumsum(0.5 * (y[1:] + y[:-1]) * dt, out=out[1:])
    return out


def arias_history(trace) -> np.ndarray:
    """Cumulative Arias intensity ``pi / (2 g) * integral a^2 dt`` at each sample [m s-1].

    Parameters
    ----------
    trace : obspy.Trace
        The record, acceleration [m s-2].
    """
    acc, dt = _series(trace)
    return np.pi / (2.0 * STANDARD_GRAVITY) * _cumtrapz(acc * acc, dt)


def _crossing(t, y, level):
    k = int(np.searchsorted(y, level))
    k = min(max(k, 1), len(y) - 1)
    y0, y1 = y[k - 1], y[k]
    return float(t[k - 1] + (t[k] - t[k - 1]) * ((level - y0) / (y1 - y0) if y1 > y0 else 0))


def significant_duration(trace, start: float = 0.05, end: float = 0.95) -> float:
    """Time between ``start`` and ``end`` fractions of the Arias intensity (D5-95) [s].

    Parameters
    ----------
    trace : obspy.Trace
        The record, acceleration [m s-2].
    start, end : float
        Fractions of the total Arias intensity that bound the duration (0.05 and 0.95: the
        D5-95 duration). [1]
    """
    ia = arias_history(trace)
    t = np.arange(ia.size) * trace.stats.delta
    return _crossing(t, ia, end * ia[-1]) - _crossing(t, ia, start * ia[-1])


# -- Fourier spectrum ------------------------------------------------------------------


def _fas(acc, dt):
    """Raw Fourier amplitude |X(f)| * dt [m s-1] at the FFT frequencies [Hz]."""
    n = acc.size
    spec = np.abs(np.fft.rfft(acc)) * dt
    return np.fft.rfftfreq(n, dt), spec


def _window(x):
    """The Konno-Ohmachi weight ``(sin x / x)^4`` at ``x = b log10(f / fc)``: 1 at the
    centre, 0 beyond the main lobe (``|x| > pi``)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        w = (np.sin(x) / x) ** 4
    w[np.abs(x) < 1e-12] = 1.0
    w[np.abs(x) > np.pi] = 0.0
    return w


def _konno_ohmachi(freq, amp, centres, bandwidth):
    """Konno-Ohmachi smoothing of ``amp(freq)`` evaluated at ``centres``.

    The window is ``(sin x / x)^4``, ``x = b log10(f / fc)`` (Konno & Ohmachi 1998, BSSA
    88(1), eq. 4). urmx keeps its main lobe, ``|x| <= pi`` (ObsPy's
    ``konno_ohmachi_smoothing`` keeps the side lobes too, whose weights are below 2.3e-3),
    so each centre sums only the FFT bins of its band ``fc 10^(+-pi/b)``: ``freq`` is
    sorted, and the band's ends are found by bisection. That takes 1-10 % of the time of
    the full weight matrix for records of 2,700-40,000 samples and gives the same result
    to rounding (``_konno_ohmachi_full``, tests/test_records.py)."""
    ok = freq > 0
    f, a = freq[ok], amp[ok]
    half = np.pi / bandwidth
    lo = np.searchsorted(f, centres * 10.0 ** -half, side="left")
    hi = np.searchsorted(f, centres * 10.0 ** half, side="right")
    out = np.zeros(centres.size)
    for i, (fc, i0, i1) in enumerate(zip(centres, lo, hi, strict=True)):
        w = _window(bandwidth * np.log10(f[i0:i1] / fc))
        total = w.sum()
        if total > 0:
            out[i] = (w @ a[i0:i1]) / total
    return out


def _konno_ohmachi_full(freq, amp, centres, bandwidth):
    """`_konno_ohmachi` with the full weight matrix (every bin for every centre): the
    yardstick the banded form is tested against."""
    ok = freq > 0
    f, a = freq[ok], amp[ok]
    w = _window(bandwidth * np.log10(f[None, :] / centres[:, None]))
    return (w @ a) / np.maximum(w.sum(axis=1), 1e-300)


def smoothed_fourier_amplitude(acceleration, dt: float, frequencies=None,
                               bandwidth: float = 40.0) -> tuple[np.ndarray, np.ndarray]:
    """`fourier_spectrum` as numpy arrays (no Trace, no xarray): (frequency [Hz], smoothed
    amplitude [m s-1])."""
    acc = np.asarray(acceleration, dtype=float)
    freq, amp = _fas(acc, dt)
    centres = np.asarray(DEFAULT_FREQUENCIES if frequencies is None else frequencies, float)
    # below two FFT bins the smoothed spectrum is not resolved by the record length
    centres = centres[(centres >= 2.0 / (acc.size * dt)) & (centres <= 0.5 / dt)]
    return centres, _konno_ohmachi(freq, amp, centres, bandwidth)


def fourier_spectrum(trace, frequencies=None, bandwidth: float = 40.0) -> xr.DataArray:
    """Konno-Ohmachi-smoothed Fourier amplitude spectrum of the acceleration.

    Parameters
    ----------
    trace : obspy.Trace
        Acceleration [m s-2].
    frequencies : array_like, optional
        Frequencies to evaluate [Hz]; default 300 log-spaced from 0.05 to 50 Hz (cut at
        the Nyquist frequency).
    bandwidth : float
        Konno-Ohmachi ``b`` (40 is the usual value). [1]

    Returns
    -------
    xarray.DataArray
        ``fourier_amplitude(frequency)`` [m s-1].
    """
    import xarray as xr

    acc, dt = _series(trace)
    centres, smooth = smoothed_fourier_amplitude(acc, dt, frequencies, bandwidth)
    fas = xr.DataArray(smooth, dims="frequency", name="fourier_amplitude",
                       coords={"frequency": centres},
                       attrs={"smoothing": f"Konno-Ohmachi b={bandwidth:g}"})
    return stamp(fas, scope="spectrum")


def significant_frequency_range(trace, low: float = 0.05, high: float = 0.95):
    """Frequency band holding the central ``high - low`` share of the Fourier power.

    The "significant frequency range" of the paper's Table V is not defined there; urmx
    uses the frequency analogue of the significant duration: the frequencies at which the
    cumulative Fourier power ``integral |X(f)|^2 df`` (Parseval: the record's energy)
    reaches 5 % and 95 % of its total. The band therefore holds 90 % of the energy.

    Parameters
    ----------
    trace : obspy.Trace
        Acceleration [m s-2].
    low, high : float
        Fractions of the total power bounding the band. [1]

    Returns
    -------
    tuple of float
        ``(f_low, f_high)`` [Hz].
    """
    acc, dt = _series(trace)
    freq, amp = _fas(acc - acc.mean(), dt)
    power = np.cumsum(amp * amp)
    power = power / power[-1]
    return _crossing(freq, power, low), _crossing(freq, power, high)


def predominant_frequency(trace) -> float:
    """Frequency of the peak of the smoothed Fourier amplitude spectrum [Hz].

    Parameters
    ----------
    trace : obspy.Trace
        The record, acceleration [m s-2].
    """
    return dominant_frequency(*_series(trace))


def dominant_frequency(acceleration, dt: float) -> float:
    """`predominant_frequency` of samples [m s-2] at time step `dt` [s], numpy only. [Hz]"""
    centres, smooth = smoothed_fourier_amplitude(acceleration, dt)
    return float(centres[int(np.argmax(smooth))])


# -- response spectrum: exact piecewise-linear recursion -------------------------------


def nigam_jennings_coefficients(omega, damping, dt):
    """Coefficients of the exact recursion for piecewise-linear excitation.

    Nigam & Jennings (1969); Chopra, *Dynamics of Structures*, Table 5.2.1, for a unit
    mass with ``k = omega**2``. With ``p = -a_g``::

        u[i+1] = A u[i] + B v[i] + C p[i] + D p[i+1]
        v[i+1] = A' u[i] + B' v[i] + C' p[i] + D' p[i+1]

    Parameters
    ----------
    omega : ndarray
        Natural circular frequencies [rad s-1].
    damping : float
        Damping ratio [1], below 1.
    dt : float
        Time step [s].

    Returns
    -------
    ndarray
        Shape ``(8, n)``: A, B, C, D, A', B', C', D'.
    """
    w = np.asarray(omega, dtype=float)
    z = float(damping)
    sq = np.sqrt(1.0 - z * z)
    wd = w * sq
    k = w * w
    e = np.exp(-z * w * dt)
    s, c = np.sin(wd * dt), np.cos(wd * dt)
    two_z_wh = 2.0 * z / (w * dt)
    a = e * (z / sq * s + c)
    b = e * s / wd
    cc = (two_z_wh + e * (((1.0 - 2.0 * z * z) / (wd * dt) - z / sq) * s
                          - (1.0 + two_z_wh) * c)) / k
    d = (1.0 - two_z_wh + e * ((2.0 * z * z - 1.0) / (wd * dt) * s + two_z_wh * c)) / k
    a1 = -e * (w / sq * s)
    b1 = e * (c - z / sq * s)
    c1 = (-1.0 / dt + e * ((w / sq + z / (dt * sq)) * s + c / dt)) / k
    d1 = (1.0 - e * (z / sq * s + c)) / (k * dt)
    return np.array([a, b, cc, d, a1, b1, c1, d1])


@jit(cache=True)  # numba is imported on first use
def _nj_run(p, coef, omega, damping, keep_history):
    n_per = coef.shape[1]
    u = np.zeros(n_per)
    v = np.zeros(n_per)
    umax = np.zeros(n_per)
    vmax = np.zeros(n_per)
    amax = np.zeros(n_per)
    hist = np.zeros((p.size if keep_history else 1, n_per))
    for i in range(p.size - 1):
        p0, p1 = p[i], p[i + 1]
        for j in range(n_per):
            un = coef[0, j] * u[j] + coef[1, j] * v[j] + coef[2, j] * p0 + coef[3, j] * p1
            vn = coef[4, j] * u[j] + coef[5, j] * v[j] + coef[6, j] * p0 + coef[7, j] * p1
            u[j], v[j] = un, vn
            au = abs(un)
            if au > umax[j]:
                umax[j] = au
            if abs(vn) > vmax[j]:
                vmax[j] = abs(vn)
            aa = abs(2.0 * damping * omega[j] * vn + omega[j] * omega[j] * un)
            if aa > amax[j]:
                amax[j] = aa
            if keep_history:
                hist[i + 1, j] = un
    return umax, vmax, amax, hist


def sdof_displacement(acc, dt: float, period: float, damping: float = 0.05) -> np.ndarray:
    """Relative displacement history [m] of a linear oscillator under ground acceleration.

    Exact for piecewise-linear ``acc`` [m s-2] sampled at ``dt`` [s]; starts at rest.

    Parameters
    ----------
    acc : array_like of float
        Ground acceleration, linear between samples. [m s-2]
    dt : float
        Time step of `acc`. [s]
    period : float
        Natural period of the oscillator, > 0. [s]
    damping : float
        Ratio of critical damping. [1]
    """
    damping = _check_damping(damping)
    p = numbers_argument("sdof_displacement", "acc", acc)
    dt, period = (float(numbers_argument("sdof_displacement", n, v))
                  for n, v in (("dt", dt), ("period", period)))
    if not (np.isfinite(dt) and dt > 0):
        raise InputError(f"dt={dt!r} must be a positive time step in seconds")
    if not (np.isfinite(period) and period > 0):
        raise InputError(f"period={period!r} must be a positive period in seconds")
    omega = np.array([2.0 * np.pi / period])
    coef = nigam_jennings_coefficients(omega, damping, dt)
    p = -check_finite(p, "acc", dt)
    return _nj_run(p, coef, omega, float(damping), True)[3][:, 0]


def response_spectrum(trace, periods=None, damping: float = 0.05) -> xr.Dataset:
    """Elastic response spectrum by the exact piecewise-linear recursion.

    One pass over the record advances all oscillators at once (vectorised over periods).
    Period 0, if asked for, is the PGA (the limit of a rigid oscillator).

    Parameters
    ----------
    trace : obspy.Trace or (array, dt)
        Ground acceleration [m s-2] (with its time step [s] for an array).
    periods : array_like, optional
        Natural periods [s]; default ``DEFAULT_PERIODS`` (0.02-10 s).
    damping : float
        Damping ratio in (0, 1) [1]; default 5 %.

    Returns
    -------
    xarray.Dataset
        ``sd`` [m], ``psv`` [m s-1], ``psa`` [m s-2] and ``sa`` (absolute acceleration)
        [m s-2] on dimension ``period`` [s].
    """
    import xarray as xr

    acc, dt = _series(as_trace(trace))
    periods = np.asarray(DEFAULT_PERIODS if periods is None else periods, dtype=float)
    out = _spectrum(acc, dt, periods, damping)
    damping = out.pop("damping")
    ds = xr.Dataset({k: ("period", v) for k, v in out.items()}, coords={"period": periods},
                    attrs={"damping": damping,
                           "method": "Nigam-Jennings exact piecewise-linear recursion"})
    return stamp(ds, scope="spectrum")


def pseudo_spectral_acceleration(acceleration, dt: float, periods,
                                 damping: float = 0.05) -> np.ndarray:
    """``psa`` of `response_spectrum` at `periods` [s] (0: the PGA) as a numpy array, from
    samples [m s-2] at time step `dt` [s] (no Trace, no xarray). [m s-2]"""
    acc = np.asarray(acceleration, dtype=float)
    return _spectrum(acc, float(dt), np.asarray(periods, dtype=float), damping)["psa"]


def _spectrum(acc, dt, periods, damping) -> dict:
    """sd, psv, psa, sa over `periods` and the checked damping ratio."""
    damping = _check_damping(damping)
    bad = periods[~(np.isfinite(periods) & (periods >= 0))]
    if bad.size:
        raise InputError(f"response_spectrum: period {bad[0]!r} s is not a finite period "
                         ">= 0 s")
    pos = periods > 0
    omega = 2.0 * np.pi / periods[pos]
    coef = nigam_jennings_coefficients(omega, damping, dt)
    umax, _, amax, _ = _nj_run(-acc, coef, omega, float(damping), False)
    pga = float(np.max(np.abs(acc)))
    sd = np.zeros(periods.size)
    sa = np.full(periods.size, pga)
    sd[pos] = umax
    sa[pos] = amax
    w = np.zeros(periods.size)
    w[pos] = omega
    psa = np.where(pos, w * w * sd, pga)
    return {"sd": sd, "psv": w * sd, "psa": psa, "sa": sa, "damping": damping}


# -- average spectral acceleration -----------------------------------------------------

#: number of log-spaced periods (both ends included) of the average spectral acceleration
SA_AVG_PERIODS = 10


def check_period_range(period_range, name: str = "period_range") -> tuple[float, float]:
    """A period range ``(low, high)`` of finite positive periods with low <= high [s], or an
    InputError naming it."""
    try:
        low, high = (float(v) for v in period_range)
    except (TypeError, ValueError):
        raise InputError(f"{name}={period_range!r} must be two periods (low, high) in "
                         "seconds") from None
    if not (np.isfinite(low) and np.isfinite(high) and 0.0 < low <= high):
        raise InputError(f"{name}={period_range!r} must be two finite periods with "
                         "0 < low <= high [s]")
    return low, high


def average_periods(period_range, n: int = SA_AVG_PERIODS) -> np.ndarray:
    """The `n` log-spaced periods of ``period_range = (low, high)``, both ends included. [s]"""
    low, high = check_period_range(period_range)
    return np.geomspace(low, high, int(n))


def geometric_mean_psa(acceleration, dt: float, periods, damping: float = 0.05) -> np.ndarray:
    """Geometric mean over the last axis of `periods` [s] of the pseudo-spectral
    acceleration of samples [m s-2] at step `dt` [s], in one pass of the exact recursion
    over the distinct periods, numpy only. [m s-2]"""
    p = np.asarray(periods, dtype=float)
    uniq, inv = np.unique(p.ravel(), return_inverse=True)
    psa = pseudo_spectral_acceleration(acceleration, dt, uniq, damping)[inv].reshape(p.shape)
    with np.errstate(divide="ignore"):
        return np.exp(np.mean(np.log(psa), axis=-1))


def average_spectral_acceleration(trace, period_range, n: int = SA_AVG_PERIODS,
                                  damping: float = 0.05) -> float:
    """Average spectral acceleration ``sa_avg`` (Eads, Miranda & Lignos 2015, EESD 44):
    the geometric mean of the pseudo-spectral acceleration at `n` log-spaced periods over
    `period_range`.

    Parameters
    ----------
    trace : obspy.Trace or (array, dt)
        Ground acceleration [m s-2] (with its time step [s] for an array).
    period_range : (float, float)
        Shortest and longest period, both included. [s]
    n : int
        Number of periods. [1]
    damping : float
        Damping ratio. [1]

    Returns
    -------
    float
        Proportional to the record's amplitude. [m s-2]
    """
    acc, dt = _series(as_trace(trace))
    return float(geometric_mean_psa(acc, dt, average_periods(period_range, n), damping))


# -- all scalar measures ---------------------------------------------------------------

#: the scalar measures of :func:`measures`, in order (units and long names: the registry)
MEASURES = ("pga", "pgv", "pgd", "arias_intensity", "significant_duration", "cav",
            "rms_acceleration", "significant_frequency_low", "significant_frequency_high",
            "predominant_frequency", "duration", "dt")


class _Intermediates:
    """Integrals of a record that several measures share, each computed on first use."""

    def __init__(self, trace, acc, dt):
        self.trace, self.acc, self.dt = trace, acc, dt

    @cached_property
    def vel(self):
        return _cumtrapz(self.acc, self.dt)

    @cached_property
    def arias(self):
        return np.pi / (2.0 * STANDARD_GRAVITY) * _cumtrapz(self.acc * self.acc, self.dt)

    @cached_property
    def t(self):
        return np.arange(self.acc.size) * self.dt

    @cached_property
    def t595(self):
        ia = self.arias
        return _crossing(self.t, ia, 0.05 * ia[-1]), _crossing(self.t, ia, 0.95 * ia[-1])

    @cached_property
    def frequency_range(self):
        return significant_frequency_range(self.trace)

    def rms(self):
        win = (self.t >= self.t595[0]) & (self.t <= self.t595[1])
        return np.sqrt(np.mean(self.acc[win] ** 2)) if win.any() else 0.0


def measures(trace, periods=None, damping: float = 0.05, names=None,
             sa_avg_range=None) -> xr.Dataset:
    """Scalar intensity measures of an acceleration trace.

    PGV and PGD come from trapezoidal integration of the trace as given; process
    uncorrected records (baseline, band-pass) first for meaningful values.

    Parameters
    ----------
    trace : obspy.Trace or (array, dt)
        Acceleration [m s-2] (with its time step [s] for an array).
    periods : array_like, optional
        Natural periods at which to add the pseudo-spectral acceleration ``psa(period)``
        (`response_spectrum`; period 0 gives the PGA). [s]
    damping : float
        Damping ratio of ``psa`` and ``sa_avg``. [1]
    names : sequence of str, optional
        Only these scalar measures (default: all); each is computed only when asked for
        (``["pga", "pgv"]`` skips the Fourier spectra).
    sa_avg_range : (float, float), optional
        Adds ``sa_avg``, the average spectral acceleration over these periods
        (`average_spectral_acceleration`, `SA_AVG_PERIODS` log-spaced periods). [s]

    Returns
    -------
    xarray.Dataset
        Scalars ``pga`` [m s-2], ``pgv`` [m s-1], ``pgd`` [m], ``arias_intensity``
        [m s-1], ``significant_duration`` [s], ``cav`` [m s-1], ``rms_acceleration``
        [m s-2], ``significant_frequency_low``/``_high`` [Hz],
        ``predominant_frequency`` [Hz], ``duration`` [s], ``dt`` [s]; each with
        ``units`` and ``long_name``; with `periods`, also ``psa(period)`` [m s-2]; with
        `sa_avg_range`, also ``sa_avg`` [m s-2].
    """
    import xarray as xr

    trace = as_trace(trace)
    acc, dt = _series(trace)
    if names is None:
        names = list(MEASURES)
    unknown = [n for n in names if n not in MEASURES]
    if unknown:
        raise InputError(f"unknown measure(s) {', '.join(map(repr, unknown))} (known: "
                         f"{', '.join(MEASURES)})")
    r = _Intermediates(trace, acc, dt)
    compute = {
        "pga": lambda: np.max(np.abs(acc)), "pgv": lambda: np.max(np.abs(r.vel)),
        "pgd": lambda: np.max(np.abs(_cumtrapz(r.vel, dt))),
        "arias_intensity": lambda: r.arias[-1],
        "significant_duration": lambda: r.t595[1] - r.t595[0],
        "cav": lambda: np.sum(np.abs(acc)) * dt, "rms_acceleration": r.rms,
        "significant_frequency_low": lambda: r.frequency_range[0],
        "significant_frequency_high": lambda: r.frequency_range[1],
        "predominant_frequency": lambda: predominant_frequency(trace),
        "duration": lambda: (acc.size - 1) * dt, "dt": lambda: dt,
    }
    ds = xr.Dataset({k: ((), float(compute[k]()), attrs(k)) for k in names})
    ds.attrs["trace"] = trace.id
    if periods is not None:
        rs = response_spectrum(trace, np.atleast_1d(np.asarray(periods, dtype=float)), damping)
        ds["psa"] = rs.psa.assign_attrs(damping=damping)
    if sa_avg_range is not None:
        low, high = check_period_range(sa_avg_range, "sa_avg_range")
        value = geometric_mean_psa(acc, dt, average_periods((low, high)), damping)
        ds["sa_avg"] = ((), float(value), {**attrs("sa_avg"), "damping": damping,
                                          "period_range": [low, high],
                                          "periods": SA_AVG_PERIODS})
    return ds
