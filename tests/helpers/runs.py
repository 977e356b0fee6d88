"""Helpers of tests that run whole studies or read the project: `Interrupt` (what a stand-in
kernel raises for Ctrl-C), `same_run` (two runs' archives equal but for their start times)
and `fallback_version` (pyproject.toml's setuptools-scm fallback)."""

from __future__ import annotations

from pathlib import Path

import xarray as xr

ROOT = Path(__file__).resolve().parents[2]


class Interrupt(Exception):
    """Stands for Ctrl-C, a killed run or a lost worker partway through a study (raised by
    the stand-in kernels, caught by the tests)."""


def same_run(a: xr.Dataset, b: xr.Dataset) -> None:
    """Two runs' archives are identical but for the start time heading this run's line of
    `history` (an extended archive lists the earlier runs' after it)."""
    a, b = a.copy(), b.copy()
    for ds in (a, b):
        # this run's line (an extended archive lists the earlier runs' after it)
        ds.attrs["history"] = ds.attrs["history"].splitlines()[0].split(" ", 1)[1]
    xr.testing.assert_identical(a, b)


def fallback_version() -> str:
    """The version a build outside git gets: setuptools-scm's ``fallback_version`` in
    pyproject.toml."""
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib

    with open(ROOT / "pyproject.toml", "rb") as f:
        return tomllib.load(f)["tool"]["setuptools_scm"]["fallback_version"]
