"""Which study an archive or a parts folder belongs to: its *definition*, not its name.

A study's definition is the canonical form its cells' keys come from (`urmx.study.cells`):
the kind, the kind's settings, the tail, t_rest (when not the default), the default impact
law, the names of the cell dimensions (together, the *base*, kept as the archive's
attribute ``study_definition``) and the values of each dimension (the wall, diaphragm and
record ids, the COR values, ...: an archive's coordinates). The study's ``name`` is a
label: two files of one name with other walls are two studies, a renamed file the same one.

A run into an existing archive (or parts folder) compares the two (:func:`compare`):

- the same base and, on every dimension, the same values: the same study;
- the same base and, on every dimension, values that hold the others or are held by them:
  the study *extended* (new cells are computed, the others taken over) or *shrunk* (the
  cells of the values left out are dropped, and the run says which);
- anything else (another base, or a dimension whose values were swapped for others, such as
  walls s12, s18 there and s14 here): another study, whose cells the run would lose, so it
  needs ``force``.

Dimensions of more than `LISTED` values are kept in a parts folder as a digest: such a
dimension is the same or another, never found extended.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass, field
from typing import Any

from ..model import T_REST

#: values of a dimension a parts folder lists (more: a digest of them)
LISTED = 65536


def _plain_value(value: Any) -> Any:
    """A dimension's value as plain Python; a number as a float, so that an archive's
    int64 or float64 coordinate compares equal to the study's ints or floats."""
    value = value.item() if hasattr(value, "item") else value
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    return value


def _canonical(value: Any) -> str:
    return json.dumps(value, sort_keys=True, default=str)


def _plain(value: Any) -> Any:
    """A kind's settings as plain values, as the cells' keys take them
    (`urmx.study.cells`): its ``to_dict()`` where it has one, a dataclass as its dict."""
    if callable(getattr(value, "to_dict", None)):
        return value.to_dict()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return dataclasses.asdict(value)
    return value


def base(study: Any, kind: Any) -> str:
    """The base of a study's definition as canonical JSON (module docstring)."""
    dims = kind.cell_dims(study)
    base = {"kind": kind.name, "settings": _plain(study.settings), "tail": study.tail,
            "impact": None if "impact" in dims else study.impact, "dims": list(dims)}
    t_rest = getattr(study, "t_rest", T_REST)
    if t_rest != T_REST:  # the default left out, as in the cells' keys: earlier archives stay
        base["t_rest"] = t_rest
    return _canonical(base)


def labels(study: Any, kind: Any) -> dict[str, list]:
    """The values of each cell dimension of a study, as plain Python values."""
    return {n: [_plain_value(v) for v in values] for n, values in kind.cell_dims(study).items()}


def stored(values: list) -> Any:
    """A dimension's values as a parts folder keeps them (a digest when many)."""
    if len(values) <= LISTED:
        return values
    return {"n": len(values), "sha256": hashlib.sha256(_canonical(values).encode()).hexdigest()}


@dataclass
class Definition:
    """A study's definition: its `base` (None: not known, an older archive) and the values
    of each of its cell dimensions (`dims`; a digest dict for a long one, None: not known)."""

    name: str | None
    base: str | None
    dims: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def of(cls, study: Any, kind: Any) -> Definition:
        return cls(study.name, base(study, kind), labels(study, kind))

    def to_json(self) -> str:
        return json.dumps({"name": self.name, "base": self.base,
                           "dims": {n: stored(v) for n, v in self.dims.items()}})

    @classmethod
    def from_json(cls, text: str) -> Definition:
        d = json.loads(text)
        return cls(d.get("name"), d.get("base"), dict(d.get("dims", {})))

    @classmethod
    def of_archive(cls, ds: Any, dims: list[str]) -> Definition:
        """The definition of the study an archive holds: its ``study_definition`` base and
        its coordinates."""
        found = {n: [_plain_value(v) for v in ds[n].values.tolist()]
                 for n in dims if n in ds.coords and ds[n].ndim == 1}
        return cls(ds.attrs.get("study_name"), ds.attrs.get("study_definition"), found)


@dataclass
class Verdict:
    """How a new definition stands to an old one: ``same`` study (extended or shrunk
    included) or not, why not (`why`), and what the new one leaves out (`dropped`: per
    dimension, the values)."""

    same: bool
    why: str = ""
    dropped: dict[str, list] = field(default_factory=dict)

    def dropped_text(self) -> str:
        return "; ".join(f"{n} {_few(v)}" for n, v in self.dropped.items())


def _few(values: Any, at_most: int = 4) -> str:
    if isinstance(values, dict):
        return f"({values['n']:,} values)"
    shown = ", ".join(str(v) for v in values[:at_most])
    more = len(values) - at_most
    return shown + (f" and {more:,} more" if more > 0 else "")


def _dimension(name: str, old: Any, new: list) -> Verdict:
    """Compare one dimension's values."""
    if isinstance(old, dict):  # a digest
        if stored(new) == old:
            return Verdict(True)
        return Verdict(False, f"{name}: {old['n']:,} values there, {len(new):,} other ones "
                              "here")
    a, b = set(map(_canonical, old)), set(map(_canonical, new))
    if b >= a:
        return Verdict(True)
    if b <= a:
        return Verdict(True, dropped={name: [v for v in old if _canonical(v) not in b]})
    return Verdict(False, f"{name} {_few(old)} there, {_few(new)} here")


def compare(old: Definition, new: Definition) -> Verdict:
    """Whether `new` is the study `old` holds (the same, extended or shrunk) or another one
    (module docstring). An old definition without a base (an older urmx) is the same study
    only under the same name."""
    if old.base is None:
        if old.name != new.name:
            return Verdict(False, f"study {old.name!r} there, {new.name!r} here")
    elif old.base != new.base:
        return Verdict(False, _base_difference(old.base, new.base))
    verdict = Verdict(True)
    for name, values in new.dims.items():
        if old.dims.get(name) is None:
            continue  # not known there (an older archive without that coordinate)
        one = _dimension(name, old.dims[name], values)
        if not one.same:
            return one
        verdict.dropped.update(one.dropped)
    return verdict


def _base_difference(old: str, new: str) -> str:
    """The first entry of two bases that differs, in words."""
    a, b = json.loads(old), json.loads(new)
    for key in sorted(set(a) | set(b)):
        if a.get(key) != b.get(key):
            return f"{key} {_canonical(a.get(key))} there, {_canonical(b.get(key))} here"
    return "another definition"  # pragma: no cover - equal bases compare equal above
