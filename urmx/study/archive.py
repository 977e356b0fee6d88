"""Reopening a study archive lazily, with the archives of older urmx masked by their kind."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import xarray as xr

from .. import variables
from ..errors import MissingFileError
from . import kinds


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
    """
    path = Path(path)
    if not path.is_file():
        raise MissingFileError(f"no study archive {str(path)!r}")
    ds = xr.open_dataset(path, engine="netcdf4", chunks={} if chunks is None else chunks)
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
