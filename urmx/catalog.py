"""The catalog: walls, diaphragms, the parametric building (``catalog/*.toml``), read and
checked before any computation, and what reading a study file needs of it (a TOML source
that locates keys for error messages, a dimension's values, an item table of a study file);
the study file itself is parsed by `urmx.study.file`.

Data lives in the top-level ``catalog/`` folder, never in code:

- ``walls.toml``: the Table II test walls with their own supports and PMR;
- ``diaphragms.toml``: D1-D5 of Table IV (D5 the paper's 1e9 N/m spring) and ``D5-pinned``
  (a pinned top, ``rigid``);
- ``building.toml``: the parametric building (plan, density, diaphragm weight, wall length)
  and the parametric wall family (230 mm, slenderness 8-24, crack at 2/3, PMR 75);
- ``studies/*.toml``: study grids (`urmx.study.file.load_study`);
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
from .errors import InputError, MissingFileError, UrmxError, path_argument
from .model import (
    EFFECTIVE_MASS,
    RIGID,
    Wall,
    effective_diaphragm_mass,
    effective_wall_mass,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["EFFECTIVE_MASS", "CatalogError", "Catalog", "Building", "Diaphragm", "WallSpec",
           "load_catalog", "read_wall", "CATALOG_FILE_KEYS"]

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
#: most values one dimension of a study may hold (a ``{start, stop, step}`` range included;
#: `urmx.study.limits.MAX_VALUES`)
MAX_VALUES = 10**7
# dimensions of a study's grid, in order; the last three are optional (study keys)
DIMS = ("wall", "diaphragm", "record", "cor", "scale", "impact", "damping")

#: every key of the catalog files a study can bring (``[study] catalog = "folder"``)
CATALOG_FILE_KEYS: dict[str, tuple[str, ...]] = {
    "building.toml [building]": ("plan", "density", "wall_length", "diaphragm_weight"),
    "building.toml [parametric_walls]": ("thickness", "crack_ratio", "pmr", "kappa",
                                         "slenderness"),
    "building.toml [calibration]": ("instability_wall", "instability_weight"),
    "walls.toml [<id>]": WALL_KEYS,
    "diaphragms.toml [<id>]": DIAPHRAGM_KEYS,
}
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

class Source:
    """A parsed TOML file that can point at the line of a key or value; its tables' keys
    in NFC (two keys of one table that are the same text in different normal forms are
    refused)."""

    def __init__(self, path: Path, text: str | None = None):
        self.path = Path(path)
        try:
            self.text = self.path.read_text(encoding="utf-8") if text is None else text
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


def _wall_from_table(src: Source, key: str, table: dict, known: tuple[str, ...] = WALL_KEYS,
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


def _checked_wall(src: Source, key: str, values: dict, build, renamed: dict | None = None
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


def _building_wall(src: Source, key: str, t: dict) -> Wall:
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
    ``walls.toml``). `path` may also name a catalog example (``benchmark-wall``;
    `wall_path`).

    Raises
    ------
    urmx.errors.MissingFileError
        No such file (a FileNotFoundError).
    CatalogError
        Not TOML, an unknown key, a missing or bad field: the message names the file, the
        key and (where it can be found) the line.
    """
    path_argument("read_wall", "path", path)
    path = wall_path(path)
    if not path.is_file():
        raise MissingFileError(f"wall file {str(path)!r} does not exist")
    src = Source(path)
    if "wall" not in src.data:
        return _wall_from_table(src, "", src.data)
    extra = [k for k in src.data if k != "wall"]
    if extra:
        raise src.error(extra[0], f"unknown key(s) {', '.join(extra)} beside the [wall] table")
    if not isinstance(src.data["wall"], dict):
        raise src.error("wall", "must be a table of Wall fields")
    return _wall_from_table(src, "wall", src.data["wall"])


def diaphragm_from_table(src: Source, key: str, ident: str, t: dict,
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


def _table(src: Source, name: str, label: str, required: tuple[str, ...] = ()) -> dict:
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


def _building(src: Source) -> Building:
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


def _parametric_walls(src: Source, building: Building) -> dict[str, WallSpec]:
    """The parametric wall family of ``building.toml`` (``[parametric_walls]``)."""
    if "parametric_walls" not in src.data:
        return {}
    pw = _table(src, "parametric_walls", "building.toml [parametric_walls]",
                ("thickness", "crack_ratio", "slenderness"))
    walls = {}
    for s in dimension_values(src, "parametric_walls.slenderness", pw["slenderness"], float):
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
    bsrc = Source(root / "building.toml")
    building = _building(bsrc)
    walls = _parametric_walls(bsrc, building)
    calibration = _table(bsrc, "calibration", "building.toml [calibration]")
    wsrc = Source(root / "walls.toml")
    for ident, t in wsrc.data.items():
        walls[ident] = wall_spec(wsrc, ident, t)
    dsrc = Source(root / "diaphragms.toml")
    diaphragms = {ident: diaphragm_from_table(dsrc, ident, ident, t)
                  for ident, t in dsrc.data.items()}
    return Catalog(walls, diaphragms, building, dict(calibration), root)


def wall_spec(src: Source, ident: str, t: dict, key: str | None = None,
               known: tuple[str, ...] = WALL_KEYS) -> WallSpec:
    key = key or ident
    if not isinstance(t, dict):
        raise src.error(key, "must be a table of wall fields", key)
    wall = _wall_from_table(src, key, t, known)
    own = tuple(k for k in (*SUPPORT_FIELDS, *DIAPHRAGM_TERMS) if k in t)
    return WallSpec(ident, wall, name=t.get("name", ident), source=t.get("source", str(src.path)),
                    records=tuple(t.get("records", ())), own_supports=own)


# ---- a dimension's values ----------------------------------------------------------------

def finite_number(value: Any) -> bool:
    """Whether `value` is a finite number (not a bool)."""
    return not isinstance(value, bool) and isinstance(value, (int, float)) \
        and math.isfinite(value)


def _range(src: Source, key: str, value: dict) -> list[float]:
    """The values of a ``{start, stop, step}`` range (stop included), counted before they
    are made: more than `urmx.study.limits.MAX_VALUES` is refused."""
    needle = key.split(".")[-1]
    src.check_keys(key, value, ("start", "stop", "step"), needle)
    missing = [k for k in ("start", "stop", "step") if k not in value]
    if missing:
        raise src.error(key, f"range needs start, stop and step (missing {missing[0]})",
                        needle)
    bad = next((k for k in ("start", "stop", "step") if not finite_number(value[k])), None)
    if bad:
        raise src.error(key, f"range {bad}={value[bad]!r} is not a finite number", needle)
    start, stop, step = (float(value[k]) for k in ("start", "stop", "step"))
    if step <= 0:
        raise src.error(key, "range step must be positive", needle)
    if start > stop:
        raise src.error(key, f"range start={start:g} is above stop={stop:g}: a range runs "
                        "upwards from start to stop (swap them)", needle)
    count = (stop - start) / step + 1e-9
    if not count < MAX_VALUES:  # inf and NaN too
        raise src.error(key, f"range start={start:g}, stop={stop:g}, step={step:g} makes "
                        f"{count:.3g} values, more than the {MAX_VALUES:,} a dimension may "
                        "hold (urmx.study.limits.MAX_VALUES): is the step in the intended "
                        "unit?", needle)
    n = int(math.floor(count)) + 1
    decimals = max(0, -int(math.floor(math.log10(step))) + 3)
    return [round(start + i * step, decimals) for i in range(max(n, 0))]


def dimension_values(src: Source, key: str, value: Any, kind: type) -> list:
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
            if not finite_number(v):
                raise src.error(key, f"{v!r} is not a finite number", key.split(".")[-1])
            out.append(float(v))
        else:
            if not isinstance(v, str):
                raise src.error(key, f"{v!r} is not a string id", key.split(".")[-1])
            out.append(nfc(v))
    if len(set(out)) != len(out):
        raise src.error(key, "has repeated values", key.split(".")[-1])
    return out


# ---- the catalog by name (``urmx catalog list``, ``urmx catalog copy``, a wall by name) -------

#: what ``urmx catalog copy`` copies: (section, file of an entry), in the order looked up
COPYABLE = (("examples", "examples/{}.toml"), ("studies", "studies/{}.toml"))


def _comment(path: Path) -> str:
    """The first comment line of a TOML file, without its ``#`` (what the file is)."""
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("#"):
            return line.lstrip("#").strip()
        if line.strip():
            break
    return ""


def catalog_entries(path: str | os.PathLike | None = None) -> dict[str, list[tuple[str, str]]]:
    """The catalog by name: ``walls`` (the test walls and the parametric family),
    ``diaphragms``, ``examples`` (wall files, `read_wall` by name) and ``studies`` (study
    files, ``urmx run NAME``), each a list of (name, one line saying what it is).

    Parameters
    ----------
    path : path, optional
        A catalog folder (default: the one urmx carries, `catalog_dir`).
    """
    cat = load_catalog(path)
    root = catalog_dir(path)
    walls = [(k, f"{w.name or k}: h/t {w.slenderness:.3g}"
              + (", parametric (supports from the diaphragm)" if w.parametric else
                 ", on its own supports" if w.own_supports else ""))
             for k, w in cat.walls.items()]
    diaphragms = [(k, (d.description or "") + (" (rigid)" if d.rigid else
                                               f" ({d.stiffness_value:.4g} N/m)"))
                  for k, d in cat.diaphragms.items()]
    files = {section: [(f.stem, _comment(f)) for f in sorted((root / section).glob("*.toml"))]
             for section in ("examples", "studies")}
    return {"walls": walls, "diaphragms": diaphragms, **files}


def catalog_file(name: str, path: str | os.PathLike | None = None) -> Path | None:
    """The catalog's example or study file called `name` (``benchmark-wall``,
    ``verification``), or None."""
    root = catalog_dir(path)
    for _, pattern in COPYABLE:
        found = root / pattern.format(name)
        if found.is_file():
            return found
    return None


def wall_path(name: str | os.PathLike) -> Path:
    """A wall file: a path that exists, else the catalog example of that name
    (``benchmark-wall`` -> ``catalog/examples/benchmark-wall.toml``, also from an
    installed wheel); a missing one is a `MissingFileError` naming the examples."""
    p = Path(name)
    if p.exists():
        return p
    found = catalog_dir() / "examples" / f"{name}.toml"
    if p.suffix != ".toml" and found.is_file():
        return found
    known = sorted(f.stem for f in (catalog_dir() / "examples").glob("*.toml"))
    raise MissingFileError(f"wall file {str(name)!r} does not exist, nor is it a catalog "
                           f"example ({', '.join(known)}; `urmx catalog list`)")


def copy_entry(name: str, dest: str | os.PathLike | None = None) -> Path:
    """Copy the catalog's example or study `name` to edit: into `dest` (a folder, or a
    file name), default ``<name>.toml`` in the current folder; never over an existing
    file. Returns the new file."""
    import shutil

    source = catalog_file(name)
    if source is None:
        known = [n for s in ("examples", "studies") for n, _ in catalog_entries()[s]]
        close = difflib.get_close_matches(name, known, n=3)
        hint = f" (did you mean {', '.join(close)}?)" if close else ""
        raise MissingFileError(f"{name!r} is no example or study of the catalog{hint}; "
                               "`urmx catalog list` lists them")
    target = Path(dest) if dest is not None else Path(source.name)
    if target.is_dir():
        target = target / source.name
    if target.exists():
        raise InputError(f"{str(target)!r} exists: give another DEST (nothing is "
                         "overwritten)")
    shutil.copyfile(source, target)
    return target
