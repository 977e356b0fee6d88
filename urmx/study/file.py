"""A study file -> a `Study`: the ``[study]`` table, the study's own walls, diaphragms and
record files, its added dimensions, pairs and histories, each checked against the catalog
(`urmx.catalog`) before any computation, with file, key and line in every error. A
``[study.<kind>]`` table is kept as data (``Study.tables``) and parsed by its kind
(`urmx.study.kinds`); a table no registered kind reads is refused.

Every key a study file accepts is declared once, in `STUDY_FILE_KEYS` (with each registered
kind's ``keys`` and the catalog's `urmx.catalog.CATALOG_FILE_KEYS`: :func:`file_keys`);
``docs/study-files.md`` documents exactly these (a test holds the two together).
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..catalog import (
    CATALOG_FILE_KEYS,
    DIAPHRAGM_KEYS,
    DIMS,
    IMPACT_LAWS,
    RECORD_KEYS,
    SPECIMEN,
    SUPPORTS,
    WALL_KEYS,
    Catalog,
    CatalogError,
    Diaphragm,
    Source,
    WallSpec,
    catalog_dir,
    damping_ratio_problem,
    diaphragm_from_table,
    dimension_values,
    finite_number,
    load_catalog,
    nfc,
    wall_spec,
)
from ..errors import MissingFileError, path_argument
from ..model import RIGID, T_REST, Wall
from ..records.readers import UNIT_FACTORS
from . import kinds

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
#: the ``[study]`` table's sub-tables (beside a registered kind's ``[study.<kind>]``)
_STUDY_SUBTABLES = ("pairs", "scale_factor", "history")
STUDY_KEYS = (*STUDY_FILE_KEYS["[study]"], *_STUDY_SUBTABLES)  # keys of [study] itself


def file_keys() -> dict[str, tuple[str, ...]]:
    """Every table a study file and a catalog file may hold, with its keys:
    `STUDY_FILE_KEYS`, each built-in kind's ``[study.<kind>]`` with its ``Kind.keys``, and
    `CATALOG_FILE_KEYS` (what ``docs/study-files.md`` must document)."""
    out = dict(STUDY_FILE_KEYS)
    for kind in kinds.BUILT_IN:
        if kind.table:
            out[f"[study.{kind.table}]"] = tuple(kind.keys)
    out.update(CATALOG_FILE_KEYS)
    return out



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
        """Whether the study runs `wall` under `record` (its ``pairs``; all pairs without).

        Parameters
        ----------
        wall : str
            Wall id.
        record : str
            Record id.
        """
        return self.pairs is None or record in self.pairs.get(wall, ())

    def supports_of(self, diaphragm: Diaphragm | str) -> str:
        """Supports of the cells on a diaphragm: its own (a ``"D1/both"`` entry) or the
        study's.

        Parameters
        ----------
        diaphragm : urmx.catalog.Diaphragm or str
            The diaphragm or its label.
        """
        label = diaphragm if isinstance(diaphragm, str) else diaphragm.id
        return self.own_supports.get(label, self.supports)

    def wall(self, spec: WallSpec, diaphragm: Diaphragm, damping: float | None = None) -> Wall:
        """The `Wall` of one cell: a catalog wall on a diaphragm as the study's supports say.

        On ``specimen`` the wall stands on its own supports; a parametric wall on a
        diaphragm is the building's wall (`Building.wall`, `urmx.Wall.in_building`); any
        other wall gets the diaphragm's stiffness and damping with the building's diaphragm
        mass. ``damping`` (the study's ``damping`` dimension) replaces the damping ratio of
        every flexible support.

        Parameters
        ----------
        spec : urmx.catalog.WallSpec
            The catalog wall.
        diaphragm : urmx.catalog.Diaphragm
            The diaphragm of the cell.
        damping : float, optional
            Damping ratio of every flexible support instead of the diaphragm's. [1]
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
        """The error to raise for `key` of the study file: its message with the file and
        the line where one of `needles` is found.

        Parameters
        ----------
        key : str
            The study-file key at fault (``study.cor``, ...).
        message : str
            What is wrong.
        *needles : str
            Texts to find the line by.
        """
        if self._src is None:
            return CatalogError(f"study {self.name}: {key}: {message}")
        return self._src.error(key, message, *needles)


def study_path(name: str | os.PathLike, catalog: str | os.PathLike | None = None) -> Path:
    """A study file: a path, or the name of one in ``catalog/studies/`` (``verification``).

    Parameters
    ----------
    name : str or path-like
        A study file's path, or a catalog study's name.
    catalog : str or path-like, optional
        The catalog folder (default the shipped catalog, `urmx.config.catalog_dir`).
    """
    path_argument("study_path", "name", name)
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
    path_argument("load_study", "path", path)
    return _load_study(Source(study_path(path, catalog)), catalog)


def load_study_text(text: str, path: str | os.PathLike,
                    catalog: str | os.PathLike | None = None) -> Study:
    """`load_study` of a study file's `text` (an archive's ``study`` attribute), read as if
    it were the file `path` (which need not exist): its own files are found relative to
    `path`'s folder and its errors name `path`."""
    return _load_study(Source(Path(path), text=text), catalog)


def _load_study(src: Source, catalog: str | os.PathLike | None) -> Study:
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
                else dimension_values(src, "study.walls", s["walls"], str))
    walls = _study_walls(src, cat, wall_ids, supports)
    diaphragms, own_supports = _study_diaphragms(src, cat, s["diaphragms"], supports)
    own, groups = _own_records(src)
    records = _record_ids(src, "study.records", s["records"], groups)
    _unused_records(src, groups, records)
    cor = dimension_values(src, "study.cor", s["cor"], float)
    for c in cor:
        if not 0.0 < c <= 1.0:
            raise src.error("study.cor", f"{c!r} must lie in (0, 1] (the kernel refuses a "
                            "coefficient of restitution of 0)", "cor")
    extra, impact = _added_dimensions(src, s)
    tail = s.get("tail", 0.0)
    if not finite_number(tail) or tail < 0:
        raise src.error("study.tail", f"{tail!r} must be a finite duration >= 0 [s]", "tail")
    name = _study_name(src, s)
    t_rest = s.get("t_rest", T_REST)
    if not finite_number(t_rest) or not t_rest > 0:
        raise src.error("study.t_rest", f"{t_rest!r} must be a finite time > 0 [s] (v_rest = "
                        "g_open/t_rest)", "t_rest")
    study = Study(name=name, title=s.get("title", s.get("name", "")),
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


def _study_name(src: Source, s: dict) -> str:
    """The study's name (default: the file's stem): a string that is not blank, as archives
    name their study by it (``study_name``)."""
    name = s.get("name", src.path.stem)
    if not isinstance(name, str) or not name.strip():
        raise src.error("study.name", f"{name!r} is not a name (give a word that names the "
                        "study: archives and reports are labelled with it)", "name")
    return name


def _study_table(src: Source, tables: tuple[str, ...]) -> dict:
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


def _override(src: Source, key: str, t: dict, catalog_ids: Any, what: str) -> None:
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


def _study_catalog(src: Source, catalog: str | os.PathLike | None) -> Catalog:
    """The catalog, extended by the study file's own walls and diaphragms."""
    cat = load_catalog(catalog)
    wall_keys = STUDY_FILE_KEYS["[walls.<id>]"]
    for ident, t in src.data.get("walls", {}).items():
        key = f"walls.{ident}"
        if isinstance(t, dict):
            _override(src, key, t, cat.walls, "wall")
        cat.walls[ident] = wall_spec(src, ident, t, key=key, known=wall_keys)
    for ident, t in src.data.get("diaphragms", {}).items():
        key = f"diaphragms.{ident}"
        if isinstance(t, dict):
            _override(src, key, t, cat.diaphragms, "diaphragm")
        cat.diaphragms[ident] = diaphragm_from_table(src, key, ident, t,
                                                      STUDY_FILE_KEYS["[diaphragms.<id>]"])
    return cat


def _study_walls(src: Source, cat: Catalog, wall_ids: list[str], supports: str
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


def _study_diaphragms(src: Source, cat: Catalog, value: Any, supports: str
                      ) -> tuple[list[Diaphragm], dict[str, str]]:
    """The study's diaphragms, and the supports of those given their own (``"D1/both"``)."""
    own_supports: dict[str, str] = {}
    if supports == SPECIMEN:
        d_ids = dimension_values(src, "study.diaphragms", value, str)
        if d_ids != [SPECIMEN]:
            raise src.error("study.diaphragms", 'supports = "specimen" takes diaphragms = '
                            '["specimen"] (each wall on its own supports)', "diaphragms")
        return [Diaphragm(SPECIMEN, stiffness=math.nan, damping=math.nan,
                          description="the test wall's own supports (Table II)")], own_supports
    diaphragms = []
    for label in dimension_values(src, "study.diaphragms", value, str):
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

def _own_records(src: Source) -> tuple[dict[str, OwnRecord], dict[str, list[str]]]:
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


def _record_options(src: Source, key: str, t: dict) -> dict[str, Any]:
    """The reading options of a ``[records.<id>]`` table, checked."""
    out: dict[str, Any] = {}
    for k in ("channel", "format", "unit", "sha256", "pattern", "file", "folder"):
        if k in t and not isinstance(t[k], str):
            raise src.error(f"{key}.{k}", f"{t[k]!r} must be a string", key, k)
    for k in ("allow_unusual", "override"):
        if k in t and not isinstance(t[k], bool):
            raise src.error(f"{key}.{k}", f"{t[k]!r} must be true or false", key, k)
    for k in ("dt", "scale"):
        if k in t and (not finite_number(t[k]) or t[k] <= 0):
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


def _record_files(src: Source, key: str, table: str, t: dict) -> dict[str, tuple[Path, str]]:
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


def _record_ids(src: Source, key: str, value: Any, groups: dict[str, list[str]]
                ) -> list[str]:
    """Record ids of `key`: the id of a ``[records.<id>]`` table stands for each of its
    records (every file of a folder)."""
    ids: list[str] = []
    for r in dimension_values(src, key, value, str):
        for rid in groups.get(r, [r]):
            if rid in ids:
                raise src.error(key, f"record {rid!r} is named twice", key.split(".")[-1], r)
            ids.append(rid)
    return ids


def _unused_records(src: Source, groups: dict[str, list[str]], records: list[str]) -> None:
    """A ``[records.<id>]`` table none of whose records the study runs is refused."""
    for table, ids in groups.items():
        if not any(r in records for r in ids):
            raise src.error(f"records.{table}", f"declared but study.records does not name "
                            f"{table!r}: add it to study.records, or remove the table",
                            f"records.{table}")


def _added_dimensions(src: Source, s: dict) -> tuple[dict[str, list], str]:
    """(the added dimensions scale, impact, damping the study gives, in `DIMS` order; the
    impact law when one is given as a single value)."""
    extra: dict[str, list] = {}
    impact = "scale"
    if "impact" in s:
        laws = dimension_values(src, "study.impact", s["impact"], str)
        for law in laws:
            if law not in IMPACT_LAWS:
                raise src.error("study.impact", f"{law!r} is not one of {IMPACT_LAWS}", "impact")
        if isinstance(s["impact"], list):
            extra["impact"] = laws
        else:
            impact = laws[0]
    if "scale" in s:
        vals = dimension_values(src, "study.scale", s["scale"], float)
        if any(v <= 0 for v in vals):
            bad = next(v for v in vals if v <= 0)
            raise src.error("study.scale", f"{bad!r}: a scale must be positive (0 analyses "
                            "no motion, a negative one the record turned over)", "scale")
        extra["scale"] = vals
    if "damping" in s:
        vals = dimension_values(src, "study.damping", s["damping"], float)
        if any(v < 0 for v in vals):
            raise src.error("study.damping", "values must not be negative", "damping")
        problem = next(filter(None, (damping_ratio_problem("damping", v) for v in vals)), None)
        if problem:
            raise src.error("study.damping", problem, "damping")
        extra["damping"] = vals
    return {k: extra[k] for k in DIMS if k in extra}, impact


def _scale_factors(src: Source, s: dict, records: list[str], own: dict[str, OwnRecord],
                   groups: dict[str, list[str]]) -> dict[str, float]:
    table = s.get("scale_factor", {})
    if not isinstance(table, dict):
        raise src.error("study.scale_factor", "must be a table of record id = factor",
                        "scale_factor")
    scale_factor = {}
    for r, f in table.items():
        key = f"study.scale_factor.{r}"
        if not finite_number(f) or f <= 0:
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


def _pairs(src: Source, s: dict, wall_ids: list[str], records: list[str],
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


def _check_cells(src: Source, study: Study) -> None:
    """Every cell's Wall must be valid: build them now, before any computation."""
    for spec in study.walls:
        for d in study.diaphragms:
            for z in study.extra.get("damping", [None]):
                try:
                    study.wall(spec, d, z)
                except ValueError as exc:
                    raise src.error("study", f"wall {spec.id!r} on diaphragm {d.id!r}: {exc}",
                                    "walls") from None


def _histories(src: Source, study: Study, entries: Any, groups: dict[str, list[str]]
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

