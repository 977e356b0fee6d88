"""What a record file holds, checked rather than assumed: a file that is not an
acceleration (a velocity or displacement, a seismometer's counts, an instrument
calibration) is never taken for one, and a stated unit must agree with the values.

Every check gives a one-line problem; `urmx.records.readers` refuses the record with it as
an :class:`urmx.records.UnusualRecordError`, or, with ``allow_unusual=True``
(``--allow-unusual``), reads it and writes ``urmx: allow_unusual overrode: <problem>`` into
the record's processing steps, which a study archive keeps (its ``record_processing``
coordinate), so an archive says that a check was overridden.

Bounds on the motion (:data:`PGV_MAX`, :data:`PGD_MAX`), from the strong-motion literature:

- The largest peak ground velocities recorded are about 2.5-3.5 m/s: the 1999 Chi-Chi,
  Taiwan, station TCU068 (about 3 m/s; Boore 2001, "Effect of baseline corrections on
  displacements and response spectra for several recordings of the 1999 Chi-Chi, Taiwan,
  earthquake", BSSA 91(5), 1199-1211), the 1994 Northridge Rinaldi record (about 1.7 m/s)
  and near-fault records of the 2016 Kaikoura and 2023 Kahramanmaras earthquakes (up to
  about 2-3 m/s). :data:`PGV_MAX` = 5 m/s lies well above all of them.
- The largest ground displacements recorded are the permanent offsets of near-fault
  stations, up to about 8-9 m at TCU068 (Boore 2001, after baseline correction).
  :data:`PGD_MAX` = 10 m lies above it.

The numbers above are as we recall them from those papers; we could not re-read the
papers here, so the bounds are set with a margin over them rather than at them. What
urmx integrates is a simple baseline correction (the mean removed from the acceleration,
a straight line from the velocity), not the processing of those papers: it removes the
drift a raw integration of an offset or a tilted baseline has, and gives El Centro 1940
S00E a PGV of 0.333 m/s (the published 0.335 m/s). A record it finds several times beyond
the bounds is beyond them after any reasonable processing. A velocity sensor's counts read
as cm/s2 give PGV of 10^3 m/s, hundreds of times the bound.

The unit agreement check (issue 34, rule 4): a stated unit is refused, with both readings
shown, when the values imply an implausible record in it (PGA above :data:`HIGH_PGA_G`,
reached by only a handful of records, or below :data:`LOW_PGA_G`, a weak motion nobody
rocks a wall with) and a typical one (:data:`TYPICAL_PGA_G`) in the unit a factor 9.81
(g and m/s2) or 100 (m/s2 and cm/s2) away, unless the header also states the peak in
that unit (the unit is then confirmed twice; COSMOS, CDMG, K-NET headers do) or the unit
comes from an instrument response removed from counts.
"""

from __future__ import annotations

import numpy as np

#: peak ground velocity above which a record is refused [m s-1] (module docstring)
PGV_MAX = 5.0
#: peak ground displacement above which a record is refused, after a baseline correction
#: [m] (module docstring)
PGD_MAX = 10.0
#: a stated unit giving a PGA above this [g] is implausible when another unit is typical
HIGH_PGA_G = 1.5
#: a stated unit giving a PGA below this [g] is implausible when another unit is typical
LOW_PGA_G = 0.05
#: the PGA range [g] of a typical strong-motion record, for the other reading
TYPICAL_PGA_G = (0.05, 1.5)
#: units a factor 9.81 or 100 apart: stated unit -> [(other unit, values in it / in this)]
_NEIGHBOURS = {"g": [("m/s2", 1.0 / 9.80665)], "m/s2": [("g", 9.80665), ("cm/s2", 0.01)],
               "cm/s2": [("m/s2", 100.0)]}
_TO_SI = {"g": 9.80665, "m/s2": 1.0, "cm/s2": 0.01}
#: SEED instrument codes (the channel code's second letter) of sensors that do not
#: measure acceleration, and what they are
_NOT_ACCELEROMETERS = {"H": "a high-gain seismometer (velocity)",
                       "L": "a low-gain seismometer (velocity)",
                       "G": "a gravimeter", "M": "a mass-position channel",
                       "D": "a pressure sensor", "F": "a magnetometer"}
_SEED_BANDS = set("FGDCESHBMLVURPTQAO")
#: SAC IDEP values and the quantity they state
_SAC_IDEP = {6: ("IDISP", "displacement"), 7: ("IVEL", "velocity"),
             50: ("IVOLTS", "volts"), 8: ("IACC", "acceleration")}


def _detrend(x: np.ndarray, block: int = 1 << 16) -> None:
    """Remove the least-squares straight line from `x` in place (over the sample index),
    a block at a time: no temporary of the record's length."""
    n = x.size
    sx = sxt = 0.0
    for k in range(0, n, block):
        seg = x[k:k + block]
        sx += float(seg.sum())
        sxt += float(np.dot(np.arange(k, k + seg.size, dtype=float), seg))
    st, stt = n * (n - 1) / 2.0, (n - 1) * n * (2 * n - 1) / 6.0
    slope = (n * sxt - st * sx) / (n * stt - st * st)
    icpt = (sx - slope * st) / n
    for k in range(0, n, block):
        seg = x[k:k + block]
        seg -= icpt + slope * np.arange(k, k + seg.size, dtype=float)


def motion(acc: np.ndarray, dt: float) -> tuple[float, float]:
    """(PGV [m s-1], PGD [m]) of an acceleration [m s-2] with time step `dt` [s] after a
    baseline correction: the mean removed from the acceleration, a least-squares straight
    line from its integral (trapezoids); the displacement is the integral of that
    velocity. Two arrays of the record's length besides `acc` (rule 7 of the README's
    "Errors")."""
    if acc.size < 3:
        return 0.0, 0.0
    a = np.array(acc, dtype=float)
    a -= a.mean()
    # trapezoids: v[k] = dt (a_0 + ... + a_k - a_0 / 2 - a_k / 2)
    v = np.cumsum(a)
    a *= 0.5
    v -= a
    v -= a[0]
    v *= dt
    _detrend(v)
    pgv = float(np.max(np.abs(v)))
    d = np.cumsum(v, out=a)  # a is no longer needed: its buffer holds the displacement
    v *= 0.5
    d -= v
    d -= v[0]
    d *= dt
    return pgv, float(np.max(np.abs(d)))


def motion_problem(acc: np.ndarray, dt: float, reading: str) -> str | None:
    """A one-line problem when the velocity or displacement integrated from `acc` [m s-2]
    is beyond what strong motion has (:data:`PGV_MAX`, :data:`PGD_MAX`), else None;
    `reading` says how the values were read (``with unit 'cm/s2' (given)``)."""
    pgv, pgd = motion(acc, dt)
    if pgv <= PGV_MAX and pgd <= PGD_MAX:
        return None
    return (f"read {reading} it would have PGV {pgv:.3g} m/s and PGD {pgd:.3g} m (after a "
            f"baseline correction), beyond the {PGV_MAX:g} m/s and {PGD_MAX:g} m of any "
            "strong-motion record: the values are not accelerations in that unit (a "
            "seismometer's counts, a velocity, a wrong unit?)")


def unit_problem(peak: float, unit: str, source: str, confirmed: bool) -> str | None:
    """A one-line problem when the values' peak `peak` (in `unit`, stated by the file at
    `source`) gives an implausible PGA in that unit and a typical one in a unit a factor
    9.81 or 100 away (both readings shown), else None; `confirmed`: the header states the
    peak in the unit too."""
    if confirmed or unit not in _NEIGHBOURS:
        return None
    pga = peak * _TO_SI[unit] / 9.80665
    if LOW_PGA_G <= pga <= HIGH_PGA_G:
        return None
    lo, hi = TYPICAL_PGA_G
    for other, ratio in _NEIGHBOURS[unit]:
        alt = pga * ratio
        if lo <= alt <= hi and (alt > pga if pga < LOW_PGA_G else alt < pga):
            kind = "an unusually strong" if pga > HIGH_PGA_G else "a weak"
            return (f"the file states unit {unit!r} ({source}), which makes it {kind} "
                    f"record of PGA {pga:.3g} g; read as {other} its PGA would be "
                    f"{alt:.3g} g, a typical one: the header and the values disagree (is the "
                    f"unit line right?)")
    return None


def quantity_problems(stats, has_response: bool) -> list[str]:
    """What an ObsPy trace's header says it is not (an acceleration), one line each: a
    SAC ``IDEP`` of displacement, velocity or volts; a SEED channel of a sensor that is no
    accelerometer (``HH*``, ``BH*``, ``EH*``, ``SH*``, ``LH*``, ...); an instrument
    calibration (GSE ``CALIB``) other than 1; integer counts without an instrument
    response. `stats`: the trace's ``stats``; `has_response`: a response was removed."""
    out = []
    sac = stats.get("sac") or {}
    idep = sac.get("idep")
    if idep in _SAC_IDEP and idep != 8:
        name, what = _SAC_IDEP[idep]
        out.append(f"its SAC header states IDEP = {name}: it holds {what}, not acceleration "
                   "(differentiate a velocity record first, or give the acceleration file)")
    code = str(stats.get("channel") or "")
    if idep != 8 and not has_response and len(code) == 3 and code[0] in _SEED_BANDS \
            and code[1] in _NOT_ACCELEROMETERS:
        out.append(f"its channel {code} is the SEED code of {_NOT_ACCELEROMETERS[code[1]]}, "
                   f"not an accelerometer ({code[0]}N{code[2]}): give the strong-motion "
                   "channel of the station")
    calib = float(stats.get("calib", 1.0) or 1.0)
    if calib != 1.0 and not has_response:
        out.append(f"it carries an instrument calibration (CALIB {calib:g}): its values are "
                   "a sensor's counts, not an acceleration in a unit")
    return out


def counts_problem(dtype, has_response: bool) -> str | None:
    """Integer samples without an instrument response: a digitiser's counts."""
    if has_response or not np.issubdtype(dtype, np.integer):
        return None
    return (f"its samples are integers ({np.dtype(dtype).name}) and no instrument response "
            "was given: they are a digitiser's counts, not an acceleration in a unit; give "
            "the station's StationXML with response= (--response FILE.xml), or convert the "
            "record to acceleration first")
