"""Reopening a study archive lazily, with the archives of older urmx masked by their kind."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .. import variables
from ..errors import InputError, MissingFileError
from . import kinds


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
    try:
        return open_study(path).load()
    except (OSError, ValueError) as exc:  # not netCDF, or damaged
        raise InputError(f"{str(path)!r} is not a readable {what}: {exc}") from None


def open_study(path: str | os.PathLike, chunks: Any = None, keys: bool = False) -> xr.Dataset:
    """Reopen a study archive lazily (dask arrays; ``chunks`` as for `xarray.open_dataset`,
    default the archive's own chunks).

    The cells' identities an archive keeps so that a later run can reuse its cells
    (``cell_key``, `urmx.study.cells`) are left out unless `keys` is True: they are not
    results.

    Outputs of cells with no valid result read as NaN: the integer and flag outputs carry
    a CF ``_FillValue`` that xarray masks. Archives written before urmx stored them so are
    masked here by the kind they belong to (each kind's ``reopen``; a grid's by
    ``status``, for example).

    Parameters
    ----------
    path : str or path-like
        The archive (netCDF).
    chunks : dict, int, "auto" or None
        As for `xarray.open_dataset`; None: the archive's own chunks.
    keys : bool
        Keep the cells' identities (``cell_key``).
    """
    if not isinstance(path, (str, os.PathLike)):
        raise InputError(f"open_study: path={path!r} must be a file name (str or path), not "
                         f"{type(path).__name__}")
    path = Path(path)
    if not path.is_file():
        raise MissingFileError(f"no study archive {str(path)!r}")
    try:
        ds = _guarded(xr.open_dataset(path, engine="netcdf4"), path)
    except (OSError, ValueError, RuntimeError) as exc:
        raise InputError(f"{str(path)!r} is not a readable study archive: {exc}") from None
    if chunks:
        ds = ds.chunk(chunks)
    if not keys and "cell_key" in ds.variables:
        ds = ds.drop_vars("cell_key")
    if not any(n in ds.data_vars and ds[n].dtype.kind in "iub"
               for n in variables.INTEGER_OUTPUTS):
        return ds
    for kind in kinds.registered():
        masked = kind.reopen(ds) if kind.reopen is not None else None
        if masked is not None:
            return masked
    return ds


class _Guarded:
    """One variable of an open archive, read slice by slice: a file damaged since it was
    written (a flipped bit in a compressed chunk) is an `urmx.errors.InputError` naming the
    file and the variable when it is read, not a bare ``OSError: NetCDF: HDF error``."""

    def __init__(self, var: xr.Variable, path: Path, name: str):
        self.var, self.path, self.name = var, path, name
        self.shape, self.dtype, self.ndim = var.shape, var.dtype, var.ndim

    def __getitem__(self, key: Any) -> Any:
        try:
            return self.var[key].values
        except (OSError, RuntimeError) as exc:
            raise InputError(f"study archive {str(self.path)!r}: variable {self.name!r} cannot "
                             f"be read ({exc}): the file is damaged; run its study again") \
                from None


def _guarded(ds: xr.Dataset, path: Path) -> xr.Dataset:
    """`ds` (opened lazily, without dask) with every variable but the indexes a dask array
    in the file's own chunks, read through :class:`_Guarded`."""
    import uuid

    import dask.array as da

    tag = uuid.uuid4().hex
    new = {}
    for name, var in ds.variables.items():
        if name in ds.indexes:
            continue
        chunks = tuple(var.encoding.get("chunksizes") or var.shape)
        data = da.from_array(_Guarded(var, path, name), chunks=chunks, lock=False,
                             name=f"urmx-archive-{name}-{tag}", meta=np.empty((0,) * var.ndim,
                                                                              var.dtype))
        new[name] = var.copy(deep=False, data=data)
    out = ds.copy()
    coords = {n: v for n, v in new.items() if n in ds.coords}
    data_vars = {n: v for n, v in new.items() if n not in ds.coords}
    return out.assign_coords(coords).assign(data_vars)
