"""Golden cases: the kernel's outputs on a fixed set of catalog analyses, compared bit for
bit with another commit's kernel (a change that should not move results must not).

``python -m benchmarks.golden --against 8b38483`` exports that commit's source with
``git archive`` into a temporary folder (no worktree), runs every case through both
kernels in fresh processes and lists the cases whose outputs differ in any bit. The cases:
every catalog cell of the statuses section (the parametric walls on every catalog
diaphragm, single- and higher-storey, and the three Table II walls on their own supports),
C9 on the four support cases and Wall 12 on 1e9 N/m springs, each under one of the paper's
records at one of four scale factors (cycling), under both impact laws.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from benchmarks.common import export_commit

RECORDS = ("elcentro", "nahanni", "christchurch", "bigbear")
SCALES = (0.5, 1.0, 1.5, 2.0)  # times the record's manifest scale factor
LAWS = ("scale", "contact")
#: the outputs compared (every scalar of kernel.run)
KEYS = ("peak_crack_displacement", "peak_top_displacement", "peak_base_displacement",
        "peak_lower_drift", "peak_upper_drift", "peak_top_acceleration",
        "peak_crack_acceleration", "peak_base_acceleration", "instability_ratio_lower",
        "instability_ratio_upper", "instability_ratio", "peak_lower_drift_family1",
        "collapsed", "collapse_time", "unfavourable_fraction", "base_impacts",
        "crack_impacts", "status", "duration", "events", "holds")

_RUN = r"""
import sys, json
sys.path.insert(0, sys.argv[1])
import numpy as np
from urmx import kernel, Wall
spec = json.load(open(sys.argv[2]))
recs = np.load(sys.argv[3])
keys = spec["keys"]
out = []
for c in spec["cases"]:
    w = Wall(**c["wall"])
    r = kernel.run(w, recs[c["record"]], float(recs[c["record"] + "_dt"]), scale=c["scale"],
                   impact=c["law"], cor=c["cor"])
    out.append({k: (r[k].hex() if isinstance(r[k], float) else r[k]) for k in keys})
json.dump(out, open(sys.argv[4], "w"))
"""


def cases() -> tuple[list[dict], dict[str, np.ndarray]]:
    """(cases, records): each case a dict of wall fields, record id, scale, law, cor and a
    label; records as arrays [m s-2] with their steps under ``<id>_dt``."""
    from benchmarks.sections.statuses import cells
    from urmx import records
    from urmx.catalog import load_catalog

    cat = load_catalog()
    c9 = cat.walls["c9"].wall
    wall12 = cat.walls["wall12"].wall
    extra = [("c9", "rigid/rigid", c9.replace(bottom_stiffness="rigid", top_stiffness="rigid")),
             ("c9", "rigid/flex", c9.replace(bottom_stiffness="rigid")),
             ("c9", "flex/rigid", c9.replace(top_stiffness="rigid")),
             ("wall12", "1e9 springs", wall12.replace(bottom_stiffness=1e9, top_stiffness=1e9))]
    recs: dict[str, np.ndarray] = {}
    sf = {}
    for rid in RECORDS:
        tr = records.load(rid)
        recs[rid] = np.ascontiguousarray(tr.data, dtype=float)
        recs[rid + "_dt"] = np.array(float(tr.stats.delta))
        sf[rid] = float(tr.stats.record.scale_factor)
    out = []
    for i, (wid, did, wall) in enumerate([*cells(), *extra]):
        rid = RECORDS[i % len(RECORDS)]
        scale = SCALES[(i // len(RECORDS)) % len(SCALES)]
        for law in LAWS:
            out.append({"label": f"{wid} {did} {rid} x{scale:g} {law}", "wall": wall.to_dict(),
                        "record": rid, "scale": scale * sf[rid], "law": law, "cor": 0.8})
    return out, recs


def _run_tree(tree: Path, spec: Path, recs: Path, out: Path) -> list[dict]:
    subprocess.run([sys.executable, "-c", _RUN, str(tree), str(spec), str(recs), str(out)],
                   check=True, cwd=tree)
    return json.loads(out.read_text())


def compare(against: str, base: Path | None = None) -> list[tuple[str, list[str]]]:
    """Run every case through the kernel of this checkout and of commit `against` (exported
    into `base`, a temporary folder by default); returns (label, names of the differing
    outputs) of the cases that differ."""
    from urmx.config import project_root

    tree = project_root()
    spec_cases, recs = cases()
    with tempfile.TemporaryDirectory(prefix="urmx-golden-") as tmp:
        tmp = Path(tmp)
        base = export_commit(against, base or tmp / "base", ("urmx",))
        spec = tmp / "spec.json"
        spec.write_text(json.dumps({"cases": spec_cases, "keys": list(KEYS)}))
        np.savez(tmp / "recs.npz", **recs)
        new = _run_tree(tree, spec, tmp / "recs.npz", tmp / "new.json")
        old = _run_tree(base, spec, tmp / "recs.npz", tmp / "old.json")
    diffs = []
    for c, a, b in zip(spec_cases, new, old, strict=True):
        names = [k for k in KEYS if a[k] != b[k]]
        if names:
            diffs.append((c["label"], names))
    return diffs


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.golden",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--against", required=True, help="commit to compare with")
    parser.add_argument("--base", type=Path, help="folder to export that commit into "
                        "(kept, with its compiled kernel, for the next comparison)")
    args = parser.parse_args(argv)
    n = len(cases()[0])
    diffs = compare(args.against, args.base)
    print(f"{n} cases, {len(diffs)} differ from {args.against}")
    for label, names in diffs:
        print(f"  {label}: {', '.join(names)}")
    return 0


if __name__ == "__main__":
    os.environ.setdefault("PYTHONHASHSEED", "0")
    sys.exit(main())
