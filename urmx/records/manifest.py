"""The record manifest (``records/manifest.toml``, plus a records folder's own
``manifest.toml``) and loading records by id; :func:`index` writes a manifest of a folder.

The manifest and the record files it names live in the repository's ``records/`` folder
(a wheel carries a copy: `urmx.config.shipped_records`). A folder the user names
(``URMX_RECORDS``, ``urmx.toml`` or ``--records``) wins for the records it holds: an entry
whose ``file`` is in it is read from there, the others from the shipped folder. The file's
SHA-256 is checked, and the record is read with the manifest's format, dt and unit. A
records directory that holds a ``manifest.toml`` of its own (what ``urmx records index``
writes) adds its records to the shipped ones: ``URMX_RECORDS=my/suite`` makes them
loadable by id.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
import os
import re
import sys
from pathlib import Path

from ..config import data_dir, shipped_records
from ..config import records_dir as _records_dir
from ..errors import InputError, MissingFileError, writing
from .errors import ChecksumError, ManifestError, UnknownFormatError, UnsupportedRecordError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib
from ..errors import path_argument
from .errors import RecordError
from .readers import (
    UNIT_FACTORS,
    describe_all,
    detect_format,
    read_file,
    same_channel,
    stated_by_format,
)

#: the manifest file: records/manifest.toml of the source checkout, or the copy an
#: installed wheel carries (`urmx.config.data_dir`)
MANIFEST = data_dir("records") / "manifest.toml"
#: a records folder's own manifest (``urmx records index``), read beside `MANIFEST`
FOLDER_MANIFEST = "manifest.toml"
_REQUIRED = ("id", "set", "event", "file", "format", "dt", "unit", "sha256", "expected_pga_g",
             "scale_factor", "source", "notes")


_PARSED: dict[str, tuple] = {}  # path -> ((mtime, size), its checked entries)


def _read_manifest(src: Path) -> list[dict]:
    """The checked entries of the manifest `src` (a copy: callers may change them).

    A manifest is parsed and checked once while its file stays the same (path,
    modification time and size): a study loads each of its records through it."""
    try:
        st = os.stat(src)
    except OSError:
        return _parse_manifest(src)  # its own error
    where, stamp = os.fspath(Path(src).resolve()), (st.st_mtime_ns, st.st_size)
    if _PARSED.get(where, (None,))[0] != stamp:
        _PARSED[where] = (stamp, _parse_manifest(src))
    return copy.deepcopy(_PARSED[where][1])


def _parse_manifest(src: Path) -> list[dict]:
    try:
        data = tomllib.loads(src.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise MissingFileError(f"record manifest {str(src)!r} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ManifestError(src, f"cannot be read: {getattr(exc, 'strerror', None) or exc}") \
            from None
    except tomllib.TOMLDecodeError as exc:
        raise ManifestError(src, f"not valid TOML: {exc}") from None
    records = data.get("record", [])
    if not isinstance(records, list) or not all(isinstance(e, dict) for e in records):
        raise ManifestError(src, "`record` must be an array of tables ([[record]])")
    for k, entry in enumerate(records):
        missing = [f for f in _REQUIRED if f not in entry]
        if missing:
            raise ManifestError(src, f"record #{k + 1} ({entry.get('id', '?')}) lacks "
                                f"{', '.join(missing)}")
        _validate(src, k, entry)
        group = entry.get("group")
        if group is not None and not (isinstance(group, str) and group.strip()):
            raise ManifestError(src, f"record {entry.get('id', '?')}: group must be a "
                                f"non-empty string (a station or event), not {group!r}")
    return records


#: what each number of a manifest entry must be: key -> (test, what it must be)
_NUMBERS = {
    "scale_factor": (lambda v: v > 0, "a positive number (the factor the record is "
                     "analysed at)"),
    "paper_scale_factor": (lambda v: v > 0, "a positive number"),
    "dt": (lambda v: v > 0, "a positive time step in seconds"),
    "expected_pga_g": (lambda v: v >= 0, "a peak acceleration in g, >= 0"),
    "paper_pga_g": (lambda v: v >= 0, "a peak acceleration in g, >= 0"),
    "target_scaled_pga_g": (lambda v: v >= 0, "a peak acceleration in g, >= 0"),
    "npts": (lambda v: v >= 2 and float(v).is_integer(), "a whole number of points >= 2"),
}
_STRINGS = ("id", "set", "file", "format", "unit", "sha256", "source", "event", "channel")


def _validate(src: Path, k: int, entry: dict) -> None:
    """Every value of a manifest entry checked where it is read: a one-line
    `ManifestError` naming the file, the record and the key (a scale factor of 0, -0.5 or
    nan is never used)."""
    rid = entry.get("id", "?")

    def bad(key, what):
        return ManifestError(src, f"record #{k + 1} ({rid!r}): {key} = {entry[key]!r} must "
                             f"be {what}")

    for key in _STRINGS:
        if key in entry and (not isinstance(entry[key], str) or not entry[key].strip()):
            raise bad(key, "a non-empty string in quotes")
    for key, (ok, what) in _NUMBERS.items():
        if key not in entry:
            continue
        v = entry[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                or not ok(v):
            raise bad(key, what)
    if entry["unit"] not in UNIT_FACTORS and entry["unit"] not in ("g/10", "um/s2"):
        raise bad("unit", f"one of {', '.join(UNIT_FACTORS)}")
    if not re.fullmatch(r"[0-9a-f]{64}", entry["sha256"]):
        raise bad("sha256", "the 64 hexadecimal digits of the file's SHA-256")
    if "allow_unusual" in entry and not isinstance(entry["allow_unusual"], bool):
        raise bad("allow_unusual", "true or false")


def manifest(records_dir: str | os.PathLike | None = None,
             path: str | os.PathLike | None = None) -> dict[str, dict]:
    """All manifest entries by record id.

    Parameters
    ----------
    records_dir : str or path-like, optional
        A records folder of the user's (default: the configured one, ``URMX_RECORDS`` or
        ``urmx.toml``, if any). It wins over the records urmx ships
        (`urmx.config.shipped_records`) for the records it holds: an entry of
        ``records/manifest.toml`` whose ``file`` is in it is read from it, the others from
        the shipped folder; a ``manifest.toml`` in it adds its records (and replaces a
        shipped record of the same id).
    path : str or path-like, optional
        Another manifest file, read alone, its ``file`` entries relative to the records
        folder (default: ``records/manifest.toml`` and the records folder's
        ``manifest.toml``).

    Returns
    -------
    dict of str to dict
        Record id -> entry with every manifest field (id, set, event, date, magnitude,
        station, component, site, source, file, format, dt [s], unit, sha256,
        expected_pga_g [g], paper_scale_factor, scale_factor, notes, and the optional
        ``group``: records of one station or event, resampled together by the fits'
        bootstraps and the sufficiency tests, ...), in file order; ``manifest`` names the
        file the entry comes from, ``folder`` the records folder its file is read from and
        ``path`` the file itself.

    Raises
    ------
    ManifestError
        A manifest that is not valid TOML, an entry without a required field, a value
        that is not what its key needs (a scale factor that is not a positive finite
        number, ...: the message names the file, the record and the key), or an id that
        appears twice in one file.
    """
    shipped = shipped_records()
    try:
        base = _records_dir(records_dir)
    except FileNotFoundError:
        if records_dir is not None:
            raise
        base = shipped
    own_folder = base != shipped
    out: dict[str, dict] = {}
    if path is not None:
        sources = [(Path(path), base, False)]
    else:
        sources = [(MANIFEST, shipped, own_folder)]
        own = base / FOLDER_MANIFEST
        if own_folder and own.is_file() and not (MANIFEST.is_file() and own.samefile(MANIFEST)):
            sources.append((own, base, False))
    for src, folder, prefer_base in sources:
        seen: set[str] = set()
        for entry in _read_manifest(src):
            if entry["id"] in seen:
                raise ManifestError(src, f"record id {entry['id']!r} appears twice")
            seen.add(entry["id"])
            where = base if prefer_base and (base / entry["file"]).is_file() else folder
            out[entry["id"]] = dict(entry, manifest=str(src), folder=str(where),
                                    path=str(where / entry["file"]))
    return out


def sha256(path: str | os.PathLike) -> str:
    """SHA-256 hex digest of a file."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def entry(record_id: str, records_dir: str | os.PathLike | None = None,
          path: str | os.PathLike | None = None) -> dict:
    """One manifest entry (`path`: another manifest, as for :func:`manifest`); a clear
    error listing close ids if it is unknown."""
    entries = manifest(records_dir, path)
    if record_id not in entries:
        import difflib

        close = difflib.get_close_matches(record_id, list(entries), n=4, cutoff=0.5)
        hint = f"; did you mean {', '.join(close)}?" if close else "; see `urmx records list`"
        raise ManifestError(path or MANIFEST, f"no record with id {record_id!r}{hint}")
    return entries[record_id]


def load(record_id: str, records_dir: str | os.PathLike | None = None, *,
         channel: str | None = None, manifest: str | os.PathLike | None = None):
    """Load a manifest record as an :class:`obspy.Trace` in m s-2 (not scaled).

    Parameters
    ----------
    record_id : str
        Manifest id (``elcentro``, ``nahanni``, ``christchurch``, ``bigbear``,
        ``p695-01-mul009``, ...).
    records_dir : str or path-like, optional
        Folder the manifest's ``file`` entries are resolved against (default
        :func:`urmx.config.records_dir`); a ``manifest.toml`` in it adds its records.
    channel : str, optional
        The channel of a multi-channel file whose entry names none; it must agree with
        the entry's ``channel`` where there is one.
    manifest : str or path-like, optional
        Another manifest file (what ``urmx records index`` wrote), read alone.

    Returns
    -------
    obspy.Trace
        Acceleration [m s-2]; ``stats.record`` carries the manifest entry's id, set,
        scale_factor and paper_scale_factor besides the reader's fields.

    Raises
    ------
    FileNotFoundError
        The records directory or the record file is missing (the message names the file
        and its source).
    ChecksumError
        The file's SHA-256 differs from the manifest.
    ManifestError
        An unknown id, or a multi-channel file without a channel (the message lists them).
    """
    s = load_samples(record_id, records_dir, channel=channel, manifest=manifest)
    tr = s.trace()
    tr.stats.processing.append(f"urmx.records.load: {record_id!r}, sha256 verified")
    return tr


def load_samples(record_id: str, records_dir: str | os.PathLike | None = None, *,
                 channel: str | None = None, manifest: str | os.PathLike | None = None):
    """:func:`load` without ObsPy: the record as :class:`urmx.records.readers.Samples`
    (``data`` in m s-2, ``dt``, ``record`` with the manifest entry's id, set, scale_factor,
    paper_scale_factor and sha256). Same arguments, checks and errors as :func:`load`; the
    file is read once.

    Parameters
    ----------
    record_id : str
        Manifest id, as for :func:`load`.
    records_dir : str or path-like, optional
        Folder the manifest's ``file`` entries are resolved against (default
        :func:`urmx.config.records_dir`).
    channel : str, optional
        The channel of a multi-channel file whose entry names none.
    manifest : str or path-like, optional
        Another manifest file, read alone.
    """
    if not isinstance(record_id, str):
        raise InputError(f"load: record_id must be a manifest record id (str), got "
                         f"{record_id!r} ({type(record_id).__name__})")
    e = entry(record_id, records_dir, manifest)
    path = Path(e["path"])
    if not path.is_file():
        raise MissingFileError(f"record {record_id!r}: file {str(path)!r} is missing; it comes "
                               f"from {e['source']}")

    def mismatch(digest):
        return ChecksumError(path, f"record {record_id!r}: SHA-256 {digest[:12]}... differs "
                             f"from the manifest's {e['sha256'][:12]}...; the file is not the "
                             f"one from {e['source']}")

    want = e.get("channel")
    if channel is not None and want is not None and not same_channel(want, channel):
        raise ManifestError(e["manifest"], f"record {record_id!r} is channel {want!r} of "
                            f"{e['file']}, not {channel!r}")
    states = stated_by_format(e["format"])
    try:
        got = read_file(path, e["format"], None if "dt" in states else e["dt"],
                    None if "unit" in states else e["unit"], want or channel,
                    bool(e.get("allow_unusual", False)))
    except RecordError:
        digest = sha256(path)  # a file that no longer reads: say first that it changed
        if digest != e["sha256"]:
            raise mismatch(digest) from None
        raise
    if got.sha256 != e["sha256"]:
        raise mismatch(got.sha256)
    if len(got.samples) != 1:
        raise ManifestError(e["manifest"], f"record {record_id!r}: {e['file']} holds "
                            f"{len(got.samples)} channels ({', '.join(got.channels)}); set "
                            "`channel` in the manifest (or pass channel=)")
    s = got.samples[0]
    s.record.update({k: e.get(k) for k in ("id", "set", "scale_factor",
                                           "paper_scale_factor", "sha256")})
    return s


# -- a manifest of a folder of record files (``urmx records index``) --------------------


def record_id(text: str) -> str:
    """A record id from a file name or channel: lower case, runs of other characters than
    letters and digits as one ``-`` (``RSN763_LOMAP_GIL067`` -> ``rsn763-lomap-gil067``)."""
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-") or "record"


def index(folder: str | os.PathLike, *, pattern: str = "*", dt: float | None = None,
          unit: str | None = None, record_set: str = "own", allow_unusual: bool = False,
          skip_unknown: bool = False) -> tuple[list[dict], list[str]]:
    """Manifest entries for the record files of a folder, each file read once.

    Parameters
    ----------
    folder : str or path-like
        The folder; ``file`` entries are relative to it (it is the records directory the
        entries are loaded with).
    pattern : str
        Glob of the files to index, relative to `folder` (``"*.AT2"``, ``"**/*.V2A"``).
    dt : float, optional
        Time step [s] of the plain number files (format ``columns``) that do not state
        one; files that state their own are not given it.
    unit : {"g", "m/s2", "cm/s2", "mm/s2"}, optional
        Unit of the plain number files and ObsPy-format files (which do not state one).
    record_set : str
        The entries' ``set``.
    allow_unusual : bool
        Index records outside `urmx.records.readers.DT_RANGE`/`PGA_RANGE_G` too; their
        entries carry ``allow_unusual = true``.
    skip_unknown : bool
        Leave out files that are not record files (unknown format, spectra, pickles)
        instead of stopping at the first; they are listed in the second return value.

    Returns
    -------
    entries : list of dict
        One entry per channel (a multi-channel file gives one per channel, with
        ``channel``), with every field `manifest` requires: id (from the file name, and
        the channel for multi-channel files; unique, and none an id of
        ``records/manifest.toml``), set, event (the file's header line naming the record,
        else its name), station, component, file, format, dt [s], unit, npts, sha256,
        expected_pga_g (unscaled PGA [g]), scale_factor (1.0), source, notes.
    skipped : list of str
        ``"name: why"`` for each file left out.

    Raises
    ------
    InputError
        No file matches `pattern`.
    RecordError
        A file that cannot be read (names it; with ``skip_unknown`` only for files of a
        known format).
    """
    path_argument("index", "folder", folder)

    folder = Path(folder)
    if not folder.is_dir():
        raise MissingFileError(f"records folder {str(folder)!r} does not exist")
    files = sorted(p for p in folder.glob(pattern) if p.is_file()
                   and not p.name.startswith(".") and p.name != FOLDER_MANIFEST)
    if not files:
        raise InputError(f"no file in {str(folder)!r} matches {pattern!r}")
    found, skipped = _described(folder, files, dt, unit, allow_unusual, skip_unknown)
    taken = set(manifest(path=MANIFEST)) if MANIFEST.is_file() else set()
    ids = _unique_ids([record_id(f.stem) + (f"-{record_id(rf.channel)}" if multi else "")
                       for f, rf, multi in found],
                      [record_id(f.name) + (f"-{record_id(rf.channel)}" if multi else "")
                       for f, rf, multi in found], taken, record_id(record_set))
    return [_entry(ident, f.relative_to(folder).as_posix(), rf, multi, record_set,
                   allow_unusual) for ident, (f, rf, multi) in zip(ids, found, strict=True)], \
        skipped


def _described(folder: Path, files: list[Path], dt: float | None, unit: str | None,
               allow_unusual: bool, skip_unknown: bool) -> tuple[list[tuple], list[str]]:
    """([(file, its described channel, whether the file has several)], the files left out
    with why) of :func:`index`: each file read once, with the `dt` and `unit` its format
    does not state."""
    found, skipped = [], []
    for f in files:
        try:
            fmt = detect_format(f, allow_unusual=allow_unusual)
        except (UnknownFormatError, UnsupportedRecordError) as exc:
            if not skip_unknown:
                raise
            why = exc.problem.split("; urmx reads")[0]  # not the list of formats each time
            skipped.append(f"{f.relative_to(folder).as_posix()}: {why}")
            continue
        states = stated_by_format(fmt)
        rfs = describe_all(f, dt=None if "dt" in states else dt,
                           unit=None if "unit" in states else unit,
                           allow_unusual=allow_unusual)
        found.extend((f, rf, len(rfs) > 1) for rf in rfs)
    return found, skipped


def _entry(ident: str, rel: str, rf, multi: bool, record_set: str,
           allow_unusual: bool) -> dict:
    """The manifest entry of one described channel (file `rel` of the indexed folder)."""
    e = dict(id=ident, set=record_set, event=rf.description or Path(rel).name,
             station=rf.station, component=rf.channel)
    if multi:
        e["channel"] = rf.channel
    e.update(source=f"{rel} (urmx records index)", file=rel, format=rf.format, dt=rf.dt,
             unit=rf.unit, npts=rf.npts, sha256=rf.sha256,
             expected_pga_g=float(f"{rf.pga_g:.6g}"), scale_factor=1.0,
             notes="; ".join(rf.processing[1:]) or "read as it is")
    if allow_unusual:
        e["allow_unusual"] = True
    return e


def _unique_ids(short: list[str], long: list[str], taken: set[str], prefix: str) -> list[str]:
    """Ids from `short` (file stems), using `long` (with the extension) where two clash,
    prefixing `prefix` to ids of the checkout's manifest, numbering what still clashes."""
    ids = [long[k] if short.count(s) > 1 else s for k, s in enumerate(short)]
    ids = [f"{prefix}-{i}" if i in taken else i for i in ids]
    out, seen = [], set(taken)
    for i in ids:
        j, n = i, 2
        while j in seen:
            j, n = f"{i}-{n}", n + 1
        seen.add(j)
        out.append(j)
    return out


def _toml(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise InputError(f"a manifest value must be finite, not {value!r}")
        return repr(value)
    return json.dumps(str(value)).replace("\x7f", "\\u007f")  # a TOML basic string


def write_manifest(entries: list[dict], path: str | os.PathLike, comment: str = "") -> Path:
    """Write manifest entries as ``[[record]]`` tables of a TOML file (the schema of
    ``records/manifest.toml``), `comment` as ``#`` lines on top. Returns the path.

    Parameters
    ----------
    entries : list of dict
        One dict per record, with the keys of a ``[[record]]`` table (``id``, ``file``,
        ``sha256``, ``dt`` [s], ``unit``, ``scale_factor`` [1], ...).
    path : str or path-like
        The TOML file to write.
    comment : str
        Text written as ``#`` lines on top.
    """
    path_argument("write_manifest", "path", path)
    path = Path(path)
    lines = [f"# {ln}".rstrip() for ln in comment.splitlines()]
    for e in entries:
        lines += ["", "[[record]]"] + [f"{k} = {_toml(v)}" for k, v in e.items()
                                       if k not in ("path", "manifest")]
    with writing(path, "manifest"):
        path.write_text("\n".join(lines).lstrip("\n") + "\n", encoding="utf-8")
    return path
