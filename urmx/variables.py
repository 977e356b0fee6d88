"""The registry of output variables (``variables.toml``) and the helper that stamps it."""

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


@lru_cache(maxsize=1)
def registry() -> dict[str, dict[str, str]]:
    """name -> {units, long_name, description}."""
    text = resources.files("urmx").joinpath("variables.toml").read_text(encoding="utf-8")
    return tomllib.loads(text)


def attrs(name: str, **context: str) -> dict[str, str]:
    """CF attributes (units, long_name, description) of a registered variable.

    Entries whose units depend on a study setting hold ``{placeholders}`` (the intensity
    measure's ``{im_units}`` and ``{im_name}``), filled from `context`.
    """
    try:
        entry = registry()[name]
    except KeyError:
        raise KeyError(f"{name!r} is not in urmx's variable registry") from None
    out = {"units": entry["units"], "long_name": entry["long_name"],
           "description": entry.get("description", "")}
    if context:
        out = {k: v.format_map(context) for k, v in out.items()}
    return out


def stamp(ds):
    """Set units/long_name/description on every registered variable of an xarray object.

    Entries with placeholders take them from the object's ``intensity_measure`` attribute
    (IDA archives); without it they are left as they are."""
    reg = registry()
    context = {}
    im = getattr(ds, "attrs", {}).get("intensity_measure")
    if im is not None:
        from .fragility import IM_ATTRS

        if im in IM_ATTRS:
            context = {"im_units": IM_ATTRS[im][0], "im_name": IM_ATTRS[im][1]}
    for name in list(ds.variables):
        if name in reg:
            if "{" in reg[name]["units"] + reg[name]["long_name"] and not context:
                continue
            ds[name].attrs.update(attrs(name, **context))
    return ds
