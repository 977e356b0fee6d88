"""What both reports (`urmx.reports.paper`, `urmx.reports.ida`) share: opening a study archive
with a clear error, and saving a figure as a PNG with its Markdown link. (Quantities are
shown in g and mm by `urmx.plot.display_scale`.)"""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np
import xarray as xr

from ..jitcache import SOURCE_HASH
from ..study.archive import open_archive  # noqa: F401 - re-exported for the reports

#: the time stamp an archive's ``history`` lines start with (``2026-11-23T15:34:59+00:00 ``)
_STAMP = re.compile(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(?:\.\d+)?(?:Z|[+-]\d\d:\d\d)?\s+")


def history_line(ds: xr.Dataset) -> str:
    """The last line of an archive's ``history`` without its time stamp (``urmx 0.1.0: urmx
    paper``): what a committed report may show. The time of the run stays in the archive; a
    report that printed it would change on every run though nothing else did, leaving a
    checkout's ``git status`` unclean after ``urmx paper``."""
    lines = str(ds.attrs.get("history", "")).strip().splitlines()
    return _STAMP.sub("", lines[-1].strip()) if lines else ""


def save_figure(axes, folder: Path, name: str, dpi: int = 110, palette: bool = False) -> str:
    """Write the figure of `axes` as ``folder/name`` (PNG) and return its Markdown link.

    Parameters
    ----------
    dpi : int
        Resolution. [dots per inch]
    palette : bool
        A palette PNG (256 colours: a third of the size of RGBA).
    """
    fig = np.ravel(axes)[0].figure
    if not palette:
        fig.savefig(folder / name, dpi=dpi)
        return f"![{name}]({name})"
    from PIL import Image

    buf = io.BytesIO()
    fig.savefig(buf, dpi=dpi, format="png")
    buf.seek(0)
    with Image.open(buf) as im:
        im.convert("RGB").quantize(256).save(folder / name, optimize=True)
    return f"![{name}]({name})"


# ---- what a report may state from how many records ---------------------------------------------

#: records per wall and diaphragm below which a report states no statistic across records
#: (recommendation, efficiency ratio, interval, ranking) and says what it would need. The
#: standard error of a lognormal median goes as beta / sqrt(n) (Baker 2015, Earthquake
#: Spectra 31(1), section "Uncertainty"): with beta 0.3-0.5 and 10 records it is 10-16 %,
#: with 3 records 17-29 %, no basis for ranking measures whose dispersions differ by less.
#: The bound is urmx's choice (no standard gives one); FEMA P695 uses 44 records.
MIN_RECORDS = 10
#: mark of an interval that cannot be trusted as one (a bound equal to its estimate)
DEGENERATE = "†"


def records_per_cell(ds: xr.Dataset) -> int:
    """The fewest records with a capacity over the (wall, diaphragm, cor) cells of an IDA
    archive: what its statistics across records rest on."""
    ran = np.isfinite(ds["collapse_intensity"]).sum("record")
    return int(ran.min()) if ran.size else 0


def enough_records(n: int) -> bool:
    return n >= MIN_RECORDS


def too_few(n: int, what: str) -> str:
    """What a left-out statistic would need: ``{what} needs at least 10 records per wall
    and diaphragm; this archive has 3``."""
    return (f"{what} needs at least {MIN_RECORDS} records per wall and diaphragm "
            f"(`urmx.reporting.MIN_RECORDS`); this archive has {n}")


def pct(fraction: float) -> str:
    """A fraction as a percentage with two significant digits (``0.4 %``, ``12 %``)."""
    if not np.isfinite(fraction):
        return "-"
    return f"{float(f'{100.0 * fraction:.2g}'):g} %"


def ratio(value: float) -> str:
    """A ratio with two significant digits."""
    return "-" if not np.isfinite(value) else f"{float(f'{value:.2g}'):g}"


def interval(estimate: float, lo: float, hi: float, fmt) -> str:
    """``[lo-hi]`` of an interval around `estimate` (each formatted by `fmt`); ``[no
    interval]`` when a bound is missing; ``[lo-hi]†`` when a bound equals the estimate
    (the resamples cannot move it: too few distinct records, `DEGENERATE`)."""
    if not (np.isfinite(lo) and np.isfinite(hi)):
        return "[no interval]"
    text = f"[{fmt(lo)}-{fmt(hi)}]"
    if np.isfinite(estimate) and (fmt(lo) == fmt(estimate) or fmt(hi) == fmt(estimate)
                                  or lo == estimate or hi == estimate):
        text += DEGENERATE
    return text


DEGENERATE_NOTE = (f"{DEGENERATE}: a bound of this interval equals its estimate: the "
                   "resamples of the records cannot move it (too few distinct records), so "
                   "it is no confidence interval.")


def made_from(ds: xr.Dataset, name: str = "archive", commit: bool = True) -> str:
    """One sentence naming the code an archive was made with (its ``urmx_git_commit``,
    local changes, ``kernel_source_hash``: `urmx.provenance.attrs`) and whether that kernel
    differs from the one running now (`urmx.jitcache.SOURCE_HASH`): a report made from an
    archive of an older kernel says so.

    ``commit=False`` leaves the commit and the hash out of the sentence (it points at the
    archive's attributes instead): for a committed report that a run in any later checkout
    or environment writes again (`urmx paper` in CI), whose text must not change with each
    new commit, or with the numba, llvmlite and Python builds the hash also stamps, when
    its numbers do not (issue 33, item 3); whether the kernel differs is still said."""
    at = str(ds.attrs.get("urmx_git_commit", "none"))
    kernel = str(ds.attrs.get("kernel_source_hash", "unknown"))
    code = ("an unrecorded commit" if at in ("none", "") else
            f"commit `{at[:12]}`" + (" with local changes"
                                     if ds.attrs.get("urmx_git_dirty") == 1 else ""))
    if not commit and at not in ("none", "") and kernel != "unknown":
        # neither the commit nor the hash, which also stamps the numba, llvmlite and Python
        # builds of the environment: a report CI writes again must not change with them
        same = ("the current kernel is the same" if kernel[:16] == SOURCE_HASH[:16] else
                f"**the current kernel differs** (`{SOURCE_HASH[:16]}`, the archive's "
                f"`{kernel[:16]}`): run the study again for numbers of the current kernel")
        return (f"The {name} was made at the commit and with the kernel its attributes "
                f"`urmx_git_commit` and `kernel_source_hash` name; {same}.")
    if kernel == "unknown":
        same = ("it does not record its kernel source hash, so whether the current kernel "
                f"(`{SOURCE_HASH[:16]}`) would give the same numbers is not known")
    elif kernel[:16] == SOURCE_HASH[:16]:
        same = "the current kernel is the same"
    else:
        same = (f"**the current kernel differs** (`{SOURCE_HASH[:16]}`): run the study again "
                "for numbers of the current kernel")
    return (f"The {name} was made at {code}, kernel source hash `{kernel[:16]}`; {same}.")
