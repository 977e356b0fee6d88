"""What both reports (`urmx.report`, `urmx.fragility_report`) share: opening a study archive
with a clear error, and saving a figure as a PNG with its Markdown link. (Quantities are
shown in g and mm by `urmx.plot.display_scale`.)"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import xarray as xr

from .errors import InputError, MissingFileError


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


def made_from(ds: xr.Dataset, name: str = "archive") -> str:
    """One sentence naming the code an archive was made with (its ``urmx_git_commit``,
    local changes, ``kernel_source_hash``: `urmx.provenance.attrs`) and whether that kernel
    differs from the one running now (`urmx.jitcache.SOURCE_HASH`): a report made from an
    archive of an older kernel says so."""
    from .jitcache import SOURCE_HASH

    commit = str(ds.attrs.get("urmx_git_commit", "none"))
    kernel = str(ds.attrs.get("kernel_source_hash", "unknown"))
    code = ("an unrecorded commit" if commit in ("none", "") else
            f"commit `{commit[:12]}`" + (" with local changes"
                                         if ds.attrs.get("urmx_git_dirty") == 1 else ""))
    if kernel == "unknown":
        same = ("it does not record its kernel source hash, so whether the current kernel "
                f"(`{SOURCE_HASH[:16]}`) would give the same numbers is not known")
    elif kernel[:16] == SOURCE_HASH[:16]:
        same = "the current kernel is the same"
    else:
        same = (f"**the current kernel differs** (`{SOURCE_HASH[:16]}`): run the study again "
                "for numbers of the current kernel")
    return (f"The {name} was made at {code}, kernel source hash `{kernel[:16]}`; {same}.")
