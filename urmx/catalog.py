"""The catalog and study files: walls, diaphragms, the parametric building (``catalog/*.toml``)
and the study files that run them, read and checked before any computation.

Data lives in the top-level ``catalog/`` folder, never in code:

- ``walls.toml``: the Table II test walls with their own supports and PMR;
- ``diaphragms.toml``: D1-D5 of Table IV (D5 the paper's 1e9 N/m spring) and ``D5-pinned``
  (a pinned top, ``rigid``);
- ``building.toml``: the parametric building (plan, density, diaphragm weight, wall length)
  and the parametric wall family (230 mm, slenderness 8-24, crack at 2/3, PMR 75);
- ``studies/*.toml``: study grids (`load_study`);
- ``paper.toml``: the paper's own numbers (read by :mod:`urmx.paper`, which also fits the
  building to them).

A study file may also define its own walls (``[walls.<id>]``, by their masses or in building
terms), diaphragms (``[diaphragms.<id>]``) and record files (``[records.<id>]``, a file or a
folder of files) beside ``[study]``; an own item with a catalog id must say
``override = true``. A diaphragm entry ``"D1/both"`` (or ``"D1/top"``) gives the cells on
it their own supports, so that one study holds single- and higher-storey walls. A
``[study.<kind>]`` table names the study's kind and holds its settings: the catalog keeps
it as data (``Study.tables``), refuses a table no registered kind reads, and has the kind
parse it (`urmx.study.kinds`); a study without one is the default kind.

Every key a study file (and a catalog file) accepts is declared once, in `STUDY_FILE_KEYS`
and `CATALOG_FILE_KEYS` (with each registered kind's ``keys``: :func:`file_keys`); the
loader refuses any other key, and ``docs/study-files.md`` documents exactly these (a test
holds the two together). Ids are compared in Unicode normal form NFC. Every error names
the file, the key and (where it can be found) the line.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import os
import re
import sys
import unicodedata
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .config import data_dir
from .errors import MissingFileError, UrmxError
from .model import (
    EFFECTIVE_MASS,
    RIGID,
    T_REST,
    Wall,
    effective_diaphragm_mass,
    effective_wall_mass,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["EFFECTIVE_MASS", "CatalogError", "Catalog", "Building", "Diaphragm", "WallSpec",
           "Study", "History", "OwnRecord", "load_catalog", "load_study", "read_wall",
           "study_path", "file_keys", "STUDY_FILE_KEYS", "CATALOG_FILE_KEYS"]

SPECIMEN = "specimen"  # the diaphragm id meaning "the wall's own supports" (test walls)
SUPPORTS = ("top", "both", SPECIMEN)
IMPACT_LAWS = ("scale", "contact")
#: the supports' fields of a Wall: a wall table that states any of them keeps its own supports
SUPPORT_FIELDS = ("bottom_mass", "top_mass", "bottom_stiffness", "top_stiffness",
                  "bottom_damping", "top_damping")
WALL_FIELDS = ("thickness", "height", "crack_ratio", "mass", *SUPPORT_FIELDS, "pmr", "kappa")
#: a wall given in building terms (`urmx.Wall.in_building`): its mass from the masonry
#: density and the out-of-plane walls' length (Eq. 7), and, with the diaphragm terms, its
#: own diaphragm (weight over the plan area, and stiffness or frequency)
MASS_TERMS = ("density", "wall_length")
DIAPHRAGM_TERMS = ("diaphragm_weight", "plan_area", "diaphragm_stiffness",
                   "diaphragm_frequency", "supports", "damping")
#: keys of a wall table (``walls.toml``, a study's ``[walls.<id>]``, a wall file)
WALL_KEYS = (*WALL_FIELDS, "allow_unusual", *MASS_TERMS, *DIAPHRAGM_TERMS, "name", "source",
             "records")
#: keys of a diaphragm table (``diaphragms.toml``, a study's ``[diaphragms.<id>]``)
DIAPHRAGM_KEYS = ("stiffness", "damping", "description", "direction")
#: keys of a study's ``[records.<id>]`` table: one record file, or a folder of them
RECORD_KEYS = ("file", "folder", "pattern", "channel", "dt", "unit", "format", "scale",
               "sha256", "allow_unusual", "override")
# dimensions of a study's grid, in order; the last three are optional (study keys)
DIMS = ("wall", "diaphragm", "record", "cor", "scale", "impact", "damping")

#: every key of a study file by table: the one declaration the loader checks tables
#: against (a registered kind's ``[study.<kind>]`` keys are its ``Kind.keys``:
#: :func:`file_keys`). ``<wall id>`` and ``<record id>`` stand for keys that are ids.
STUDY_FILE_KEYS: dict[str, tuple[str, ...]] = {
    "[study]": ("name", "title", "description", "walls", "diaphragms", "supports", "records",
                "cor", "scale", "impact", "damping", "tail", "t_rest", "catalog"),
    "[study.pairs]": ("<wall id>",),
    "[study.scale_factor]": ("<record id>",),
    "[[study.history]]": ("wall", "diaphragm", "record", "cor"),
    "[walls.<id>]": (*WALL_KEYS, "override"),
    "[diaphragms.<id>]": (*DIAPHRAGM_KEYS, "override"),
    "[records.<id>]": RECORD_KEYS,
}
#: every key of the catalog files a study can bring (``[study] catalog = "folder"``)
CATALOG_FILE_KEYS: dict[str, tuple[str, ...]] = {
    "building.toml [building]": ("plan", "density", "wall_length", "diaphragm_weight"),
    "building.toml [parametric_walls]": ("thickness", "crack_ratio", "pmr", "kappa",
                                         "slenderness"),
    "building.toml [calibration]": ("instability_wall", "instability_weight"),
    "walls.toml [<id>]": WALL_KEYS,
    "diaphragms.toml [<id>]": DIAPHRAGM_KEYS,
}
#: the ``[study]`` table's sub-tables (beside a registered kind's ``[study.<kind>]``)
_STUDY_SUBTABLES = ("pairs", "scale_factor", "history")
STUDY_KEYS = (*STUDY_FILE_KEYS["[study]"], *_STUDY_SUBTABLES)  # keys of [study] itself


def file_keys() -> dict[str, tuple[str, ...]]:
    """Every table a study file and a catalog file may hold, with its keys:
    `STUDY_FILE_KEYS`, each built-in kind's ``[study.<kind>]`` with its ``Kind.keys``, and
    `CATALOG_FILE_KEYS` (what ``docs/study-files.md`` must document)."""
    from .study import kinds

    out = dict(STUDY_FILE_KEYS)
    for kind in kinds.BUILT_IN:
        if kind.table:
            out[f"[study.{kind.table}]"] = tuple(kind.keys)
    out.update(CATALOG_FILE_KEYS)
    return out


class CatalogError(UrmxError, ValueError):
    """A catalog or study file is invalid; the message names the file, key and line."""


#: largest damping ratio accepted for a support (critical damping); larger values are
#: almost surely percentages typed as ratios
MAX_DAMPING = 1.0


def damping_ratio_problem(name: str, value: Any) -> str | None:
    """Why `value` is not a damping ratio in [0, `MAX_DAMPING`] (None when it is)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None  # a type error is reported by Wall itself
    if math.isfinite(value) and value > MAX_DAMPING:
        return (f"{name}={value!r} is not a damping ratio in [0, {MAX_DAMPING:g}] "
                f"(0.12 means 12 % of critical; {value!r} looks like a percentage)")
    return None


def damping_problem(table: dict) -> str | None:
    """The first damping field of a table of Wall fields that is not a ratio, or None."""
    for name in ("bottom_damping", "top_damping", "damping"):
        problem = damping_ratio_problem(name, table.get(name))
        if problem:
            return problem
    return None


def catalog_dir(path: str | os.PathLike | None = None) -> Path:
    """The catalog folder: `path`, else ``catalog/`` of the source checkout, or the copy an
    installed wheel carries (`urmx.config.data_dir`)."""
    return Path(path) if path is not None else data_dir("catalog")


def nfc(text: str) -> str:
    """An id in Unicode normal form NFC, the one form ids are compared in."""
    return unicodedata.normalize("NFC", text)


# ---- locating keys in TOML text for error messages -------------------------------------

class _Source:
    """A parsed TOML file that can point at the line of a key or value; its tables' keys
    in NFC (two keys of one table that are the same text in different normal forms are
    refused)."""

    def __init__(self, path: Path):
        self.path = Path(path)
        try:
            self.text = self.path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise MissingFileError(f"{self.path}: no such file") from None
        except (OSError, UnicodeDecodeError) as exc:  # a folder, unreadable, not text
            raise CatalogError(f"{self.path}: cannot be read as a TOML file "
                               f"({getattr(exc, 'strerror', None) or exc})") from None
        try:
            data = tomllib.loads(self.text)
        except tomllib.TOMLDecodeError as exc:
            raise CatalogError(f"{self.path}: not valid TOML: {exc}") from None
        self.data = self._normal(data, "")

    def _normal(self, value: Any, where: str) -> Any:
        """`value` with every table's keys in NFC, recursively."""
        if isinstance(value, list):
            return [self._normal(v, f"{where}[{i}]") for i, v in enumerate(value)]
        if not isinstance(value, dict):
            return value
        out: dict = {}
        spelt: dict[str, str] = {}
        for k, v in value.items():
            n = nfc(k)
            if n in out:
                key = f"{where}.{n}".lstrip(".")
                line = next((i for i, ln in enumerate(self.text.splitlines(), 1)
                             if k in ln.split("#", 1)[0]
                             and ln.lstrip().startswith(("[", k, f'"{k}"'))), None)
                at = f"{self.path}:{line}" if line else str(self.path)
                raise CatalogError(f"{at}: {key}: {spelt[n]!r} and {k!r} are the same text "
                                   "in different Unicode normal forms (NFC and NFD): one "
                                   "id, given twice")
            spelt[n] = k
            out[n] = self._normal(v, f"{where}.{n}".lstrip("."))
        return out

    def line(self, *needles: str) -> int | None:
        """First line holding the last needle after the lines holding the earlier ones."""
        lines = self.text.splitlines()
        start = 0
        found = None
        for k, needle in enumerate(needles):
            if k and needle == needles[k - 1]:  # the same needle again: its next line
                start += 1
            pat = re.compile(r"(^|[^\w-])" + re.escape(str(needle)) + r"($|[^\w-])")
            for i in range(start, len(lines)):
                code = nfc(lines[i].split("#", 1)[0])
                if pat.search(code):
                    found, start = i + 1, i
                    break
            else:
                return found
        return found

    def error(self, key: str, message: str, *needles: str) -> CatalogError:
        line = self.line(*(needles or key.split(".")))
        where = f"{self.path}:{line}" if line else str(self.path)
        return CatalogError(f"{where}: {key}: {message}")

    def check_keys(self, key: str, table: dict, known: tuple[str, ...], *needles: str,
                   what: str = "") -> None:
        """Refuse a key of `table` (the table `key`) that is not in `known`, naming the
        close ones (`what`: the kind of key, ``"wall "``)."""
        for name in table:
            if name not in known:
                close = difflib.get_close_matches(name, known, n=2)
                hint = f"did you mean {' or '.join(map(repr, close))}? " if close else ""
                raise self.error(f"{key}.{name}".lstrip("."), f"unknown {what}key {name!r} "
                                 f"({hint}known: {', '.join(known)})", *needles, name)


# ---- catalog items ----------------------------------------------------------------------

@dataclass(frozen=True)
class Diaphragm:
    """A timber diaphragm of Table IV.

    Parameters
    ----------
    id : str
        Catalog id (``D1`` ... ``D5``).
    stiffness : float or "rigid"
        Effective in-plane stiffness used in the analyses. [N m-1]
    damping : float
        Viscous damping ratio of the dashpot beside the spring. [1]
    """

    id: str
    stiffness: float | str
    damping: float = 0.12
    description: str = ""
    direction: str = ""

    @property
    def rigid(self) -> bool:
        return self.stiffness == RIGID

    @property
    def stiffness_value(self) -> float:
        """Stiffness as a number, inf when rigid. [N m-1]"""
        return math.inf if self.rigid else float(self.stiffness)


@dataclass(frozen=True)
class WallSpec:
    """A catalog wall: a `Wall` template plus its id and metadata.

    Parametric walls carry only the wall itself (their supports come from the study's
    diaphragm, through `urmx.Wall.in_building`); a wall whose table states its supports
    (test walls, a study's own wall with its own diaphragm) keeps them: it runs on the
    diaphragm ``specimen`` only. ``own_supports`` names the keys that stated them.
    """

    id: str
    wall: Wall
    name: str = ""
    source: str = ""
    records: tuple[str, ...] = ()
    parametric: bool = False
    own_supports: tuple[str, ...] = ()

    @property
    def slenderness(self) -> float:
        return self.wall.slenderness


@dataclass(frozen=True)
class Building:
    """The parametric building of Section 6 (``catalog/building.toml``).

    Parameters
    ----------
    plan : tuple of float
        Plan dimensions. [m]
    density : float
        Masonry density. [kg m-3]
    wall_length : float
        Length of each of the two out-of-plane walls. [m]
    diaphragm_weight : float
        Diaphragm seismic weight per plan area. [kPa]
    """

    plan: tuple[float, float]
    density: float
    wall_length: float
    diaphragm_weight: float

    @property
    def plan_area(self) -> float:
        return self.plan[0] * self.plan[1]

    def wall_mass(self, thickness: float, height: float) -> float:
        """Effective wall mass, Eq. 7: 8/15 of both out-of-plane walls' mass. [kg]"""
        return effective_wall_mass(self.density, thickness, height, self.wall_length)

    @property
    def diaphragm_mass(self) -> float:
        """Effective diaphragm mass, Eq. 7: 8/15 of its seismic weight over g. [kg]"""
        return effective_diaphragm_mass(self.diaphragm_weight, self.plan_area)

    def wall(self, spec: WallSpec, diaphragm: Diaphragm, supports: str,
             damping: float) -> Wall:
        """A parametric wall of this building on `diaphragm` (`urmx.Wall.in_building`):
        ``supports`` "top" or "both", `damping` the ratio of each flexible diaphragm. [1]"""
        w = spec.wall
        return Wall.in_building(
            thickness=w.thickness, height=w.height, crack_ratio=w.crack_ratio, pmr=w.pmr,
            kappa=w.kappa, density=self.density, wall_length=self.wall_length,
            diaphragm_weight=self.diaphragm_weight, plan_area=self.plan_area,
            diaphragm_stiffness=diaphragm.stiffness, damping=damping, supports=supports,
            allow_unusual=w.allow_unusual)

    def replace(self, **changes: Any) -> Building:
        d = dict(plan=self.plan, density=self.density, wall_length=self.wall_length,
                 diaphragm_weight=self.diaphragm_weight)
        d.update(changes)
        return Building(**d)


@dataclass
class Catalog:
    """Everything in ``catalog/``: walls (test and parametric), diaphragms, building."""

    walls: dict[str, WallSpec]
    diaphragms: dict[str, Diaphragm]
    building: Building
    calibration: dict[str, Any] = field(default_factory=dict)
    path: Path | None = None

    @property
    def parametric_walls(self) -> list[str]:
        return [k for k, w in self.walls.items() if w.parametric]


#: a Wall's error names its field first: ``Wall thickness=350 ...``, ``Wall needs mass``,
#: ``Wall.in_building density=...``
_WALL_ERROR = re.compile(r"^Wall(?:\.in_building)?:? (?:needs )?(\w+)")
#: for a wall in building terms: the key that gave each Wall field
_FROM_BUILDING = {"mass": "density", "top_mass": "diaphragm_weight",
                  "bottom_mass": "diaphragm_weight", "top_damping": "damping",
                  "bottom_damping": "damping"}


def _wall_from_table(src: _Source, key: str, table: dict, known: tuple[str, ...] = WALL_KEYS,
                     **extra: Any) -> Wall:
    """The `Wall` of a TOML table of wall fields or building terms (`extra` fields added);
    ``key`` is the table's dotted key ("" at the top level). The one TOML-to-Wall loader:
    catalog walls, study walls and wall files (:func:`read_wall`)."""
    where = (key,) if key else ()
    src.check_keys(key, table, known, *where, what="wall ")
    if any(k in table for k in (*MASS_TERMS, *DIAPHRAGM_TERMS)):
        return _building_wall(src, key, table)
    values = {k: table[k] for k in (*WALL_FIELDS, "allow_unusual") if k in table}
    values.update(extra)
    return _checked_wall(src, key, values, lambda: Wall(**values))


def _checked_wall(src: _Source, key: str, values: dict, build, renamed: dict | None = None
                  ) -> Wall:
    """``build()`` (a Wall), its errors as a CatalogError naming the key the Wall's
    message names (`renamed` maps a Wall field to the table key that gave it)."""
    renamed = renamed or {}
    problem = damping_problem(values)
    if problem:
        bad = problem.split("=", 1)[0]
        raise src.error(f"{key}.{bad}".lstrip("."), problem, *((key,) if key else ()), bad)
    try:
        return build()
    except (TypeError, ValueError) as exc:
        found = _WALL_ERROR.match(str(exc))
        bad = renamed.get(found.group(1), found.group(1)) if found else None
        bad = bad if bad in WALL_KEYS else None
        message = str(exc).replace("Wall.__init__()", "wall")
        raise src.error(f"{key}.{bad}".lstrip(".") if bad else key or "wall", message,
                        *((key,) if key else ()), *([bad] if bad else [])) from None


def _building_wall(src: _Source, key: str, t: dict) -> Wall:
    """A wall given in building terms: its mass by Eq. 7 from ``density`` and
    ``wall_length``; with the diaphragm terms, its own diaphragm (`urmx.Wall.in_building`)."""
    where = (key,) if key else ()
    mixed = [k for k in ("mass", *SUPPORT_FIELDS) if k in t]
    if mixed:
        raise src.error(f"{key}.{mixed[0]}".lstrip("."), "a wall in building terms (density, "
                        "wall_length, ...) gets its masses and supports from them: give "
                        f"either those or {mixed[0]}, not both", *where, mixed[0])
    need = [*MASS_TERMS, "thickness", "height", "crack_ratio"]
    if any(k in t for k in DIAPHRAGM_TERMS):
        need += ["diaphragm_weight", "plan_area"]
        if ("diaphragm_stiffness" in t) == ("diaphragm_frequency" in t):
            raise src.error(key or "wall", "a wall with its own diaphragm takes exactly one "
                            "of diaphragm_stiffness [N m-1] and diaphragm_frequency [Hz]",
                            *where)
    missing = [k for k in need if k not in t]
    if missing:
        raise src.error(f"{key}.{missing[0]}".lstrip("."), "missing (a wall in building "
                        f"terms needs {', '.join(need)})", *where)
    for k in (*MASS_TERMS, "thickness", "height"):
        v = t[k]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                or v <= 0:
            raise src.error(f"{key}.{k}".lstrip("."), f"{v!r} must be a positive number",
                            *where, k)
    fields = {k: t[k] for k in ("thickness", "height", "crack_ratio", "pmr", "kappa",
                                "allow_unusual") if k in t}
    if "diaphragm_weight" not in t:
        mass = effective_wall_mass(t["density"], t["thickness"], t["height"], t["wall_length"])
        return _checked_wall(src, key, fields, lambda: Wall(mass=mass, **fields),
                             _FROM_BUILDING)
    terms = {k: t[k] for k in (*MASS_TERMS, *DIAPHRAGM_TERMS) if k in t}
    stiff = "diaphragm_stiffness" if "diaphragm_stiffness" in t else "diaphragm_frequency"
    renamed = dict(_FROM_BUILDING, top_stiffness=stiff, bottom_stiffness=stiff)
    return _checked_wall(src, key, {**fields, **terms},
                         lambda: Wall.in_building(**fields, **terms), renamed)


def read_wall(path: str | os.PathLike) -> Wall:
    """A `Wall` from a TOML file: its fields (or building terms) in a ``[wall]`` table or at
    the top level (``name``, ``source`` and ``records`` may sit beside them, as in
    ``walls.toml``).

    Raises
    ------
    urmx.errors.MissingFileError
        No such file (a FileNotFoundError).
    CatalogError
        Not TOML, an unknown key, a missing or bad field: the message names the file, the
        key and (where it can be found) the line.
    """
    path = Path(path)
    if not path.is_file():
        raise MissingFileError(f"wall file {str(path)!r} does not exist")
    src = _Source(path)
    if "wall" not in src.data:
        return _wall_from_table(src, "", src.data)
    extra = [k for k in src.data if k != "wall"]
    if extra:
        raise src.error(extra[0], f"unknown key(s) {', '.join(extra)} beside the [wall] table")
    if not isinstance(src.data["wall"], dict):
        raise src.error("wall", "must be a table of Wall fields")
    return _wall_from_table(src, "wall", src.data["wall"])


def _diaphragm_from_table(src: _Source, key: str, ident: str, t: dict,
                          known: tuple[str, ...] = DIAPHRAGM_KEYS) -> Diaphragm:
    if not isinstance(t, dict):
        raise src.error(key, "must be a table (stiffness, damping, ...)", key)
    src.check_keys(key, t, known, key)
    if "stiffness" not in t:
        raise src.error(f"{key}.stiffness", "missing", key)
    k = t["stiffness"]
    if isinstance(k, str):
        if k.strip().lower() != RIGID:
            raise src.error(f"{key}.stiffness", f'{k!r} is not a number or "rigid"', key,
                            "stiffness")
        k = RIGID
    elif isinstance(k, bool) or not isinstance(k, (int, float)) or not math.isfinite(k) \
            or k <= 0:
        raise src.error(f"{key}.stiffness", f"{k!r} must be a positive number [N m-1] or "
                        '"rigid"', key, "stiffness")
    damping = t.get("damping", 0.12)
    if isinstance(damping, bool) or not isinstance(damping, (int, float)) \
            or not math.isfinite(damping) or damping < 0:
        raise src.error(f"{key}.damping", f"{damping!r} must be a ratio >= 0", key, "damping")
    problem = damping_ratio_problem("damping", damping)
    if problem:
        raise src.error(f"{key}.damping", problem, key, "damping")
    return Diaphragm(id=ident, stiffness=k if k == RIGID else float(k), damping=float(damping),
                     description=t.get("description", ""), direction=t.get("direction", ""))


def parametric_wall_id(slenderness: float) -> str:
    """Id of a parametric wall: ``s`` + the slenderness on two digits (``s18``)."""
    return f"s{int(round(slenderness)):02d}"


def _table(src: _Source, name: str, label: str, required: tuple[str, ...] = ()) -> dict:
    """The table `name` of a catalog file, its keys checked against `CATALOG_FILE_KEYS`
    (`label`) and the `required` ones present."""
    t = src.data.get(name, {})
    if not isinstance(t, dict):
        raise src.error(name, "must be a table", name)
    src.check_keys(name, t, CATALOG_FILE_KEYS[label], name)
    for k in required:
        if k not in t:
            raise src.error(f"{name}.{k}", "missing", name)
    return t


def _building(src: _Source) -> Building:
    """The ``[building]`` table of ``building.toml``."""
    for name in src.data:
        if name not in ("building", "parametric_walls", "calibration"):
            raise src.error(name, "unknown table (known: building, parametric_walls, "
                            "calibration)", name)
    b = _table(src, "building", "building.toml [building]", ("plan", "density",
                                                             "wall_length", "diaphragm_weight"))
    try:
        plan = tuple(float(x) for x in b["plan"])
        if len(plan) != 2:
            raise ValueError
        values = {k: float(b[k]) for k in ("density", "wall_length", "diaphragm_weight")}
    except (TypeError, ValueError):
        raise src.error("building", "plan must be two lengths [m] and density, wall_length, "
                        "diaphragm_weight numbers", "building") from None
    return Building(plan=plan, **values)  # type: ignore[arg-type]


def _parametric_walls(src: _Source, building: Building) -> dict[str, WallSpec]:
    """The parametric wall family of ``building.toml`` (``[parametric_walls]``)."""
    if "parametric_walls" not in src.data:
        return {}
    pw = _table(src, "parametric_walls", "building.toml [parametric_walls]",
                ("thickness", "crack_ratio", "slenderness"))
    walls = {}
    for s in _values(src, "parametric_walls.slenderness", pw["slenderness"], float):
        values = {k: pw[k] for k in ("thickness", "crack_ratio", "pmr", "kappa") if k in pw}
        t = values["thickness"]
        if isinstance(t, bool) or not isinstance(t, (int, float)):
            raise src.error("parametric_walls.thickness", f"{t!r} is not a number",
                            "parametric_walls", "thickness")
        t = values["thickness"] = float(t)
        h = round(s * t, 10)
        ident = parametric_wall_id(s)
        wall = _wall_from_table(src, "parametric_walls", {}, **values, height=h,
                                mass=building.wall_mass(t, h))
        walls[ident] = WallSpec(ident, wall, name=f"slenderness {s:g}",
                                source="paper Section 6 (parametric)", parametric=True)
    return walls


def load_catalog(path: str | os.PathLike | None = None) -> Catalog:
    """Load ``walls.toml``, ``diaphragms.toml`` and ``building.toml`` of a catalog folder."""
    root = catalog_dir(path)
    bsrc = _Source(root / "building.toml")
    building = _building(bsrc)
    walls = _parametric_walls(bsrc, building)
    calibration = _table(bsrc, "calibration", "building.toml [calibration]")
    wsrc = _Source(root / "walls.toml")
    for ident, t in wsrc.data.items():
        walls[ident] = _wall_spec(wsrc, ident, t)
    dsrc = _Source(root / "diaphragms.toml")
    diaphragms = {ident: _diaphragm_from_table(dsrc, ident, ident, t)
                  for ident, t in dsrc.data.items()}
    return Catalog(walls, diaphragms, building, dict(calibration), root)


def _wall_spec(src: _Source, ident: str, t: dict, key: str | None = None,
               known: tuple[str, ...] = WALL_KEYS) -> WallSpec:
    key = key or ident
    if not isinstance(t, dict):
        raise src.error(key, "must be a table of wall fields", key)
    wall = _wall_from_table(src, key, t, known)
    own = tuple(k for k in (*SUPPORT_FIELDS, *DIAPHRAGM_TERMS) if k in t)
    return WallSpec(ident, wall, name=t.get("name", ident), source=t.get("source", str(src.path)),
                    records=tuple(t.get("records", ())), own_supports=own)


# ---- studies -----------------------------------------------------------------------------

@dataclass(frozen=True)
class History:
    """One cell whose time histories are kept."""

    wall: str
    diaphragm: str
    record: str
    cor: float

    @property
    def label(self) -> str:
        return f"{self.wall}/{self.diaphragm}/{self.record}/cor{self.cor:g}"


@dataclass(frozen=True)
class OwnRecord:
    """A record file a study file declares (``[records.<id>]``), before it is read
    (`urmx.study.samples.resolve_records` reads it, once).

    Parameters
    ----------
    id : str
        Record id: the table's id for a file, ``<table>/<file stem>`` for each file of a
        folder.
    path : Path
        The file, absolute.
    file : str
        The file as the study names it, relative to the study file's folder.
    table : str
        The ``[records.<table>]`` it comes from.
    channel, unit, format : str or None
        As for `urmx.records.describe`.
    dt : float or None
        Time step, for files that do not state it. [s]
    scale : float or None
        The record's scale factor (1 when None). [1]
    sha256 : str or None
        The file's SHA-256 the study pins (a file that differs is refused).
    allow_unusual : bool
        Read a record outside the plausible time steps and peaks.
    override : bool
        The id is also a records-manifest id, and this file replaces it.
    """

    id: str
    path: Path
    file: str
    table: str
    channel: str | None = None
    dt: float | None = None
    unit: str | None = None
    format: str | None = None
    scale: float | None = None
    sha256: str | None = None
    allow_unusual: bool = False
    override: bool = False


@dataclass
class Study:
    """A study grid read from a TOML file (`load_study`).

    ``dims`` maps every grid dimension (``wall``, ``diaphragm``, ``record``, ``cor`` and any
    of ``scale``, ``impact``, ``damping`` the file adds) to its values, in `DIMS` order.
    ``own_records`` holds the record files the study declares (``[records.<id>]``) by
    record id; every other record id is one of the records manifest.
    """

    name: str
    title: str
    path: Path | None
    text: str
    catalog: Catalog
    walls: list[WallSpec]
    diaphragms: list[Diaphragm]
    supports: str
    records: list[str]
    cor: list[float]
    extra: dict[str, list]  # added dimensions: scale, impact, damping
    impact: str = "scale"
    tail: float = 0.0
    t_rest: float = T_REST  # v_rest = g_open/t_rest (MODEL.md section 4) [s]
    scale_factor: dict[str, float] = field(default_factory=dict)
    pairs: dict[str, list[str]] | None = None
    histories: list[History] = field(default_factory=list)
    own_supports: dict[str, str] = field(default_factory=dict)  # diaphragm label -> supports
    tables: dict[str, Any] = field(default_factory=dict)  # [study.<kind>] tables, as data
    kind: str = "grid"  # the study kind (urmx.study.kinds) its tables make it
    settings: Any = None  # the kind's settings, parsed from its table
    own_records: dict[str, OwnRecord] = field(default_factory=dict)
    _src: Any = field(default=None, repr=False)

    @property
    def dims(self) -> dict[str, list]:
        d = {"wall": [w.id for w in self.walls], "diaphragm": [d.id for d in self.diaphragms],
             "record": list(self.records), "cor": list(self.cor)}
        d.update(self.extra)
        return d

    @property
    def specimen(self) -> bool:
        """Whether each wall stands on its own supports (the test walls of Table II)."""
        return self.supports == SPECIMEN

    @property
    def size(self) -> int:
        """Number of analyses run (cells the pairs exclude are not counted)."""
        n = math.prod(len(v) for k, v in self.dims.items() if k not in ("wall", "record"))
        return n * sum(1 for w in self.walls for r in self.records if self.paired(w.id, r))

    def paired(self, wall: str, record: str) -> bool:
        return self.pairs is None or record in self.pairs.get(wall, ())

    def supports_of(self, diaphragm: Diaphragm | str) -> str:
        """Supports of the cells on a diaphragm: its own (a ``"D1/both"`` entry) or the
        study's."""
        label = diaphragm if isinstance(diaphragm, str) else diaphragm.id
        return self.own_supports.get(label, self.supports)

    def wall(self, spec: WallSpec, diaphragm: Diaphragm, damping: float | None = None) -> Wall:
        """The `Wall` of one cell: a catalog wall on a diaphragm as the study's supports say.

        On ``specimen`` the wall stands on its own supports; a parametric wall on a
        diaphragm is the building's wall (`Building.wall`, `urmx.Wall.in_building`); any
        other wall gets the diaphragm's stiffness and damping with the building's diaphragm
        mass. ``damping`` (the study's ``damping`` dimension) replaces the damping ratio of
        every flexible support.
        """
        supports = self.supports_of(diaphragm)
        if supports == SPECIMEN:
            w = spec.wall
            if damping is not None:
                w = w.replace(bottom_damping=0.0 if w.bottom_rigid else damping,
                              top_damping=0.0 if w.top_rigid else damping)
            return w
        zeta = diaphragm.damping if damping is None else damping
        if spec.parametric:
            return self.catalog.building.wall(spec, diaphragm, supports, zeta)
        md = self.catalog.building.diaphragm_mass
        zeta = 0.0 if diaphragm.rigid else zeta
        top = dict(top_stiffness=diaphragm.stiffness, top_mass=md, top_damping=zeta)
        if supports == "top":  # single storey: the ground is the rigid bottom support
            bottom = dict(bottom_stiffness=RIGID, bottom_mass=0.0, bottom_damping=0.0)
        else:  # "both": a higher storey between two diaphragms alike
            bottom = dict(bottom_stiffness=diaphragm.stiffness, bottom_mass=md,
                          bottom_damping=zeta)
        return spec.wall.replace(**top, **bottom)

    def error(self, key: str, message: str, *needles: str) -> CatalogError:
        if self._src is None:
            return CatalogError(f"study {self.name}: {key}: {message}")
        return self._src.error(key, message, *needles)


def _number(value: Any) -> bool:
    """Whether `value` is a finite number (not a bool)."""
    return not isinstance(value, bool) and isinstance(value, (int, float)) \
        and math.isfinite(value)


def _range(src: _Source, key: str, value: dict) -> list[float]:
    """The values of a ``{start, stop, step}`` range (stop included), counted before they
    are made: more than `urmx.study.limits.MAX_VALUES` is refused."""
    from .study.limits import MAX_VALUES

    needle = key.split(".")[-1]
    src.check_keys(key, value, ("start", "stop", "step"), needle)
    missing = [k for k in ("start", "stop", "step") if k not in value]
    if missing:
        raise src.error(key, f"range needs start, stop and step (missing {missing[0]})",
                        needle)
    bad = next((k for k in ("start", "stop", "step") if not _number(value[k])), None)
    if bad:
        raise src.error(key, f"range {bad}={value[bad]!r} is not a finite number", needle)
    start, stop, step = (float(value[k]) for k in ("start", "stop", "step"))
    if step <= 0:
        raise src.error(key, "range step must be positive", needle)
    count = (stop - start) / step + 1e-9
    if not count < MAX_VALUES:  # inf and NaN too
        raise src.error(key, f"range start={start:g}, stop={stop:g}, step={step:g} makes "
                        f"{count:.3g} values, more than the {MAX_VALUES:,} a dimension may "
                        "hold (urmx.study.limits.MAX_VALUES): is the step in the intended "
                        "unit?", needle)
    n = int(math.floor(count)) + 1
    decimals = max(0, -int(math.floor(math.log10(step))) + 3)
    return [round(start + i * step, decimals) for i in range(max(n, 0))]


def _values(src: _Source, key: str, value: Any, kind: type) -> list:
    """A dimension's values: a list, a scalar, or {start, stop, step} (stop included);
    string ids in NFC."""
    if isinstance(value, dict):
        values: list = _range(src, key, value)
    elif isinstance(value, list):
        values = value
    else:
        values = [value]
    if not values:
        raise src.error(key, "has no values (a dimension needs at least one)",
                        key.split(".")[-1])
    out = []
    for v in values:
        if kind is float:
            if not _number(v):
                raise src.error(key, f"{v!r} is not a finite number", key.split(".")[-1])
            out.append(float(v))
        else:
            if not isinstance(v, str):
                raise src.error(key, f"{v!r} is not a string id", key.split(".")[-1])
            out.append(nfc(v))
    if len(set(out)) != len(out):
        raise src.error(key, "has repeated values", key.split(".")[-1])
    return out


def study_path(name: str | os.PathLike, catalog: str | os.PathLike | None = None) -> Path:
    """A study file: a path, or the name of one in ``catalog/studies/`` (``verification``)."""
    p = Path(name)
    if p.suffix == ".toml" or p.exists():
        return p
    found = catalog_dir(catalog) / "studies" / f"{name}.toml"
    if not found.is_file():
        known = sorted(f.stem for f in (catalog_dir(catalog) / "studies").glob("*.toml"))
        raise MissingFileError(f"study {str(name)!r} is neither a file nor a catalog study "
                               f"(catalog studies: {', '.join(known)})")
    return found


def load_study(path: str | os.PathLike, catalog: str | os.PathLike | None = None) -> Study:
    """Read and validate a study file (before any computation).

    Parameters
    ----------
    path : str or path
        A study TOML file, or the name of a catalog study (``paper-single-storey``).
    catalog : str or path, optional
        Catalog folder; default: the ``catalog`` key of the study file (relative to the file),
        else the source checkout's ``catalog/``.

    Raises
    ------
    CatalogError
        Naming the file, the key and the line: unknown ids or keys, empty dimensions, bad
        values (those the kernel would refuse included), a range of too many values, an own
        item with a catalog id and no ``override = true``, a wall with its own supports on
        listed diaphragms, a missing record file, a ``[study.<kind>]`` table no registered
        kind reads or that its kind refuses.
    """
    from .study import kinds

    src = _Source(study_path(path, catalog))
    s = _study_table(src, kinds.tables())
    if catalog is None and "catalog" in s:
        catalog = (src.path.parent / s["catalog"]).resolve()
    cat = _study_catalog(src, catalog)
    for k in ("walls", "diaphragms", "records", "cor"):
        if k not in s:
            raise src.error(f"study.{k}", "missing", "study")
    supports = s.get("supports", "top")
    if supports not in SUPPORTS:
        raise src.error("study.supports", f"{supports!r} is not one of {SUPPORTS}", "supports")
    wall_ids = (cat.parametric_walls if s["walls"] == "parametric"
                else _values(src, "study.walls", s["walls"], str))
    walls = _study_walls(src, cat, wall_ids, supports)
    diaphragms, own_supports = _study_diaphragms(src, cat, s["diaphragms"], supports)
    own, groups = _own_records(src)
    records = _record_ids(src, "study.records", s["records"], groups)
    _unused_records(src, groups, records)
    cor = _values(src, "study.cor", s["cor"], float)
    for c in cor:
        if not 0.0 < c <= 1.0:
            raise src.error("study.cor", f"{c!r} must lie in (0, 1] (the kernel refuses a "
                            "coefficient of restitution of 0)", "cor")
    extra, impact = _added_dimensions(src, s)
    tail = s.get("tail", 0.0)
    if not _number(tail) or tail < 0:
        raise src.error("study.tail", f"{tail!r} must be a finite duration >= 0 [s]", "tail")
    t_rest = s.get("t_rest", T_REST)
    if not _number(t_rest) or not t_rest > 0:
        raise src.error("study.t_rest", f"{t_rest!r} must be a finite time > 0 [s] (v_rest = "
                        "g_open/t_rest)", "t_rest")
    study = Study(name=s.get("name", src.path.stem), title=s.get("title", s.get("name", "")),
                  path=src.path, text=src.text, catalog=cat, walls=walls,
                  diaphragms=diaphragms, supports=supports, records=records, cor=cor,
                  extra=extra, impact=impact, tail=float(tail), t_rest=float(t_rest),
                  scale_factor=_scale_factors(src, s, records, own, groups),
                  pairs=_pairs(src, s, wall_ids, records, groups), own_supports=own_supports,
                  tables={k: s[k] for k in kinds.tables() if k in s},
                  own_records={r: own[r] for r in records if r in own}, _src=src)
    study.histories = _histories(src, study, s.get("history", []), groups)
    _check_cells(src, study)
    study.kind, study.settings = kinds.prepare(study)
    return study


def _study_table(src: _Source, tables: tuple[str, ...]) -> dict:
    """The ``[study]`` table, its keys and the file's tables checked (a registered kind's
    table may sit in it)."""
    data = src.data
    s = data.get("study")
    if not isinstance(s, dict):
        raise src.error("study", "missing [study] table")
    src.check_keys("study", s, (*STUDY_KEYS, *tables), "study")
    for k in data:
        if k not in ("study", "walls", "diaphragms", "records"):
            raise src.error(k, "unknown table (known: study, walls, diaphragms, records)", k)
        if not isinstance(data[k], dict):
            raise src.error(k, "must be a table", k)
    return s


def _override(src: _Source, key: str, t: dict, catalog_ids: Any, what: str) -> None:
    """An own item (`key`) whose id is a catalog id needs ``override = true``; an
    ``override`` of an id the catalog lacks is refused too."""
    ident = key.split(".", 1)[1]
    override = t.get("override", False)
    if not isinstance(override, bool):
        raise src.error(f"{key}.override", f"{override!r} must be true or false", key,
                        "override")
    if ident in catalog_ids and not override:
        raise src.error(key, f"{ident!r} is already a {what} of the catalog: choose another "
                        f"id, or set override = true in [{key}] to replace the catalog's "
                        f"{what} in this study", key)
    if override and ident not in catalog_ids:
        raise src.error(f"{key}.override", f"the catalog has no {what} {ident!r} to "
                        "override: remove override = true", key, "override")


def _study_catalog(src: _Source, catalog: str | os.PathLike | None) -> Catalog:
    """The catalog, extended by the study file's own walls and diaphragms."""
    cat = load_catalog(catalog)
    wall_keys = STUDY_FILE_KEYS["[walls.<id>]"]
    for ident, t in src.data.get("walls", {}).items():
        key = f"walls.{ident}"
        if isinstance(t, dict):
            _override(src, key, t, cat.walls, "wall")
        cat.walls[ident] = _wall_spec(src, ident, t, key=key, known=wall_keys)
    for ident, t in src.data.get("diaphragms", {}).items():
        key = f"diaphragms.{ident}"
        if isinstance(t, dict):
            _override(src, key, t, cat.diaphragms, "diaphragm")
        cat.diaphragms[ident] = _diaphragm_from_table(src, key, ident, t,
                                                      STUDY_FILE_KEYS["[diaphragms.<id>]"])
    return cat


def _study_walls(src: _Source, cat: Catalog, wall_ids: list[str], supports: str
                 ) -> list[WallSpec]:
    """The study's walls; a wall that states its own supports runs on ``specimen`` only."""
    walls = []
    for w in wall_ids:
        if w not in cat.walls:
            raise src.error("study.walls", f"unknown wall id {w!r} (known: "
                            f"{', '.join(cat.walls)})", "walls", w)
        spec = cat.walls[w]
        if spec.own_supports and supports != SPECIMEN:
            raise src.error("study.walls", f"wall {w!r} states its own supports "
                            f"({', '.join(spec.own_supports)}): it keeps them only in a study "
                            'with supports = "specimen" and diaphragms = ["specimen"]; to put '
                            "it on the listed diaphragms, leave those keys out of its table",
                            "walls", w)
        walls.append(spec)
    return walls


def _study_diaphragms(src: _Source, cat: Catalog, value: Any, supports: str
                      ) -> tuple[list[Diaphragm], dict[str, str]]:
    """The study's diaphragms, and the supports of those given their own (``"D1/both"``)."""
    own_supports: dict[str, str] = {}
    if supports == SPECIMEN:
        d_ids = _values(src, "study.diaphragms", value, str)
        if d_ids != [SPECIMEN]:
            raise src.error("study.diaphragms", 'supports = "specimen" takes diaphragms = '
                            '["specimen"] (each wall on its own supports)', "diaphragms")
        return [Diaphragm(SPECIMEN, stiffness=math.nan, damping=math.nan,
                          description="the test wall's own supports (Table II)")], own_supports
    diaphragms = []
    for label in _values(src, "study.diaphragms", value, str):
        d, _, own = label.partition("/")
        if d not in cat.diaphragms:
            hint = (' (the walls\' own supports: supports = "specimen")' if d == SPECIMEN
                    else "")
            raise src.error("study.diaphragms", f"unknown diaphragm id {d!r} (known: "
                            f"{', '.join(cat.diaphragms)}){hint}", "diaphragms", label)
        if own and own not in ("top", "both"):
            raise src.error("study.diaphragms", f"{label!r}: the supports after '/' must "
                            'be "top" or "both"', "diaphragms", label)
        if own:
            own_supports[label] = own
            diaphragms.append(dataclasses.replace(cat.diaphragms[d], id=label))
        else:
            diaphragms.append(cat.diaphragms[d])
    return diaphragms, own_supports


# ---- a study's own record files ([records.<id>]) ------------------------------------------

def _own_records(src: _Source) -> tuple[dict[str, OwnRecord], dict[str, list[str]]]:
    """(the study file's own records by id, the record ids of each ``[records.<id>]``
    table: its own id for a file, one id per file for a folder)."""
    own: dict[str, OwnRecord] = {}
    groups: dict[str, list[str]] = {}
    for table, t in src.data.get("records", {}).items():
        key = f"records.{table}"
        if not isinstance(t, dict):
            raise src.error(key, "must be a table (file = ... or folder = ...)", key)
        src.check_keys(key, t, RECORD_KEYS, key)
        options = _record_options(src, key, t)
        if ("file" in t) == ("folder" in t):
            raise src.error(key, "needs exactly one of file = \"...\" (one record) and "
                            "folder = \"...\" (one record per file)", key)
        files = _record_files(src, key, table, t)
        for rid, (path, name) in files.items():
            if rid in own:
                raise src.error(key, f"record id {rid!r} is made twice (also by "
                                f"[records.{own[rid].table}])", key)
            own[rid] = OwnRecord(rid, path, name, table, **options)
        groups[table] = list(files)
    return own, groups


def _record_options(src: _Source, key: str, t: dict) -> dict[str, Any]:
    """The reading options of a ``[records.<id>]`` table, checked."""
    from .records.readers import UNIT_FACTORS

    out: dict[str, Any] = {}
    for k in ("channel", "format", "unit", "sha256", "pattern", "file", "folder"):
        if k in t and not isinstance(t[k], str):
            raise src.error(f"{key}.{k}", f"{t[k]!r} must be a string", key, k)
    for k in ("allow_unusual", "override"):
        if k in t and not isinstance(t[k], bool):
            raise src.error(f"{key}.{k}", f"{t[k]!r} must be true or false", key, k)
    for k in ("dt", "scale"):
        if k in t and (not _number(t[k]) or t[k] <= 0):
            unit = "[s]" if k == "dt" else "[1]"
            raise src.error(f"{key}.{k}", f"{t[k]!r} must be a positive, finite number "
                            f"{unit}", key, k)
    if "unit" in t and t["unit"] not in UNIT_FACTORS:
        raise src.error(f"{key}.unit", f"{t['unit']!r} is not one of {sorted(UNIT_FACTORS)}",
                        key, "unit")
    if "sha256" in t:
        if "folder" in t:
            raise src.error(f"{key}.sha256", "pins one file: give it in a [records.<id>] "
                            "table with file = ...", key, "sha256")
        if not re.fullmatch(r"[0-9a-fA-F]{64}", t["sha256"]):
            raise src.error(f"{key}.sha256", f"{t['sha256']!r} is not a SHA-256 (64 hex "
                            "digits)", key, "sha256")
    if "pattern" in t and "folder" not in t:
        raise src.error(f"{key}.pattern", "is for a folder = ... table", key, "pattern")
    for k in ("channel", "dt", "unit", "format", "allow_unusual", "override"):
        if k in t:
            out[k] = t[k]
    if "scale" in t:
        out["scale"] = float(t["scale"])
    if "sha256" in t:
        out["sha256"] = t["sha256"].lower()
    return out


def _record_files(src: _Source, key: str, table: str, t: dict) -> dict[str, tuple[Path, str]]:
    """Record id -> (absolute file, the name the study gives it) of a ``[records.<id>]``
    table: its file, or each file of its folder matching ``pattern`` (``*`` by default;
    hidden files and ``manifest.toml`` left out), as ``<id>/<file stem>``, in name order."""
    base = src.path.parent
    if "file" in t:
        path = base / t["file"]
        if not path.is_file():
            raise src.error(f"{key}.file", f"{str(path)!r} does not exist (a file is named "
                            "relative to the study file's folder)", key, "file")
        return {table: (path.absolute(), t["file"])}
    folder = base / t["folder"]
    if not folder.is_dir():
        raise src.error(f"{key}.folder", f"{str(folder)!r} is not a folder (named relative "
                        "to the study file's folder)", key, "folder")
    pattern = t.get("pattern", "*")
    files = sorted(p for p in folder.glob(pattern) if p.is_file()
                   and not p.name.startswith(".") and p.name != "manifest.toml")
    if not files:
        raise src.error(key, f"no file of {str(folder)!r} matches pattern {pattern!r}", key)
    out: dict[str, tuple[Path, str]] = {}
    for f in files:
        rid = f"{table}/{nfc(f.stem)}"
        if rid in out:
            raise src.error(key, f"{out[rid][1]!r} and {f.name!r} both make record id "
                            f"{rid!r} (one id per file stem): narrow the pattern", key)
        rel = f.relative_to(folder).as_posix()
        out[rid] = (f.absolute(), f"{Path(t['folder']).as_posix()}/{rel}")
    return out


def _record_ids(src: _Source, key: str, value: Any, groups: dict[str, list[str]]
                ) -> list[str]:
    """Record ids of `key`: the id of a ``[records.<id>]`` table stands for each of its
    records (every file of a folder)."""
    ids: list[str] = []
    for r in _values(src, key, value, str):
        for rid in groups.get(r, [r]):
            if rid in ids:
                raise src.error(key, f"record {rid!r} is named twice", key.split(".")[-1], r)
            ids.append(rid)
    return ids


def _unused_records(src: _Source, groups: dict[str, list[str]], records: list[str]) -> None:
    """A ``[records.<id>]`` table none of whose records the study runs is refused."""
    for table, ids in groups.items():
        if not any(r in records for r in ids):
            raise src.error(f"records.{table}", f"declared but study.records does not name "
                            f"{table!r}: add it to study.records, or remove the table",
                            f"records.{table}")


def _added_dimensions(src: _Source, s: dict) -> tuple[dict[str, list], str]:
    """(the added dimensions scale, impact, damping the study gives, in `DIMS` order; the
    impact law when one is given as a single value)."""
    extra: dict[str, list] = {}
    impact = "scale"
    if "impact" in s:
        laws = _values(src, "study.impact", s["impact"], str)
        for law in laws:
            if law not in IMPACT_LAWS:
                raise src.error("study.impact", f"{law!r} is not one of {IMPACT_LAWS}", "impact")
        if isinstance(s["impact"], list):
            extra["impact"] = laws
        else:
            impact = laws[0]
    if "scale" in s:
        vals = _values(src, "study.scale", s["scale"], float)
        if any(v <= 0 for v in vals):
            bad = next(v for v in vals if v <= 0)
            raise src.error("study.scale", f"{bad!r}: a scale must be positive (0 analyses "
                            "no motion, a negative one the record turned over)", "scale")
        extra["scale"] = vals
    if "damping" in s:
        vals = _values(src, "study.damping", s["damping"], float)
        if any(v < 0 for v in vals):
            raise src.error("study.damping", "values must not be negative", "damping")
        problem = next(filter(None, (damping_ratio_problem("damping", v) for v in vals)), None)
        if problem:
            raise src.error("study.damping", problem, "damping")
        extra["damping"] = vals
    return {k: extra[k] for k in DIMS if k in extra}, impact


def _scale_factors(src: _Source, s: dict, records: list[str], own: dict[str, OwnRecord],
                   groups: dict[str, list[str]]) -> dict[str, float]:
    table = s.get("scale_factor", {})
    if not isinstance(table, dict):
        raise src.error("study.scale_factor", "must be a table of record id = factor",
                        "scale_factor")
    scale_factor = {}
    for r, f in table.items():
        key = f"study.scale_factor.{r}"
        if not _number(f) or f <= 0:
            raise src.error(key, f"{f!r} must be a positive, finite number", "scale_factor", r)
        for rid in groups.get(r, [r]):
            if rid not in records:
                raise src.error(key, "names a record the study does not list",
                                "scale_factor", r)
            if rid in own and own[rid].scale is not None:
                raise src.error(key, f"record {rid!r} has its scale in [records."
                                f"{own[rid].table}] already: give it in one place",
                                "scale_factor", r)
            scale_factor[rid] = float(f)
    return scale_factor


def _pairs(src: _Source, s: dict, wall_ids: list[str], records: list[str],
           groups: dict[str, list[str]]) -> dict[str, list[str]] | None:
    if "pairs" not in s:
        return None
    if not isinstance(s["pairs"], dict):
        raise src.error("study.pairs", "must be a table of wall id = [record ids]", "pairs")
    pairs = {}
    for w, rs in s["pairs"].items():
        if w not in wall_ids:
            raise src.error(f"study.pairs.{w}", "names a wall the study does not list",
                            "pairs", w)
        rs = _record_ids(src, f"study.pairs.{w}", rs, groups)
        for r in rs:
            if r not in records:
                raise src.error(f"study.pairs.{w}", f"record {r!r} is not in study.records",
                                "pairs", w)
        pairs[w] = rs
    return pairs


def _check_cells(src: _Source, study: Study) -> None:
    """Every cell's Wall must be valid: build them now, before any computation."""
    for spec in study.walls:
        for d in study.diaphragms:
            for z in study.extra.get("damping", [None]):
                try:
                    study.wall(spec, d, z)
                except ValueError as exc:
                    raise src.error("study", f"wall {spec.id!r} on diaphragm {d.id!r}: {exc}",
                                    "walls") from None


def _histories(src: _Source, study: Study, entries: Any, groups: dict[str, list[str]]
               ) -> list[History]:
    if isinstance(entries, dict):
        entries = [entries]
    if not isinstance(entries, list):
        raise src.error("study.history", "must be [[study.history]] tables", "history")
    out: list[History] = []
    dims = study.dims
    known = STUDY_FILE_KEYS["[[study.history]]"]
    for i, e in enumerate(entries):
        key = f"study.history[{i}]"
        if not isinstance(e, dict):
            raise src.error(key, "must be a table (wall, diaphragm, record, cor)", "history")
        src.check_keys(key, e, known, *(["study.history"] * (i + 1)))
        sel = {}
        for dim in known:
            v = e.get(dim, dims[dim])
            v = v if isinstance(v, list) else [v]
            v = [nfc(x) if isinstance(x, str) else x for x in v]
            if dim == "record":
                v = [rid for x in v for rid in groups.get(x, [x])]
            for x in v:
                if x not in dims[dim]:
                    raise src.error(f"{key}.{dim}", f"{x!r} is not in the study's {dim} "
                                    "dimension", "history", dim)
            sel[dim] = v
        for w in sel["wall"]:
            for d in sel["diaphragm"]:
                for r in sel["record"]:
                    for c in sel["cor"]:
                        h = History(w, d, r, float(c))
                        if study.paired(w, r) and h not in out:
                            out.append(h)
    return out
