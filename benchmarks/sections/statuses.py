"""How analyses end over the catalog and the FEMA P695 far-field set: every catalog wall
(the paper's parametric walls on every catalog diaphragm, as single-storey walls and as
higher-storey walls between two diaphragms alike, and the three Table II walls on their own
supports) under each of the 40 records, at scale factors from 0.25 up to the first
collapse. Counts the analyses ending ok, collapsed and on the event bound (``event-limit``,
the guard against a hang, which no wall should reach), and the joints held closed."""

from __future__ import annotations

import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from urmx.markdown import table

IN_ALL = False
SCALES = [0.25 * 2.0 ** (k / 2.0) for k in range(17)]  # 0.25 ... 64, ratio sqrt(2)
MAX_PGA = 5.0 * 9.80665  # stop the ladder beyond 5 g [m s-2]


def cells() -> list[tuple[str, str, object]]:
    """(wall id, diaphragm label, urmx.Wall) of every catalog cell."""
    from urmx.catalog import load_catalog
    from urmx.study.file import load_study

    cat = load_catalog()
    study = load_study("fema-p695-ida")
    out = []
    for spec in study.walls:
        for d in cat.diaphragms.values():
            for supports in ("top", "both"):
                study.own_supports = {d.id: supports}
                out.append((spec.id, d.id if supports == "top" else f"{d.id}/both",
                            study.wall(spec, d)))
    for key in ("wall12", "west", "c9"):
        out.append((key, "specimen", cat.walls[key].wall))
    return out


def _ladder(task):
    """Analyses of one wall under one record at the rising scale factors, up to the first
    collapse: a list of (scale, status, holds, events)."""
    wall, ag, dt = task
    from urmx import kernel

    pga = float(np.max(np.abs(ag)))
    out = []
    for s in SCALES:
        if s * pga > MAX_PGA and out:
            break
        r = kernel.run(wall, ag, dt, scale=s)
        out.append((s, r["status"], r["holds"], r["events"]))
        if r["status"] == "collapsed":
            break
    return out


def run(quick: bool, echo=print) -> dict:
    from urmx import records
    from urmx.kernel import warm_up

    ids = [k for k, v in records.manifest().items() if v.get("set") == "fema-p695-far-field"]
    if quick:
        ids = ids[:2]
    recs = {}
    for rid in ids:
        tr = records.load(rid)
        sf = float(tr.stats.record.scale_factor)
        recs[rid] = (np.ascontiguousarray(tr.data, dtype=float) * sf, float(tr.stats.delta))
    cl = cells()
    if quick:
        cl = cl[:: max(1, len(cl) // 6)]
    tasks = [(w, *recs[rid]) for _, _, w in cl for rid in ids]
    keys = [(wid, did, rid) for wid, did, _ in cl for rid in ids]
    warm_up()
    t0 = time.perf_counter()
    with ProcessPoolExecutor(2, initializer=warm_up) as pool:
        ladders = list(pool.map(_ladder, tasks, chunksize=8))
    seconds = time.perf_counter() - t0
    counts = {"ok": 0, "collapsed": 0, "event-limit": 0}
    holds = 0
    held_runs = 0
    limit_cells = []
    by_wall: dict[str, dict[str, int]] = {}
    for (wid, did, rid), lad in zip(keys, ladders, strict=True):
        group = "Table II" if did == "specimen" else ("higher storey" if "/both" in did
                                                     else "single storey")
        g = by_wall.setdefault(group, {"ok": 0, "collapsed": 0, "event-limit": 0,
                                       "analyses": 0, "held": 0})
        for s, status, h, _ in lad:
            counts[status] += 1
            g[status] += 1
            g["analyses"] += 1
            holds += h
            held_runs += h > 0
            g["held"] += h > 0
            if status == "event-limit":
                limit_cells.append([wid, did, rid, s])
    echo(f"statuses: {sum(counts.values())} analyses in {seconds:.0f} s: {counts}")
    return {"analyses": sum(counts.values()), "counts": counts, "holds": holds,
            "analyses_with_holds": held_runs, "cells": len(cl), "records": len(ids),
            "by_group": by_wall, "event_limit_cells": limit_cells, "seconds": seconds,
            "scales": [SCALES[0], SCALES[-1]], "max_pga": MAX_PGA}


def render(data: dict) -> list[str]:
    c = data["counts"]
    rows = [[g, v["analyses"], v["ok"], v["collapsed"], v["event-limit"], v["held"]]
            for g, v in data["by_group"].items()]
    rows.append(["all", data["analyses"], c["ok"], c["collapsed"], c["event-limit"],
                 data["analyses_with_holds"]])
    lines = [
        f"{data['cells']} catalog cells (walls x diaphragms x support kinds, and the Table II "
        f"walls on their own supports) x {data['records']} records of the FEMA P695 "
        f"far-field set, each at scale factors {data['scales'][0]:g}, "
        f"{data['scales'][0] * 2 ** 0.5:.3g}, ... (ratio sqrt 2) up to its first collapse "
        f"(or {data['max_pga'] / 9.80665:g} g): {data['analyses']} analyses in "
        f"{data['seconds']:.0f} s on 2 processes.",
        "",
        *table(["walls", "analyses", "ok", "collapsed", "event-limit",
                "analyses with a held joint"], rows),
        "",
        f"Joints held closed after an impact (MODEL.md section 4): {data['holds']} holds in "
        f"{data['analyses_with_holds']} analyses. "
        + ("No analysis reached the event bound." if not c["event-limit"] else
           f"Analyses on the event bound: {data['event_limit_cells']}"),
    ]
    return lines


def targets(data: dict) -> list[list[str]]:
    n = data["counts"]["event-limit"]
    return [["no catalog wall reaches the event bound (event-limit)",
             f"{n} of {data['analyses']}", "met" if n == 0 else "missed"]]
