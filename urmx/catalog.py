"""The catalog: walls, diaphragms, the parametric building and study files (``catalog/*.toml``).

Data lives in the top-level ``catalog/`` folder, never in code:

- ``walls.toml``: the Table II test walls with their own supports and PMR;
- ``diaphragms.toml``: D1-D5 of Table IV (D5 the paper's 1e9 N/m spring) and ``D5-pinned``
  (a pinned top, ``rigid``);
- ``building.toml``: the parametric building (plan, density, diaphragm weight, wall length)
  and the parametric wall family (230 mm, slenderness 8-24, crack at 2/3, PMR 75);
- ``studies/*.toml``: study grids (`load_study`);
- ``paper.toml``: the paper's own numbers (read by :mod:`urmx.paper`, which also fits the
  building to them).

A study file may also define its own walls (``[walls.<id>]``) and diaphragms
(``[diaphragms.<id>]``) beside ``[study]``; they extend the catalog. A diaphragm entry
``"D1/both"`` (or ``"D1/top"``) gives the cells on it their own supports, so that one study
holds single- and higher-storey walls. A ``[study.<kind>]`` table names the study's kind
and holds its settings: the catalog keeps it as data (``Study.tables``), refuses a table no
registered kind reads, and has the kind parse it (`urmx.study.kinds`); a study without one
is the default kind. Every error names the file, the key and (where it can be found) the
line.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .config import data_dir
from .errors import MissingFileError, UrmxError
from .model import PAPER_G, RIGID, Wall

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

EFFECTIVE_MASS = 8.0 / 15.0  # Eq. 7: effective over nominal mass of walls and diaphragms
SPECIMEN = "specimen"  # the diaphragm id meaning "the wall's own supports" (test walls)
SUPPORTS = ("top", "both", SPECIMEN)
IMPACT_LAWS = ("scale", "contact")
WALL_FIELDS = ("thickness", "height", "crack_ratio", "mass", "bottom_mass", "top_mass",
               "bottom_stiffness", "top_stiffness", "bottom_damping", "top_damping", "pmr",
               "kappa")
# dimensions of a study's grid, in order; the last three are optional (study keys)
DIMS = ("wall", "diaphragm", "record", "cor", "scale", "impact", "damping")


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
    for name in ("bottom_damping", "top_damping"):
        problem = damping_ratio_problem(name, table.get(name))
        if problem:
            return problem
    return None


def catalog_dir(path: str | os.PathLike | None = None) -> Path:
    """The catalog folder: `path`, else ``catalog/`` of the source checkout, or the copy an
    installed wheel carries (`urmx.config.data_dir`)."""
    return Path(path) if path is not None else data_dir("catalog")


# ---- locating keys in TOML text for error messages -------------------------------------

class _Source:
    """A parsed TOML file that can point at the line of a key or value."""

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
            self.data = tomllib.loads(self.text)
        except tomllib.TOMLDecodeError as exc:
            raise CatalogError(f"{self.path}: not valid TOML: {exc}") from None

    def line(self, *needles: str) -> int | None:
        """First line holding the last needle after the lines holding the earlier ones."""
        lines = self.text.splitlines()
        start = 0
        found = None
        for needle in needles:
            pat = re.compile(r"(^|[^\w-])" + re.escape(str(needle)) + r"($|[^\w-])")
            for i in range(start, len(lines)):
                code = lines[i].split("#", 1)[0]
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
    diaphragm); test walls carry their own supports (diaphragm ``specimen``).
    """

    id: str
    wall: Wall
    name: str = ""
    source: str = ""
    records: tuple[str, ...] = ()
    parametric: bool = False

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
        return EFFECTIVE_MASS * 2.0 * self.density * thickness * height * self.wall_length

    @property
    def diaphragm_mass(self) -> float:
        """Effective diaphragm mass, Eq. 7: 8/15 of its seismic weight over g. [kg]"""
        return EFFECTIVE_MASS * self.diaphragm_weight * 1e3 * self.plan_area / PAPER_G

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


def _wall_from_table(src: _Source, key: str, table: dict, **extra: Any) -> Wall:
    """The `Wall` of a TOML table of wall fields (`extra` fields added); ``key`` is the
    table's dotted key ("" at the top level). The one TOML-to-Wall loader: catalog walls,
    study walls and wall files (:func:`read_wall`)."""
    where = (key.split(".")[-1],) if key else ()
    unknown = set(table) - set(WALL_FIELDS) - {"name", "source", "records"}
    if unknown:
        name = sorted(unknown)[0]
        raise src.error(f"{key}.{name}".lstrip("."), f"unknown wall key {name!r} (known: "
                        f"{', '.join(WALL_FIELDS)})", *where, name)
    values = {k: table[k] for k in WALL_FIELDS if k in table}
    values.update(extra)
    problem = damping_problem(values)
    if problem:
        bad = problem.split("=", 1)[0]
        raise src.error(f"{key}.{bad}".lstrip("."), problem, *where, bad)
    try:
        return Wall(**values)
    except (TypeError, ValueError) as exc:
        bad = next((k for k in WALL_FIELDS if k in str(exc)), None)
        message = str(exc).replace("Wall.__init__()", "wall")
        raise src.error(f"{key}.{bad}".lstrip(".") if bad else key or "wall", message,
                        *where, *([bad] if bad else [])) from None


def read_wall(path: str | os.PathLike) -> Wall:
    """A `Wall` from a TOML file: its fields in a ``[wall]`` table or at the top level
    (``name``, ``source`` and ``records`` may sit beside them, as in ``walls.toml``).

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


def _diaphragm_from_table(src: _Source, key: str, ident: str, t: dict) -> Diaphragm:
    if "stiffness" not in t:
        raise src.error(f"{key}.stiffness", "missing", ident)
    k = t["stiffness"]
    if isinstance(k, str):
        if k.strip().lower() != RIGID:
            raise src.error(f"{key}.stiffness", f'{k!r} is not a number or "rigid"', ident,
                            "stiffness")
        k = RIGID
    elif isinstance(k, bool) or not isinstance(k, (int, float)) or not math.isfinite(k) \
            or k <= 0:
        raise src.error(f"{key}.stiffness", f"{k!r} must be a positive number [N m-1] or "
                        '"rigid"', ident, "stiffness")
    damping = t.get("damping", 0.12)
    if isinstance(damping, bool) or not isinstance(damping, (int, float)) or damping < 0:
        raise src.error(f"{key}.damping", f"{damping!r} must be a ratio >= 0", ident, "damping")
    problem = damping_ratio_problem("damping", damping)
    if problem:
        raise src.error(f"{key}.damping", problem, ident, "damping")
    return Diaphragm(id=ident, stiffness=k if k == RIGID else float(k), damping=float(damping),
                     description=t.get("description", ""), direction=t.get("direction", ""))


def parametric_wall_id(slenderness: float) -> str:
    """Id of a parametric wall: ``s`` + the slenderness on two digits (``s18``)."""
    return f"s{int(round(slenderness)):02d}"


def load_catalog(path: str | os.PathLike | None = None) -> Catalog:
    """Load ``walls.toml``, ``diaphragms.toml`` and ``building.toml`` of a catalog folder."""
    root = catalog_dir(path)
    bsrc = _Source(root / "building.toml")
    b = bsrc.data.get("building", {})
    try:
        building = Building(plan=tuple(float(x) for x in b["plan"]), density=float(b["density"]),
                            wall_length=float(b["wall_length"]),
                            diaphragm_weight=float(b["diaphragm_weight"]))
    except KeyError as exc:
        raise bsrc.error(f"building.{exc.args[0]}", "missing", "building") from None
    walls: dict[str, WallSpec] = {}
    pw = bsrc.data.get("parametric_walls", {})
    for s in pw.get("slenderness", []):
        t = float(pw["thickness"])
        h = round(s * t, 10)
        ident = parametric_wall_id(s)
        wall = _wall_from_table(bsrc, "parametric_walls", {}, thickness=t, height=h,
                                crack_ratio=float(pw["crack_ratio"]), pmr=float(pw["pmr"]),
                                mass=building.wall_mass(t, h))
        walls[ident] = WallSpec(ident, wall, name=f"slenderness {s:g}",
                                source="paper Section 6 (parametric)", parametric=True)
    wsrc = _Source(root / "walls.toml")
    for ident, t in wsrc.data.items():
        walls[ident] = _wall_spec(wsrc, ident, t)
    dsrc = _Source(root / "diaphragms.toml")
    diaphragms = {ident: _diaphragm_from_table(dsrc, ident, ident, t)
                  for ident, t in dsrc.data.items()}
    return Catalog(walls, diaphragms, building, dict(bsrc.data.get("calibration", {})), root)


def _wall_spec(src: _Source, ident: str, t: dict, key: str | None = None) -> WallSpec:
    key = key or ident
    if not isinstance(t, dict):
        raise src.error(key, "must be a table of wall fields", ident)
    wall = _wall_from_table(src, key, t)
    return WallSpec(ident, wall, name=t.get("name", ident), source=t.get("source", str(src.path)),
                    records=tuple(t.get("records", ())))


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


@dataclass
class Study:
    """A study grid read from a TOML file (`load_study`).

    ``dims`` maps every grid dimension (``wall``, ``diaphragm``, ``record``, ``cor`` and any
    of ``scale``, ``impact``, ``damping`` the file adds) to its values, in `DIMS` order.
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
    scale_factor: dict[str, float] = field(default_factory=dict)
    pairs: dict[str, list[str]] | None = None
    histories: list[History] = field(default_factory=list)
    own_supports: dict[str, str] = field(default_factory=dict)  # diaphragm label -> supports
    tables: dict[str, Any] = field(default_factory=dict)  # [study.<kind>] tables, as data
    kind: str = "grid"  # the study kind (urmx.study.kinds) its tables make it
    settings: Any = None  # the kind's settings, parsed from its table
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

        ``damping`` (the study's ``damping`` dimension) replaces the damping ratio of every
        flexible support.
        """
        supports = self.supports_of(diaphragm)
        if supports == SPECIMEN:
            w = spec.wall
            if damping is not None:
                w = w.replace(bottom_damping=0.0 if w.bottom_rigid else damping,
                              top_damping=0.0 if w.top_rigid else damping)
            return w
        md = self.catalog.building.diaphragm_mass
        zeta = diaphragm.damping if damping is None else damping
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


def _values(src: _Source, key: str, value: Any, kind: type) -> list:
    """A dimension's values: a list, a scalar, or {start, stop, step} (stop included)."""
    if isinstance(value, dict):
        try:
            start, stop, step = (float(value[k]) for k in ("start", "stop", "step"))
        except KeyError as exc:
            raise src.error(key, f"range needs start, stop and step (missing {exc.args[0]})",
                            key.split(".")[-1]) from None
        if step <= 0:
            raise src.error(key, "range step must be positive", key.split(".")[-1])
        n = int(math.floor((stop - start) / step + 1e-9)) + 1
        decimals = max(0, -int(math.floor(math.log10(step))) + 3)
        values = [round(start + i * step, decimals) for i in range(max(n, 0))]
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
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise src.error(key, f"{v!r} is not a number", key.split(".")[-1])
            out.append(float(v))
        else:
            if not isinstance(v, str):
                raise src.error(key, f"{v!r} is not a string id", key.split(".")[-1])
            out.append(v)
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


#: keys of the ``[study]`` table itself (a registered kind's table may sit beside them)
STUDY_KEYS = ("name", "title", "description", "walls", "diaphragms", "supports", "records",
              "cor", "scale", "impact", "damping", "tail", "scale_factor", "pairs", "history",
              "catalog")


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
        Naming the file, the key and the line: unknown ids, empty dimensions, bad values,
        a ``[study.<kind>]`` table no registered kind reads or that its kind refuses.
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
    walls = _study_walls(src, cat, wall_ids)
    diaphragms, own_supports = _study_diaphragms(src, cat, s["diaphragms"], supports)
    records = _values(src, "study.records", s["records"], str)
    cor = _values(src, "study.cor", s["cor"], float)
    for c in cor:
        if not 0.0 <= c <= 1.0:
            raise src.error("study.cor", f"{c!r} must lie in [0, 1]", "cor")
    extra, impact = _added_dimensions(src, s)
    tail = s.get("tail", 0.0)
    if isinstance(tail, bool) or not isinstance(tail, (int, float)) or tail < 0:
        raise src.error("study.tail", f"{tail!r} must be a duration >= 0 [s]", "tail")
    study = Study(name=s.get("name", src.path.stem), title=s.get("title", s.get("name", "")),
                  path=src.path, text=src.text, catalog=cat, walls=walls,
                  diaphragms=diaphragms, supports=supports, records=records, cor=cor,
                  extra=extra, impact=impact, tail=float(tail),
                  scale_factor=_scale_factors(src, s, records),
                  pairs=_pairs(src, s, wall_ids, records), own_supports=own_supports,
                  tables={k: s[k] for k in kinds.tables() if k in s}, _src=src)
    study.histories = _histories(src, study, s.get("history", []))
    study.kind, study.settings = kinds.prepare(study)
    _check_cells(src, study)
    return study


def _study_table(src: _Source, tables: tuple[str, ...]) -> dict:
    """The ``[study]`` table, its keys and the file's tables checked (a registered kind's
    table may sit in it)."""
    data = src.data
    s = data.get("study")
    if not isinstance(s, dict):
        raise src.error("study", "missing [study] table")
    known = {*STUDY_KEYS, *tables}
    for k in s:
        if k not in known:
            raise src.error(f"study.{k}", f"unknown key (known: {', '.join(sorted(known))})", k)
    for k in data:
        if k not in ("study", "walls", "diaphragms"):
            raise src.error(k, "unknown table (known: study, walls, diaphragms)", k)
    return s


def _study_catalog(src: _Source, catalog: str | os.PathLike | None) -> Catalog:
    """The catalog, extended by the study file's own walls and diaphragms."""
    cat = load_catalog(catalog)
    for ident, t in src.data.get("walls", {}).items():
        cat.walls[ident] = _wall_spec(src, ident, t, key=f"walls.{ident}")
    for ident, t in src.data.get("diaphragms", {}).items():
        cat.diaphragms[ident] = _diaphragm_from_table(src, f"diaphragms.{ident}", ident, t)
    return cat


def _study_walls(src: _Source, cat: Catalog, wall_ids: list[str]) -> list[WallSpec]:
    walls = []
    for w in wall_ids:
        if w not in cat.walls:
            raise src.error("study.walls", f"unknown wall id {w!r} (known: "
                            f"{', '.join(cat.walls)})", "walls", w)
        walls.append(cat.walls[w])
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
            raise src.error("study.diaphragms", f"unknown diaphragm id {d!r} (known: "
                            f"{', '.join(cat.diaphragms)})", "diaphragms", label)
        if own and own not in ("top", "both"):
            raise src.error("study.diaphragms", f"{label!r}: the supports after '/' must "
                            'be "top" or "both"', "diaphragms", label)
        if own:
            own_supports[label] = own
            diaphragms.append(dataclasses.replace(cat.diaphragms[d], id=label))
        else:
            diaphragms.append(cat.diaphragms[d])
    return diaphragms, own_supports


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
    for k in ("scale", "damping"):
        if k in s:
            vals = _values(src, f"study.{k}", s[k], float)
            if any(v < 0 for v in vals):
                raise src.error(f"study.{k}", "values must not be negative", k)
            if k == "damping":
                problem = next(filter(None, (damping_ratio_problem("damping", v)
                                             for v in vals)), None)
                if problem:
                    raise src.error("study.damping", problem, "damping")
            extra[k] = vals
    return {k: extra[k] for k in DIMS if k in extra}, impact


def _scale_factors(src: _Source, s: dict, records: list[str]) -> dict[str, float]:
    scale_factor = {}
    for r, f in s.get("scale_factor", {}).items():
        if r not in records:
            raise src.error(f"study.scale_factor.{r}", "names a record the study does not "
                            "list", "scale_factor", r)
        if isinstance(f, bool) or not isinstance(f, (int, float)) or f <= 0:
            raise src.error(f"study.scale_factor.{r}", f"{f!r} must be a positive number",
                            "scale_factor", r)
        scale_factor[r] = float(f)
    return scale_factor


def _pairs(src: _Source, s: dict, wall_ids: list[str], records: list[str]
           ) -> dict[str, list[str]] | None:
    if "pairs" not in s:
        return None
    pairs = {}
    for w, rs in s["pairs"].items():
        if w not in wall_ids:
            raise src.error(f"study.pairs.{w}", "names a wall the study does not list",
                            "pairs", w)
        rs = _values(src, f"study.pairs.{w}", rs, str)
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


def _histories(src: _Source, study: Study, entries: list) -> list[History]:
    if isinstance(entries, dict):
        entries = [entries]
    out: list[History] = []
    dims = study.dims
    for i, e in enumerate(entries):
        key = f"study.history[{i}]"
        sel = {}
        for dim in ("wall", "diaphragm", "record", "cor"):
            v = e.get(dim, dims[dim])
            v = v if isinstance(v, list) else [v]
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
