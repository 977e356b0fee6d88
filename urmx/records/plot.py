"""Record figure: acceleration history, smoothed Fourier spectrum, response spectrum."""

from __future__ import annotations

import os

import numpy as np

from .measures import fourier_spectrum, response_spectrum, significant_frequency_range
from .readers import STANDARD_GRAVITY


def _label(da) -> str:
    return f"{da.attrs.get('long_name', da.name)} [{da.attrs.get('units', '1')}]"


def plot_record(trace, out: str | os.PathLike | None = None, title: str | None = None,
                paper_range_hz: tuple[float, float] | None = None):
    """Three panels for one record; saved to ``out`` (PNG) if given.

    Parameters
    ----------
    trace : obspy.Trace
        Acceleration [m s-2].
    out : str or path-like, optional
        Image file to write.
    title : str, optional
        Figure title (default: the trace id).
    paper_range_hz : tuple of float, optional
        A reference frequency band [Hz] (e.g. the paper's Table V range) shaded on the
        Fourier panel beside the measured significant frequency range.

    Returns
    -------
    matplotlib.figure.Figure
        Drawn without pyplot (the plotting backend is left as it is).
    """
    from matplotlib.figure import Figure

    g = STANDARD_GRAVITY
    acc = np.asarray(trace.data, dtype=float)
    t = np.arange(acc.size) * trace.stats.delta
    fas = fourier_spectrum(trace)
    rs = response_spectrum(trace)
    f_lo, f_hi = significant_frequency_range(trace)

    fig = Figure(figsize=(8, 9), layout="constrained")
    axes = fig.subplots(3, 1)
    ax = axes[0]
    ax.plot(t, acc / g, lw=0.6, color="k")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("acceleration [g]")
    k = int(np.argmax(np.abs(acc)))
    ax.annotate(f"PGA {abs(acc[k]) / g:.3f} g", (t[k], acc[k] / g), fontsize=8)

    ax = axes[1]
    ax.loglog(fas.frequency, fas, color="k", lw=1)
    ax.axvspan(f_lo, f_hi, color="tab:blue", alpha=0.15,
               label=f"measured 5-95 % power band {f_lo:.2f}-{f_hi:.1f} Hz")
    if paper_range_hz is not None:
        ax.axvspan(*paper_range_hz, color="tab:red", alpha=0.2,
                   label=f"paper Table V {paper_range_hz[0]:g}-{paper_range_hz[1]:g} Hz")
    ax.set_xlabel(_label(fas.frequency))
    ax.set_ylabel(_label(fas))
    ax.legend(fontsize=8, loc="lower left")

    ax = axes[2]
    ax.plot(rs.period, rs.psa / g, color="k")
    ax.set_xscale("log")
    ax.set_xlabel(_label(rs.period))
    ax.set_ylabel(f"PSA, {rs.attrs['damping']:.0%} damping [g]")
    import textwrap

    # wrapped: a long title (event, station, component) must not run off the figure
    fig.suptitle("\n".join(textwrap.wrap(title or str(trace.id), 80)))
    if out is not None:
        fig.savefig(out, dpi=110)
    return fig
