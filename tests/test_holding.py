"""Held joints and contact functions that start at zero (MODEL.md section 4, "Details of
holding", and section 11).

After an event a contact function can sit at zero and move away (the joint that has just
impacted, or one released from a hold, whose gap, rate and acceleration are all zero);
it may come back and cross zero again within the same sub-step, and comparing the signs
at the sub-step's ends misses an even number of crossings. The exact kernel searches the
series of such a sub-step for its first fall; the reference samples its dense output
(geometrically near the start of a piece). The constructed cases below lose crossings
with the sign test at the ends (the kernel at 8b38483); the randomised comparison covers
the four support cases and both impact laws with holds counted.
"""

from __future__ import annotations

import math
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

import numpy as np
import pytest

from urmx import kernel, reference

from .fixtures import held_cases
from .fixtures.random_cases import SUPPORTS, held_case
from .kernel_helpers import SUPPORTS as C9_SUPPORTS
from .kernel_helpers import differences, elcentro

TOL, TOL_CHAOTIC = 1e-6, 1e-3
N_RANDOM = 200  # seeded random cases of the comparison
SEED = 20261124


def _agree(a: dict, b: dict, tol: float = TOL) -> None:
    d = differences(a, b)
    worst = max(d, key=d.get)
    assert d[worst] <= tol, (worst, a[worst] if worst != "status" else a["status"],
                             b[worst] if worst != "status" else b["status"])


def test_released_joint_that_comes_back_within_a_substep_is_found():
    """A rigid base and a flexible top, scale law: the base joint is held at an impact at
    1.04697 s and released at once; it moves off and comes back 1.45 ms later, inside the
    same 20 ms sub-step (the wall needs one sub-step a record step). The sign test at the
    sub-step's ends lost that impact and the chatter after it: 24 events and 2 holds
    instead of 33 and 6, unfavourable_fraction 0.132 instead of 0.0185."""
    w, ag, dt, cor = (held_cases.RETURN_WALL, held_cases.RETURN_RECORD, held_cases.RETURN_DT,
                      held_cases.RETURN_COR)
    res = kernel.run(w, ag, dt, cor=cor, tail=0.74, max_log=100)
    log = res["event_log"]
    i = int(np.flatnonzero(log[:, 1] == kernel.EV_BASE_RELEASE)[0])
    t_release, t_back = log[i, 0], log[i + 1, 0]
    assert t_release == pytest.approx(1.0469678607, abs=1e-9)
    assert log[i - 1, 0] == t_release and log[i - 1, 1] == kernel.EV_BASE_IMPACT  # held at once
    assert log[i + 1, 1] == kernel.EV_BASE_IMPACT
    assert t_back - t_release == pytest.approx(1.44756e-3, rel=1e-4)
    tab = kernel.tables(w, dt)
    h = dt / int(tab.nsub[tab.ready].max())
    assert math.floor(t_release / h) == math.floor(t_back / h)  # one sub-step
    assert (res["events"], res["holds"], res["base_impacts"]) == (33, 6, 12)
    assert res["unfavourable_fraction"] == pytest.approx(0.0185011, rel=1e-5)
    _agree(res, reference.run(w, ag, dt, cor=cor, tail=0.74))


def test_c9_chatter_under_the_contact_law_is_found():
    """C9 on a rigid base under El Centro x 0.6 with the contact law: after the crack joint
    is released near 5.5353 s its gap crosses zero an even number of times within one
    20 ms sub-step; the six chatter impacts between 5.5439 s and 5.5471 s were lost
    (124 crack impacts instead of 130, unfavourable_fraction 0.2708 instead of 0.2697).
    The reference (which also fired a contact function sitting exactly at zero again at
    once, 31 crack impacts at one instant near 3.7576 s, before it searched for first
    falls) agrees. (Pinned again for t_rest = 0.01 s, issue 32: with v_rest = g_open/dt,
    dt = 0.02 s, it had 130 crack impacts and unfavourable_fraction 0.2696855, which
    t_rest = 0.02 s still gives.)"""
    wall = C9_SUPPORTS["rigid/flex"]
    ag, dt = elcentro()
    res = kernel.run(wall, ag[:301], dt, scale=0.6, impact="contact", max_log=3000)
    log = res["event_log"]
    crack = log[log[:, 1] == kernel.EV_CRACK_IMPACT, 0]
    assert np.count_nonzero((crack > 5.5438) & (crack < 5.5472)) == 6
    assert (res["crack_impacts"], res["base_impacts"], res["holds"]) == (132, 15, 1)
    assert res["unfavourable_fraction"] == pytest.approx(0.2696874, rel=1e-6)
    old = kernel.run(wall, ag[:301], dt, scale=0.6, impact="contact", t_rest=dt)
    assert (old["crack_impacts"], old["holds"]) == (130, 1)
    assert old["unfavourable_fraction"] == pytest.approx(0.2696855, rel=1e-6)
    ref = reference.run(wall, ag[:301], dt, scale=0.6, impact="contact", rtol=1e-11)
    _agree(res, ref)


def test_both_sides_qualifying_release_the_current_familys_side():
    """A rigid base and a flexible top: the crack joint is held at an impact at 2.0296 s
    (pattern 12, family 1) and both sides qualify for its release at once. The side whose
    family is the current one, its own (-1), opens: the pattern stays 12 (the side tried
    first before, +1, gave 22), and the reference, which shares the rule, agrees."""
    w, ag, dt, cor = (held_cases.TIE_WALL, held_cases.TIE_RECORD, held_cases.TIE_DT,
                      held_cases.TIE_COR)
    res = kernel.run(w, ag, dt, cor=cor, tail=1.6, max_log=100)
    log = res["event_log"]
    i = int(np.flatnonzero(np.isclose(log[:, 0], 2.02960045, atol=1e-8)
                           & (log[:, 1] == kernel.EV_CRACK_RELEASE))[0])
    assert log[i - 1, 1] == kernel.EV_CRACK_IMPACT and log[i - 1, 0] == log[i, 0]
    assert log[i - 1, 3] == 12 and log[i, 2] == -1 and log[i, 3] == 12
    _agree(res, reference.run(w, ag, dt, cor=cor, tail=1.6))


REF_TIGHT = 1e-12  # rtol of the reference run that checks its own convergence


def _compare(case: dict) -> tuple:
    """(support, impact law, holds, the sensitivity of the case: per output, the largest of
    the kernel's own difference when the scale factor moves by one unit in the last place
    and, where kernel and reference differ by more than TOL, the reference's own difference
    between its tolerance and REF_TIGHT; differences kernel - reference) of one random
    case."""
    support = case.pop("support")
    a = kernel.run(**case)
    own = differences(a, kernel.run(**case, scale=np.nextafter(1.0, 2.0)))
    ref = reference.run(**case)
    diff = differences(a, ref)
    if max(diff.values()) > TOL:
        yard = differences(ref, reference.run(**case, rtol=REF_TIGHT))
        own = {k: max(own[k], yard[k]) for k in own}
    return support, case["impact"], a["holds"], own, diff


@pytest.mark.slow
def test_exact_agrees_with_reference_on_random_held_cases():
    """200 seeded random walls on the four support cases under both impact laws, each a
    short decaying pulse and a 2 s free-vibration tail at COR 0.3-0.8 (chatter that ends in
    held joints): every output of the exact kernel within 1e-6 of the reference's. A case
    is chaotic when a change of its scale factor by one unit in the last place moves the
    kernel's own outputs by more than 1e-6; its outputs must agree within 1e-3, or within
    that own change where it is larger (the hold decisions of a chaotic chatter flip on
    the last bit: counts of impacts and holds move by several per cent). At least 40 cases
    hold joints, some on every support case and law. Two processes (the reference takes
    about 0.3 s a case).

    Since event times are polished to the last ulps (issue 32) the kernel's 1-ulp change
    no longer reveals every chaotic chatter: in one case (a flexible base and a rigid top,
    scale law, 47 holds) perturbations of event times grow about 1e4-fold in 20 impacts,
    the kernel's 1-ulp change is 3.5e-9, yet the reference at its tolerance and at 1e-12
    disagrees with itself by 20 % (unfavourable_fraction; 50 and 41 holds). Where kernel
    and reference differ by more than 1e-6 the reference's own change between the two
    tolerances is therefore part of the case's sensitivity too: a case whose yardstick is
    not converged to 1e-6 is screened as chaotic."""
    rng = np.random.default_rng(SEED)
    cases = [held_case(rng) for _ in range(N_RANDOM)]
    with ProcessPoolExecutor(2, mp_context=get_context("spawn")) as pool:
        rows = list(pool.map(_compare, cases, chunksize=10))
    held = [r for r in rows if r[2] > 0]
    chaotic = [r for r in rows if max(r[3].values()) > TOL]
    beyond = [r for r in chaotic if max(r[4].values()) > TOL_CHAOTIC]
    bad = [(r[0], r[1], k, r[4][k], r[3][k]) for r in rows for k in r[4]
           if r[4][k] > (max(TOL_CHAOTIC, r[3][k]) if r in chaotic else TOL)]
    print(f"\n{len(rows)} random cases, {len(held)} with holds ({sum(r[2] for r in rows)} "
          f"holds), {len(chaotic)} screened chaotic ({len(beyond)} beyond 1e-3, within "
          f"their own one-ulp change); worst difference of the others "
          f"{max(max(r[4].values()) for r in rows if r not in chaotic):.1e}")
    assert len(rows) >= 200 and len(held) >= 40
    assert {(r[0], r[1]) for r in held} == {(s, law) for s in SUPPORTS
                                            for law in ("scale", "contact")}
    assert not bad, bad
