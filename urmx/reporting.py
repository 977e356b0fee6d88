"""What both reports (`urmx.report`, `urmx.fragility_report`) share: opening a study archive
with a clear error, and saving a figure as a PNG with its Markdown link. (Quantities are
shown in g and mm by `urmx.plot.display_scale`.)"""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np
import xarray as xr

from .errors import InputError, MissingFileError

#: the time stamp an archive's ``history`` lines start with (``2026-11-23T15:34:59+00:00 ``)
_STAMP = re.compile(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(?:\.\d+)?(?:Z|[+-]\d\d:\d\d)?\s+")


def history_line(ds: xr.Dataset) -> str:
    """The last line of an archive's ``history`` without its time stamp (``urmx 0.1.0: urmx
    paper``): what a committed report may show. The time of the run stays in the archive; a
    report that printed it would change on every run though nothing else did, leaving a
    checkout's ``git status`` unclean after ``urmx paper``."""
    lines = str(ds.attrs.get("history", "")).strip().splitlines()
    return _STAMP.sub("", lines[-1].strip()) if lines else ""


def open_archive(archive, what: str = "study archive") -> xr.Dataset:
    """A Dataset loaded from a study archive path (`urmx.open_study`), or as given.

    Raises
    ------
    urmx.errors.MissingFileError
        No such file (``no <what> 'path'``).
    urmx.errors.InputError
        A file that is not a readable netCDF archive.
    """
    if isinstance(archive, xr.Dataset):
        return archive
    path = Path(archive)
    if not path.is_file():
        raise MissingFileError(f"no {what} {str(path)!r}")
    from .study import open_study

    try:
        return open_study(path).load()
    except (OSError, ValueError) as exc:  # not netCDF, or damaged
        raise InputError(f"{str(path)!r} is not a readable {what}: {exc}") from None


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
