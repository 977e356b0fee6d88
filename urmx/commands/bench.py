"""``urmx bench [kernel|records|study|hard|guard|all] [--quick] [--out reports/performance.md]``."""

from __future__ import annotations

#: what each subcommand runs (sections of urmx.bench)
GROUPS = {
    "kernel": ["kernel"],
    "records": ["work_precision", "cost_growth"],
    "study": ["grid_scaling"],
    "hard": ["hard_cases"],
    "all": ["kernel", "work_precision", "cost_growth", "grid_scaling", "hard_cases", "guard"],
}


def register(sub) -> None:
    p = sub.add_parser(
        "bench", help="speed against error: write reports/performance.md, or run the CI guard",
        description="kernel: analyses/s and the ratio to the reference; records: "
                    "work-precision and cost growth; study: grid scaling on LocalClusters; "
                    "hard: MODEL.md section 10 cases; guard: the CI regression guard (exit 1 "
                    "on a regression); all: everything (add --paper for `urmx paper` end to "
                    "end).")
    p.add_argument("what", nargs="?", default="all", choices=[*GROUPS, "guard"],
                   help="what to measure (default: all)")
    p.add_argument("--quick", action="store_true",
                   help="reduced sizes, to check the machinery (not the acceptance run)")
    p.add_argument("--out", default="reports/performance.md",
                   help="report to write; figures and JSON go to its folder without .md")
    p.add_argument("--paper", action="store_true",
                   help="with study/all: also time `urmx paper` from a cold start (long)")
    p.add_argument("--window", type=float, default=20.0,
                   help="records/all: seconds of each record in the work-precision study "
                        "(default 20; 0 = whole records, slow: the reference costs about 1 ms "
                        "per record step and tolerance)")
    p.add_argument("--update", action="store_true",
                   help="guard: store this measurement as the baseline of the machine class")
    p.add_argument("--baseline", default=None,
                   help="guard: baseline file (default: benchmarks/baseline.toml)")
    p.set_defaults(handler=_bench)


def _bench(args) -> int:
    import os

    os.environ.setdefault("MPLBACKEND", "Agg")
    from .. import bench

    if args.what == "guard":
        m = bench.guard(update=args.update, baseline_path=args.baseline, quick=args.quick)
        return 0 if m["passed"] else 1
    names = list(GROUPS[args.what])
    if args.paper and args.what in ("study", "all"):
        names.insert(names.index("grid_scaling") + 1, "paper")
    path = bench.run_sections(names, args.out, quick=args.quick, window=args.window or None)
    print(path)
    return 0
