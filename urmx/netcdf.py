"""The one netCDF writer: every archive urmx writes (a study, one analysis) goes through
:func:`write_netcdf`, atomically."""

from __future__ import annotations

import contextlib
import os
import shutil
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import OutputError
from .variables import INTEGER_OUTPUTS

if TYPE_CHECKING:  # xarray is not imported here: the fill value is read on workers too
    import xarray as xr

#: fill value on disk of the integer and flag outputs (`urmx.variables.INTEGER_OUTPUTS`) of
#: study cells without a valid result
INT_FILL = -1


def encoding(ds: xr.Dataset) -> dict[str, dict[str, Any]]:
    """netCDF4 encoding per variable: compressed outputs (NaN the fill value of floats, none
    for integers and booleans: a NaN fill cast to int8 would make True the fill value),
    no fill value on coordinates (multi-dimensional ones, such as the intensities of IDA
    curves, compressed), strings as they are. Integer and flag outputs held as float with
    NaN (study cells without a valid result, `urmx.variables.INTEGER_OUTPUTS`) are stored
    as int32 with the CF ``_FillValue`` `INT_FILL`, which xarray masks on reading (float64
    with NaN). A ``chunksizes`` in a variable's own encoding is kept (the slabs a study
    archive is written in, `urmx.study.sources`)."""
    enc: dict[str, dict[str, Any]] = {}
    for name, var in ds.variables.items():
        if var.dtype == object:
            enc[name] = {}
        elif name in ds.coords:
            enc[name] = {"_FillValue": None}
            if var.ndim > 1:  # a grid of values (the intensities of IDA curves)
                enc[name].update(zlib=True, complevel=4)
        elif name in INTEGER_OUTPUTS and var.dtype.kind == "f":
            enc[name] = {"zlib": True, "complevel": 4, "dtype": "int32",
                         "_FillValue": np.int32(INT_FILL)}
        elif np.issubdtype(var.dtype, np.integer) or var.dtype == bool:
            enc[name] = {"zlib": True, "complevel": 4, "_FillValue": None}
        else:
            enc[name] = {"zlib": True, "complevel": 4, "_FillValue": np.nan}
        if "chunksizes" in var.encoding and enc[name].get("zlib"):  # a study's slabs
            enc[name]["chunksizes"] = var.encoding["chunksizes"]
    return enc


def write_netcdf(ds: xr.Dataset, path: str | os.PathLike) -> Path:
    """Write `ds` as netCDF4 to a temporary name beside `path` and rename it, so an
    interrupted write never leaves a broken file; parent folders are created, and the
    temporary file is removed whatever happens.

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    urmx.errors.OutputError
        The file cannot be written (a full disk, a folder removed meanwhile, the netCDF
        library's ``NetCDF: HDF error``): one line naming the file, the reason and the
        space left on its disk.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        ds.to_netcdf(tmp, format="NETCDF4", engine="netcdf4", encoding=encoding(ds))
        os.replace(tmp, path)
    except (OSError, RuntimeError) as exc:  # netCDF4 reports HDF5's failures as
        # RuntimeError ("NetCDF: HDF error"), and a full disk as often as not as EACCES:
        # the space left is said with the reason
        reason = getattr(exc, "strerror", None) or str(exc)
        limit = size_limit_hit(tmp, exc)
        raise OutputError(f"cannot write netCDF file {str(path)!r}: {reason} "
                          f"({limit or _free(path.parent)})") from exc
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink()
    return path


def size_limit_hit(path: Path, exc: BaseException | None = None) -> str:
    """Words for a write that failed on the process's file-size limit (``ulimit -f``,
    RLIMIT_FSIZE: EFBIG, the signal SIGXFSZ that Python ignores), '' when it did not: the
    error says EFBIG, or the file reached the limit (netCDF says only ``HDF error``)."""
    import errno

    try:
        import resource

        limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    except (ImportError, OSError, ValueError):  # pragma: no cover - not POSIX
        return ""
    if limit == resource.RLIM_INFINITY:
        return ""
    try:
        size = path.stat().st_size
    except OSError:
        size = 0
    efbig = any(getattr(e, "errno", None) == errno.EFBIG for e in (exc, getattr(
        exc, "__cause__", None), getattr(exc, "__context__", None)) if e is not None)
    if not efbig and size < limit - min(1 << 20, limit // 10):
        return ""
    return (f"the file reached this process's file-size limit of {limit / 1e6:.1f} MB "
            "(ulimit -f): raise it (ulimit -f unlimited) or write elsewhere")


def remove_stale(folder: Path, prefix: str, suffix: str) -> list[tuple[Path, int]]:
    """Remove the temporary files ``<prefix><pid><suffix>`` in `folder` that a killed
    process left (its PID no longer runs); (file, pid) of each removed. Used for an
    archive's ``.NAME.nc.PID.tmp`` and a parts folder's ``.KEY.PID.npz.tmp``."""
    import glob

    removed = []
    if not folder.is_dir():
        return removed
    for tmp in folder.glob(glob.escape(prefix) + "*" + glob.escape(suffix)):
        pid = tmp.name[len(prefix):len(tmp.name) - len(suffix)].rsplit(".", 1)[-1]
        if not pid.isdigit() or _alive(int(pid)):
            continue
        with contextlib.suppress(OSError):
            tmp.unlink()
            removed.append((tmp, int(pid)))
    return removed


def _alive(pid: int) -> bool:
    """Whether a process `pid` runs (one of another user counts)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def _free(folder: Path) -> str:
    """The space left on `folder`'s disk, in words."""
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        return "space left unknown"
    return f"{free / 1e6:.1f} MB free on its disk" + (": the disk is full" if disk_full(folder)
                                                       else "")


def disk_full(folder: str | os.PathLike, below: float = 1e6) -> bool:
    """Whether the disk of `folder` has less than `below` bytes free (False when it cannot
    be asked)."""
    try:
        return shutil.disk_usage(folder).free < below
    except OSError:
        return False
