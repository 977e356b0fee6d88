"""``urmx bench guard`` (the CI regression guard) and ``urmx bench NAME ...`` (the benchmark
suite of the source checkout, ``benchmarks/``, which is not installed with the package)."""

from __future__ import annotations

import sys


def add_arguments(p) -> None:
    """The arguments of ``urmx bench`` (also ``python -m benchmarks``)."""
    p.add_argument("what", nargs="*", default=["all"], metavar="NAME",
                   help="guard (the CI regression guard), render (rewrite the report from the "
                        "saved sections), all (default), a group (kernel, records, study, "
                        "hard) or section names of benchmarks/sections (fragility: the IDA "
                        "study, not in all)")
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


def register(sub) -> None:
    p = sub.add_parser(
        "bench", help="speed against error: write reports/performance.md, or run the CI guard",
        description="guard: the CI regression guard (exit 1 on a regression); kernel: "
                    "analyses/s and the ratio to the reference; records: work-precision and "
                    "cost growth; study: grid scaling on LocalClusters; hard: MODEL.md "
                    "section 10 cases; all: everything (add --paper for `urmx paper` end to "
                    "end). All but guard run the suite in benchmarks/ of a source checkout.")
    add_arguments(p)
    p.set_defaults(handler=run)


def run(args, suite=None) -> int:
    """Run the guard, or the suite (`suite`: the ``benchmarks`` package, found if None)."""
    if args.what == ["guard"]:
        from ..guard import run as guard

        m = guard(update=args.update, baseline_path=args.baseline, quick=args.quick)
        return 0 if m["passed"] else 1
    if args.update or args.baseline:
        from ..errors import InputError

        raise InputError("--update and --baseline apply to `urmx bench guard` alone")
    suite = suite or _suite()
    print(suite.run(args.what, args.out, quick=args.quick, paper=args.paper,
                    window=args.window or None))
    return 0


def _suite():
    """The ``benchmarks`` package of the source checkout this urmx runs from."""
    import importlib.util

    from ..config import project_root

    root = project_root()
    folder = root / "benchmarks"
    loaded = sys.modules.get("benchmarks")
    if loaded is not None and getattr(loaded, "__file__", None) == str(folder / "__init__.py"):
        return loaded
    if not ((root / "pyproject.toml").is_file() and (folder / "__init__.py").is_file()):
        from ..errors import MissingFileError

        raise MissingFileError(
            "the benchmark suite is not installed with urmx: it is the benchmarks/ folder of a "
            "source checkout (run `urmx bench` from an editable install of the checkout, or "
            "`python -m benchmarks` in it); only `urmx bench guard` works without it")
    spec = importlib.util.spec_from_file_location(
        "benchmarks", folder / "__init__.py", submodule_search_locations=[str(folder)])
    module = importlib.util.module_from_spec(spec)
    sys.modules["benchmarks"] = module
    spec.loader.exec_module(module)
    return module
