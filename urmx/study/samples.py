"""A study's records as `urmx.records.Record` objects: the samples its workers run on, with the
manifest's scale factors (or the study's own) beside them."""

from __future__ import annotations

import os

from ..records.record import Record

#: the record type of a study (one type for every path: `urmx.records.Record`)
RecordData = Record


def resolve_records(study, records_dir: str | os.PathLike | None = None) -> dict[str, Record]:
    """Load the study's records through `urmx.records` (manifest scale factors unless the
    study overrides them); an unknown id fails with the study file and line."""
    from .. import records as rec

    manifest = rec.manifest(records_dir)
    for rid in study.records:
        if rid not in manifest:
            raise study.error("study.records", f"record {rid!r} is not in the records manifest "
                              f"(known: {', '.join(sorted(manifest))})", "records", rid)
    out = {}
    for rid in study.records:
        sf = study.scale_factor.get(rid, manifest[rid].get("scale_factor", 1.0))
        out[rid] = Record.from_trace(rec.load(rid, records_dir), rid, float(sf))
    return out
