"""The CI regression guard (`urmx.guard`, ``urmx bench guard``) as a report section."""

from __future__ import annotations

from collections.abc import Callable

from urmx import guard

from ..common import fmt, verdict


def run(quick: bool, *, echo: Callable[[str], None] = print) -> dict:
    """One guard run against ``benchmarks/baseline.toml`` (the baseline is not updated)."""
    return guard.run(quick=quick, echo=echo)


def targets(g: dict) -> list[list[str]]:
    """Rows (target, measured, verdict) of the report's targets table."""
    return [["regression guard passes",
             f"error {fmt(g['error'])}, {1e3 * g['seconds']:.2f} ms", verdict(g["passed"])]]


def render(g: dict) -> list[str]:
    """The regression-guard section of the report."""
    b = g.get("baseline")
    stored = f"{1e3 * b['seconds']:.3f} ms" if b else "none for this class"
    L = ["## Regression guard", "",
         f"`urmx bench guard` (CI, < 30 s): the benchmark wall under El Centro x 0.5, "
         f"{g['samples']} samples; fails when the kernel is more than {guard.SLOWDOWN:g}x "
         f"slower than the stored figure of its machine class (`benchmarks/baseline.toml`) "
         f"or its max relative peak error vs the reference at rtol "
         f"{guard.REFERENCE_RTOL:g} exceeds {guard.MAX_ERROR:g}. With a cold numba cache (a "
         "fresh install) the first call compiles the kernel (about 40 s on this machine), so "
         "CI runs the guard after the test suite, which fills the cache.", "",
         f"Measured: {1e3 * g['seconds']:.3f} ms per analysis (first call "
         f"{g.get('first_call', 0):.2f} s), error {fmt(g['error'])} "
         f"(`{g['worst']}`), events {g['events']} (reference {g['reference_events']}); "
         f"stored: {stored}; {g['guard_seconds']:.1f} s; "
         f"**{'PASS' if g['passed'] else 'FAIL'}**.", ""]
    L += [f"- {m}" for m in g["messages"]]
    return L + [""]
