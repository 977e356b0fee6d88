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
    "instability_ratio_upper", "instability_ratio", "peak_lower_drift_family1", "collapsed",
    "collapse_time", "unfavourable_fraction", "base_impacts", "crack_impacts",
)
INTEGER_SCALARS = ("collapsed", "base_impacts", "crack_impacts")
#: outputs of study cells that hold whole numbers or flags (a grid's integer scalars; an IDA
#: study's censoring and analysis counts): float64 with NaN where a cell has no result in a
#: Dataset, int32 with a CF ``_FillValue`` on disk (`urmx.netcdf.encoding`)
INTEGER_OUTPUTS = (*INTEGER_SCALARS, "censored", "analyses", "event_limits")
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


def attrs(name: str, scope: str | None = None, **context: str) -> dict[str, str]:
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
    **context : str
        Values of the ``{placeholders}`` of entries whose units depend on a study setting
        (an IDA study's intensity measure: ``im_units`` and ``im_name``, see
        :func:`intensity_context`); ``attrs("collapse_intensity", **intensity_context("pga"))``.

    Raises
    ------
    KeyError
        The name is not in the registry, or an entry holds a placeholder ``context`` does
        not fill.
    """
    reg = registry()
    entry = reg.get(f"{scope}.{name}") if scope else None
    if entry is None:
        try:
            entry = reg[name]
        except KeyError:
            raise KeyError(f"{name!r} is not in urmx's variable registry "
                           "(urmx/variables.toml)") from None
    out = {k: entry[k] for k in FIELDS if k in entry}
    if templated(entry):
        try:
            out = {k: v.format_map(context) for k, v in out.items()}
        except KeyError as exc:
            raise KeyError(f"{name!r} needs {exc.args[0]!r} (its units depend on the study's "
                           "intensity measure: pass intensity_context(im))") from None
    return out


def templated(entry: dict[str, str]) -> bool:
    """Whether a registry entry holds ``{placeholders}`` filled from a context."""
    return any("{" in str(v) for v in entry.values())


def intensity_measures() -> tuple[str, ...]:
    """The intensity measures of the registry (its ``im.<name>`` entries), in its order."""
    return tuple(key[3:] for key in registry() if key.startswith("im."))


def intensity_context(im: str) -> dict[str, str]:
    """The placeholders ``im_units`` and ``im_name`` of an intensity measure (the units and
    long name of its ``im.<name>`` entry) for :func:`attrs`.

    Raises
    ------
    KeyError
        An unknown intensity measure.
    """
    entry = registry().get(f"im.{im}")
    if entry is None:
        raise KeyError(f"unknown intensity measure {im!r} (known: "
                       f"{', '.join(intensity_measures())})")
    return {"im_units": entry["units"], "im_name": entry["long_name"]}


def stamp(obj, scope: str | None = None):
    """Set the registry's attributes on every registered variable and coordinate of an
    xarray Dataset or DataArray (in place; returned for chaining). Names the registry
    does not know are left as they are.

    Entries with placeholders take them from the object's ``intensity_measure`` attribute
    (IDA archives); without it they are left as they are (never stamped as ``{im_units}``).
    """
    reg = registry()
    context = {}
    im = getattr(obj, "attrs", {}).get("intensity_measure")
    if im is not None:
        try:
            context = intensity_context(str(im))
        except KeyError:
            context = {}

    def entry(name):
        if name is None:
            return None
        return (reg.get(f"{scope}.{name}") if scope is not None else None) or reg.get(name)

    def update(target, name):
        e = entry(name)
        if e is not None and (context or not templated(e)):
            target.attrs.update(attrs(name, scope, **context))

    for name in [*obj.coords, *getattr(obj, "data_vars", ())]:
        update(obj[name], name)
    if not hasattr(obj, "data_vars"):  # a DataArray itself
        update(obj, obj.name)
    return obj
