"""Hard cases of MODEL.md section 10: time, events and agreement with the reference of
zero input, mirrored input, energy in free vibration, simultaneous contacts, 1e9 N/m
springs, a collapse bracket and a long fine record."""

from __future__ import annotations

import math
import time

import numpy as np

from urmx import Wall
from urmx.markdown import table

from ..common import PEAKS, benchmark_wall, fmt, load_record, median_time, rel_error, table2_walls


def _energy_drift(wall: Wall, hist: dict, start: int) -> float:
    """Largest relative change of the mechanical energy (kinetic + trilinear strain energy
    of both segments) over the grid points from `start` on (a wall with both supports
    rigid: one coordinate, theta1)."""
    from urmx.model import P_A1, P_A2, potential, system

    P = wall.params
    r = hist["r"][start:, 0]
    v = hist["r_dot"][start:, 0]
    fam = hist["pattern"][start:] // 10
    E = np.empty(r.size)
    for i in range(r.size):
        f = int(fam[i]) if fam[i] in (1, 2) else 2
        M = system(P, f, 0, 0)[0][0, 0]
        th2 = -P[P_A1] / P[P_A2] * r[i]
        E[i] = 0.5 * M * v[i] ** 2 + potential(P, 3 if f == 1 else 2, r[i]) + potential(P, 1, th2)
    return float(np.max(np.abs(E - E[0])) / E[0])


def run(quick: bool) -> dict:
    """Each hard case: kernel time and events, the reference's agreement, a check."""
    from urmx import kernel, reference

    rows = []
    bw = benchmark_wall()
    ag_ec, dt_ec, sf_ec = load_record("elcentro", 10.0 if quick else None)
    w12 = table2_walls()["wall12"]
    ag_nh, dt_nh, sf_nh = load_record("nahanni", 5.0 if quick else None)

    def timed(fn, min_time=0.2 if quick else 1.0):
        res = fn()
        return res, median_time(fn, repeat=3, min_time=min_time)["median"]

    def row(name, wall, ag, dt, check, value, ok, ref=True, **kw):
        res, t = timed(lambda: kernel.run(wall, ag, dt, **kw))
        r = {"case": name, "kernel_ms": 1e3 * t, "events": res["events"],
             "status": res["status"], "check": check, "value": value, "ok": bool(ok)}
        if ref:
            t0 = time.perf_counter()
            rr = reference.run(wall, ag, dt, rtol=1e-10, **kw)
            r["reference_s"] = time.perf_counter() - t0
            r["reference_events"] = rr["events"]
            r["agreement"] = rel_error(res, rr)["max"]
            # every case must also agree with the reference to 1e-6 in every peak
            r["ok"] = r["ok"] and r["agreement"] <= 1e-6 and res["status"] == rr["status"]
        rows.append(r)
        return res

    # zero input stays exactly at rest
    zero = np.zeros_like(ag_ec)
    res = kernel.run(bw, zero, dt_ec)
    at_rest = max(abs(res[k]) for k in PEAKS)
    row("zero input (benchmark wall, 0 m s-2)", bw, zero, dt_ec,
        "max peak output", at_rest, at_rest == 0.0 and res["events"] == 0)
    # mirrored input gives mirrored output
    a = kernel.run(bw, ag_ec, dt_ec, scale=sf_ec)
    b = kernel.run(bw, -ag_ec, dt_ec, scale=sf_ec)
    mirror = rel_error(b, a)["max"]
    row("mirrored input (benchmark wall, -El Centro x 0.5)", bw, -ag_ec, dt_ec,
        "max rel. difference of peaks vs unmirrored", mirror, mirror <= 1e-9, scale=sf_ec)
    # energy: both rigid, cor 1, no damping, free vibration after a pulse
    dt = 0.005
    n_pulse, n_free = int(0.5 / dt), int((2.0 if quick else 10.0) / dt)
    for amp in (3.0, 2.0, 1.5, 1.0, 0.7, 0.5):  # the strongest pulse that rocks, no collapse
        pulse = np.zeros(n_pulse + n_free)
        pulse[:n_pulse] = amp * np.sin(np.pi * np.arange(n_pulse) / n_pulse)
        res = kernel.run(w12, pulse, dt, cor=1.0, history=True)
        if not res["collapsed"] and res["events"] > 0:
            break
    drift = _energy_drift(w12, res["history"], n_pulse + 1)
    row(f"energy (Wall 12 both rigid, COR 1, free vibration after a 0.5 s {amp:g} m s-2 "
        "half-sine pulse)", w12, pulse,
        dt, "max rel. energy change in free vibration", drift, drift <= 1e-9, cor=1.0)
    # both supports rigid: simultaneous contacts
    res = kernel.run(w12, ag_nh, dt_nh, scale=sf_nh)
    row("both supports rigid (Wall 12, Nahanni; simultaneous contacts)", w12, ag_nh, dt_nh,
        "base / crack impacts", f"{res['base_impacts']} / {res['crack_impacts']}",
        res["status"] in ("ok", "collapsed"), scale=sf_nh)
    # 1e9 N/m springs with zero diaphragm mass (Table II Wall 12 literally)
    stiff = w12.replace(bottom_stiffness=1e9, top_stiffness=1e9)
    soft = w12.replace(bottom_stiffness=5.5e5, top_stiffness=5.5e5)
    _, t_soft = timed(lambda: kernel.run(soft, ag_nh, dt_nh, scale=sf_nh))
    res, t_stiff = timed(lambda: kernel.run(stiff, ag_nh, dt_nh, scale=sf_nh))
    finite = all(math.isfinite(res[k]) for k in PEAKS)
    row("1e9 N/m springs, zero diaphragm mass (Wall 12 literally, Nahanni)", stiff, ag_nh,
        dt_nh, "time vs 5.5e5 N/m springs", round(t_stiff / t_soft, 2),
        finite and t_stiff / t_soft < 10, scale=sf_nh)
    # a scale factor bracketing collapse (bisection on the kernel)
    lo, hi = sf_ec, None
    s = sf_ec
    while hi is None and s < 64:
        s *= 2
        if kernel.run(bw, ag_ec, dt_ec, scale=s)["collapsed"]:
            hi = s
        else:
            lo = s
    if hi is not None:
        for _ in range(6 if quick else 12):
            mid = 0.5 * (lo + hi)
            if kernel.run(bw, ag_ec, dt_ec, scale=mid)["collapsed"]:
                hi = mid
            else:
                lo = mid
        below = kernel.run(bw, ag_ec, dt_ec, scale=lo)
        above = kernel.run(bw, ag_ec, dt_ec, scale=hi)
        rb = reference.run(bw, ag_ec, dt_ec, scale=lo, rtol=1e-10)
        ra = reference.run(bw, ag_ec, dt_ec, scale=hi, rtol=1e-10)
        same = (below["collapsed"], above["collapsed"]) == (rb["collapsed"], ra["collapsed"])
        row(f"collapse bracket (benchmark wall, El Centro x {lo:.6g} / x {hi:.6g})", bw,
            ag_ec, dt_ec, "collapsed below / above; reference agrees; collapse time diff [s]",
            f"{below['collapsed']} / {above['collapsed']}; {same}; "
            f"{abs(above['collapse_time'] - ra['collapse_time']):.2g}",
            (not below["collapsed"]) and above["collapsed"] and same, ref=False, scale=hi)
    else:
        rows.append({"case": "collapse bracket", "check": "no collapse up to x64",
                     "value": "-", "ok": False})
    # a long fine record: 60 s at 0.001 s (El Centro interpolated, repeated)
    ag_full, _, _ = load_record("elcentro")
    t_fine = np.arange(60001 if not quick else 10001) * 0.001
    fine = np.interp(t_fine % 53.74, np.arange(ag_full.size) * 0.02, ag_full)
    res = row(f"long fine record ({t_fine[-1]:.0f} s at 0.001 s, El Centro x 0.5)", bw, fine,
              0.001, "finished", "-", True, ref=not quick, scale=sf_ec)
    rows[-1]["value"] = res["status"]
    rows[-1]["ok"] = res["status"] in ("ok", "collapsed")
    return {"rows": rows, "reference_rtol": 1e-10}


def render(h: dict) -> list[str]:
    """The hard-cases section of the report."""
    L = ["## Hard cases (MODEL.md section 10)", "",
         f"Agreement: max relative difference of the peak outputs, kernel vs the reference at "
         f"rtol {h['reference_rtol']:g}.", ""]
    rows = []
    for r in h["rows"]:
        v = r["value"]
        rows.append([r["case"], fmt(r.get("kernel_ms")),
                     f"{r.get('events', '-')} / {r.get('reference_events', '-')}",
                     fmt(r.get("reference_s")), fmt(r.get("agreement"), 2), r["check"],
                     fmt(v) if isinstance(v, float) else v, "yes" if r["ok"] else "**no**"])
    L += table(["case", "kernel time [ms]", "events (kernel / reference)",
                "reference time [s]", "agreement", "check", "value", "ok"], rows)
    L.append("")
    return L
