"""The record manifest (``records/manifest.toml``) and loading records by id.

The manifest lives in the repository; the data files do not. ``file`` entries are
resolved against the records directory (:func:`urmx.config.records_dir`), the file's
SHA-256 is checked, and the record is read with the manifest's format, dt and unit.
"""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

from ..config import project_root
from ..config import records_dir as _records_dir
from ..errors import MissingFileError
from .errors import ChecksumError, ManifestError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

#: the manifest file in the source checkout
MANIFEST = project_root() / "records" / "manifest.toml"
_REQUIRED = ("id", "set", "event", "file", "format", "dt", "unit", "sha256", "expected_pga_g",
             "scale_factor", "source", "notes")


def manifest(records_dir: str | os.PathLike | None = None,
             path: str | os.PathLike | None = None) -> dict[str, dict]:
    """All manifest entries by record id.

    Parameters
    ----------
    records_dir : str or path-like, optional
        Records directory used to add each entry's absolute ``path``; if omitted the
        configured one is used when set (``URMX_RECORDS``, ``urmx.toml``), otherwise
        entries carry no ``path``.
    path : str or path-like, optional
        Another manifest file (default ``records/manifest.toml``).

    Returns
    -------
    dict of str to dict
        Record id -> entry with every manifest field (id, set, event, date, magnitude,
        station, component, site, source, file, format, dt [s], unit, sha256,
        expected_pga_g [g], paper_scale_factor, scale_factor, notes, ...), in file order.
    """
    src = Path(path) if path is not None else MANIFEST
    try:
        data = tomllib.loads(src.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise MissingFileError(f"record manifest {str(src)!r} does not exist") from None
    except tomllib.TOMLDecodeError as exc:
        raise ManifestError(src, f"not valid TOML: {exc}") from None
    base = None
    try:
        base = _records_dir(records_dir)
    except FileNotFoundError:
        if records_dir is not None:
            raise
    out: dict[str, dict] = {}
    for k, entry in enumerate(data.get("record", [])):
        missing = [f for f in _REQUIRED if f not in entry]
        if missing:
            raise ManifestError(src, f"record #{k + 1} ({entry.get('id', '?')}) lacks "
                                f"{', '.join(missing)}")
        if entry["id"] in out:
            raise ManifestError(src, f"record id {entry['id']!r} appears twice")
        entry = dict(entry)
        if base is not None:
            entry["path"] = str(base / entry["file"])
        out[entry["id"]] = entry
    return out


def sha256(path: str | os.PathLike) -> str:
    """SHA-256 hex digest of a file."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def entry(record_id: str, records_dir: str | os.PathLike | None = None) -> dict:
    """One manifest entry; a clear error listing close ids if it is unknown."""
    entries = manifest(records_dir)
    if record_id not in entries:
        import difflib

        close = difflib.get_close_matches(record_id, list(entries), n=4, cutoff=0.5)
        hint = f"; did you mean {', '.join(close)}?" if close else "; see `urmx records list`"
        raise ManifestError(MANIFEST, f"no record with id {record_id!r}{hint}")
    return entries[record_id]


def load(record_id: str, records_dir: str | os.PathLike | None = None):
    """Load a manifest record as an :class:`obspy.Trace` in m s-2 (not scaled).

    Parameters
    ----------
    record_id : str
        Manifest id (``elcentro``, ``nahanni``, ``christchurch``, ``bigbear``,
        ``p695-01-mul009``, ...).
    records_dir : str or path-like, optional
        Folder the manifest's ``file`` entries are resolved against (default
        :func:`urmx.config.records_dir`).

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
    """
    s = load_samples(record_id, records_dir)
    tr = s.trace()
    tr.stats.processing.append(f"urmx.records.load: {record_id!r}, sha256 verified")
    return tr


def load_samples(record_id: str, records_dir: str | os.PathLike | None = None):
    """:func:`load` without ObsPy: the record as :class:`urmx.records.readers.Samples`
    (``data`` in m s-2, ``dt``, ``record`` with the manifest entry's id, set, scale_factor,
    paper_scale_factor and sha256). Same checks and errors as :func:`load`."""
    from .readers import read_samples

    base = _records_dir(records_dir)
    e = entry(record_id, base)
    path = base / e["file"]
    if not path.is_file():
        raise MissingFileError(f"record {record_id!r}: file {str(path)!r} is missing; it comes "
                                f"from {e['source']}")
    digest = sha256(path)
    if digest != e["sha256"]:
        raise ChecksumError(path, f"record {record_id!r}: SHA-256 {digest[:12]}... differs from "
                            f"the manifest's {e['sha256'][:12]}...; the file is not the one "
                            f"from {e['source']}")
    carries = e["format"] != "columns"  # formats with headers state dt and unit themselves
    chans = read_samples(path, format=e["format"], dt=None if carries else e["dt"],
                         unit=None if carries else e["unit"])
    if "channel" in e:
        chans = [c for c in chans if c.channel == e["channel"]]
    if len(chans) != 1:
        raise ManifestError(path, f"record {record_id!r}: expected one channel, found "
                            f"{len(chans)}; set `channel` in the manifest")
    s = chans[0]
    s.record.update({k: e.get(k) for k in ("id", "set", "scale_factor",
                                           "paper_scale_factor", "sha256")})
    return s
