"""The start rule and held joints of MODEL.md section 4.

A closed (or held) joint has no side of its own: when one joint opens while the other is
still closed, the closed one's side is re-set so that the pattern is family 2; family 1
needs both joints open. The records here begin with one tiny sample of one sign and then
the other sign at full strength, so the provisional sides (against the first non-zero
sample) are wrong and a joint opens against its provisional side: the case where the old
rule counted family-1 time that the kinematics of a wall on two rigid supports rule out.
"""

from __future__ import annotations

import numpy as np
import pytest

from urmx import kernel, reference

from .fixtures.random_cases import random_wall, reversing_record
from .kernel_helpers import SUPPORTS, worst_peak_difference

OPENINGS = (kernel.EV_BASE_OPEN, kernel.EV_CRACK_OPEN)


def _family(pattern: float) -> int:
    return int(pattern) // 10


def _side(pattern: float) -> int:
    """Side of the base pivot s of a pattern code (second digit 1: +1, 2: -1)."""
    return 1 if int(pattern) % 10 == 1 else -1


def _provisional(ag: np.ndarray) -> tuple[int, int]:
    """(s, c): provisional sides, against the first non-zero ground acceleration."""
    s = -1 if ag[np.flatnonzero(ag)[0]] > 0 else 1
    return s, -s


@pytest.fixture(scope="module")
def rigid_cases():
    """200 random walls on two rigid supports under 200 reversing records (seeded)."""
    rng = np.random.default_rng(20261123)
    return [(random_wall(rng), *reversing_record(rng)) for _ in range(200)]


@pytest.fixture(scope="module")
def rigid_results(rigid_cases):
    return [kernel.run(w, ag, dt, max_log=50) for w, ag, dt in rigid_cases]


def test_both_supports_rigid_never_count_family_1(rigid_cases, rigid_results):
    """theta2 = -(a1/a2) theta1: the crack always opens first, and the kinematics allow
    family 2 only. Every one of the 200 records opens the crack against its provisional
    side (the old rule then counted family-1 time until the base opened: 200 of these 200
    walls reported unfavourable_fraction > 0 with the kernel before this rule)."""
    against = 0
    for (_, ag, _), res in zip(rigid_cases, rigid_results, strict=True):
        assert res["status"] in ("ok", "collapsed")
        assert res["unfavourable_fraction"] == 0.0
        log = res["event_log"]
        assert log.shape[0] >= 2
        first = log[0]
        assert first[1] == kernel.EV_CRACK_OPEN
        against += first[2] != _provisional(ag)[1]
        assert np.all(log[:, 3] // 10 == 2)  # every pattern after every event: family 2
    assert against == 200


def test_reference_agrees_on_the_random_rigid_walls(rigid_cases, rigid_results):
    """The reference solver shares the event logic (the start rule included): every peak
    of every one of the 200 walls within 1e-8."""
    worst = 0.0
    for (w, ag, dt), res in zip(rigid_cases, rigid_results, strict=True):
        ref = reference.run(w, ag, dt, rtol=1e-11)
        assert ref["unfavourable_fraction"] == 0.0
        assert ref["events"] == res["events"]
        worst = max(worst, worst_peak_difference(res, ref)[0])
    assert worst < 1e-8


def test_the_check_fails_with_the_old_rule():
    """The same walls with the other joint's side left provisional at an opening (the
    rule before) would spend time in family 1: the family after the first opening would
    be 1, because the crack opened against its provisional side while s kept its own."""
    rng = np.random.default_rng(20261123)
    w, ag, dt = random_wall(rng), *reversing_record(rng)
    s, c = _provisional(ag)
    res = kernel.run(w, ag, dt, max_log=5)
    opened = int(res["event_log"][0, 2])
    assert opened == -c  # against the provisional side
    old_family = 1 if s == opened else 2
    assert old_family == 1 and _family(res["event_log"][0, 3]) == 2


@pytest.mark.parametrize("support", list(SUPPORTS))
def test_sides_and_family_at_both_openings(support):
    """For every support case: the first joint opens against its provisional side; the
    closed one's side is re-set so that the pattern is family 2; at the second opening
    that joint takes the side of its own g (the logged target) and the family follows from
    the two sides."""
    wall = SUPPORTS[support]
    rng = np.random.default_rng(7)
    ag, dt = reversing_record(rng)
    prov = dict(zip(OPENINGS, _provisional(ag), strict=True))
    res = kernel.run(wall, ag, dt, max_log=40)
    log = res["event_log"]
    opens = log[np.isin(log[:, 1], OPENINGS)]
    assert len(opens) == 2 and opens[0, 1] != opens[1, 1]
    (k1, t1, p1), (k2, t2, p2) = opens[0, 1:], opens[1, 1:]
    assert t1 == -prov[k1]  # the old failure mode: against the provisional side
    # first opening: family 2, the closed joint's side re-set to match
    assert _family(p1) == 2
    s1 = t1 if k1 == kernel.EV_BASE_OPEN else -t1
    assert _side(p1) == s1
    # second opening: the joint takes its own side; the family follows from (s, c)
    s, c = (t2, -s1) if k2 == kernel.EV_BASE_OPEN else (s1, t2)
    assert _side(p2) == s and _family(p2) == (1 if s == c else 2)
    if support == "rigid/rigid":
        assert res["unfavourable_fraction"] == 0.0
