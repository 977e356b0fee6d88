"""The registry of variables and coordinates (``variables.toml``) and the helper that
stamps its attributes on xarray objects."""

from __future__ import annotations

import sys
from functools import lru_cache
from importlib import resources

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

SCALARS = (
    "peak_crack_displacement", "peak_top_displacement", "peak_base_displacement",
    "peak_lower_drift", "peak_upper_drift", "peak_top_acceleration",
    "peak_crack_acceleration", "peak_base_acceleration", "instability_ratio_lower",
    "instability_ratio_upper", "instability_ratio", "collapsed", "collapse_time",
    "unfavourable_fraction", "base_impacts", "crack_impacts",
)
INTEGER_SCALARS = ("collapsed", "base_impacts", "crack_impacts")
HISTORIES = (
    "theta_lower", "theta_upper", "base_displacement", "crack_displacement",
    "top_displacement", "base_acceleration", "crack_acceleration", "top_acceleration",
    "pattern",
)


FIELDS = ("units", "long_name", "description", "comment")  # attributes an entry may set


@lru_cache(maxsize=1)
def registry() -> dict[str, dict[str, str]]:
    """name (or ``scope.name``) -> {units, long_name, description, comment}."""
    text = resources.files("urmx").joinpath("variables.toml").read_text(encoding="utf-8")
    return tomllib.loads(text)


def attrs(name: str, scope: str | None = None) -> dict[str, str]:
    """CF attributes of a registered variable or coordinate: ``units`` (absent for ids,
    strings and flags), ``long_name`` and, where the registry has them, ``description``
    and ``comment``.

    Parameters
    ----------
    name : str
        Variable or coordinate name.
    scope : str, optional
        Where the name appears, for names whose meaning depends on it: the entry
        ``scope.name`` is used when the registry has one (``attrs("frequency",
        "spectrum")`` is a spectrum's frequency axis, ``attrs("frequency")`` a diaphragm's
        frequency).

    Raises
    ------
    KeyError
        The name is not in the registry.
    """
    reg = registry()
    entry = reg.get(f"{scope}.{name}") if scope else None
    if entry is None:
        try:
            entry = reg[name]
        except KeyError:
            raise KeyError(f"{name!r} is not in urmx's variable registry "
                           "(urmx/variables.toml)") from None
    return {k: entry[k] for k in FIELDS if k in entry}


def stamp(obj, scope: str | None = None):
    """Set the registry's attributes on every registered variable and coordinate of an
    xarray Dataset or DataArray (in place; returned for chaining). Names the registry
    does not know are left as they are."""
    reg = registry()

    def known(name) -> bool:
        return name in reg or (scope is not None and f"{scope}.{name}" in reg)

    for name in [*obj.coords, *getattr(obj, "data_vars", ())]:
        if known(name):
            obj[name].attrs.update(attrs(name, scope))
    if not hasattr(obj, "data_vars") and known(obj.name):  # a DataArray itself
        obj.attrs.update(attrs(obj.name, scope))
    return obj
