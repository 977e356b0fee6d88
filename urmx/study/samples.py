"""A study's records as `urmx.records.Record` objects: the samples its workers run on, with
their scale factors and where each comes from (the records manifest, or a record file the
study file declares in a ``[records.<id>]`` table), each file read once.

Provenance travels with every record (`urmx.records.Record`: file, SHA-256 of the file,
format, channel, unit, processing, source) into the archive's coordinates on the ``record``
dimension (`urmx.study.dataset.grid_coords`). A record's ``digest`` (in every batch key)
covers the file's SHA-256 too, so a cell computed on another version of a file is never
reused.
"""

from __future__ import annotations

import os
from pathlib import Path

from .. import records as rec
from ..config import data_dir
from ..errors import MissingFileError, UrmxError
from ..records.record import Record
from . import kinds

#: the record type of a study (one type for every path: `urmx.records.Record`)
RecordData = Record


def resolve_records(study, records_dir: str | os.PathLike | None = None) -> dict[str, Record]:
    """Load the study's records: manifest ids through `urmx.records` (manifest scale factors
    unless the study overrides them), the study file's own record files through
    `urmx.records.describe` (each read once, its SHA-256 computed in the same pass).

    Parameters
    ----------
    study : urmx.study.file.Study
        The study, as loaded from its file.
    records_dir : str or path-like, optional
        Records folder of the manifest ids (default :func:`urmx.config.records_dir`).

    Raises
    ------
    urmx.catalog.CatalogError
        An unknown id, an own record whose id is a manifest id without ``override = true``,
        a file that cannot be read as its table says (wrong channel, no dt, ...) or that
        differs from its pinned ``sha256``: each with the study file, key and line.
    """
    own = getattr(study, "own_records", {})
    manifest = _manifest(rec, records_dir, required=any(r not in own for r in study.records))
    for rid in study.records:
        if rid not in manifest and rid not in own:
            raise study.error("study.records", f"record {rid!r} is neither in the records "
                              f"manifest (known: {', '.join(sorted(manifest))}) nor a "
                              "[records.<id>] table of the study file", "records", rid)
    out = {}
    for rid in study.records:
        if rid in own:
            out[rid] = _own(study, own[rid], rid in manifest)
            continue
        entry = manifest[rid]
        sf = study.scale_factor.get(rid, entry.get("scale_factor", 1.0))
        out[rid] = Record.from_trace(rec.load(rid, records_dir), rid, float(sf),
                                     file=str(entry.get("file") or ""),
                                     source=_manifest_label(entry.get("manifest")))
    return out


def _manifest(rec, records_dir, required: bool) -> dict[str, dict]:
    """The records manifest; none when the study needs none of its records and it cannot
    be found (an installed urmx without one)."""
    try:
        return rec.manifest(records_dir)
    except MissingFileError:
        if required:
            raise
        return {}


def _own(study, o, in_manifest: bool) -> Record:
    """The Record of one of the study file's own record files, read once."""
    key = f"records.{o.table}"
    if in_manifest and not o.override:
        raise study.error(key, f"record id {o.id!r} is also a records-manifest id: choose "
                          f"another id, or set override = true in [{key}] to use this file "
                          "in its place", key)
    try:
        rf = rec.describe(o.path, channel=o.channel, dt=o.dt, unit=o.unit, format=o.format,
                          allow_unusual=o.allow_unusual)
    except UrmxError as exc:  # a RecordError, a missing file: with the study's table
        raise study.error(key, f"{o.file}: {exc}", key) from None
    window = kinds.get(study.kind).dt_above  # the kernel's merged-impact window
    if not rf.dt > window:  # only with allow_unusual: the kernel would refuse it later
        raise study.error(key, f"{o.file}: time step dt={rf.dt:g} s is not above the "
                          f"kernel's merged-impact window ({window:g} s)", key)
    if o.sha256 and rf.sha256 != o.sha256:
        raise study.error(f"{key}.sha256", f"{o.file} has SHA-256 {rf.sha256[:12]}..., not "
                          f"the {o.sha256[:12]}... the study pins: the file changed", key,
                          "sha256")
    sf = study.scale_factor.get(o.id, 1.0 if o.scale is None else o.scale)
    where = Path(study.path).name if study.path is not None else study.name
    return Record.from_file(rf, o.id, sf, file=o.file, source=f"study {where} [{key}]")


def _manifest_label(path) -> str:
    """``manifest <file>`` of a manifest entry's file: urmx's own manifest as
    ``records/manifest.toml`` (the same on every machine, from a checkout or a wheel), any
    other as it is."""
    if not path:
        return ""
    p = Path(path)
    try:
        p = p.resolve().relative_to(data_dir("records").parent.resolve())
    except (OSError, ValueError):
        pass
    return f"manifest {p.as_posix()}"
