"""Plain number columns: one acceleration per line (SLAMMER), several values per line, a
(time, acceleration) pair per line, or an ordinary CSV file with one header row of names.

The file is parsed in blocks of about a megabyte of text, so reading N samples holds the
file's bytes, the samples (8N bytes) and, per line, its count of values and its number
(6 bytes), never a Python object per value (README "Errors", rule 7). A header row names
the columns: a time column (time, t; [s], (s), _s or _ms) and acceleration columns (acc,
accel, acceleration, a; a unit in brackets or after an underscore: acc_g, acc [m/s2]); a
column of another name is asked about, never guessed; several acceleration columns are one
channel each (named by the header). Comments may state dt, a sampling rate (read as its
step), the unit and the point count.
"""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import numpy as np

from ..errors import (
    MissingTimeStepError,
    NonFiniteError,
    RecordError,
    RecordUnitError,
    TruncatedRecordError,
)
from .common import (
    DECIMAL_COMMA,
    FLOAT,
    UNIT_FACTORS,
    Channel,
    decode,
    find_groups,
    is_float,
    is_numeric_line,
    not_a_number,
    number_or_none,
    unit_name,
)

# statements of a time step in a comment line: the keyword, then an optional "=", ":",
# "is" or "of", then the value (which must then be a number)
_DT_STATEMENT = re.compile(
    r"\b(?:dt|delta|time[ -]?step|timestep|sampling interval|sample interval|spacing of)\b"
    r"\s*(?P<sep>=|:|\bis\b|\bof\b)?\s*(?P<value>[^\s;]*)\s*(?P<unit>\w*)", re.I)
_UNIT_STATEMENT = re.compile(r"\bunits?\b\s*(?P<sep>=|:|\bare\b|\bis\b|\bin\b|\bof\b)?"
                             r"(?P<rest>.*)", re.I)
_TIME_UNITS = {"": 1.0, "s": 1.0, "sec": 1.0, "secs": 1.0, "second": 1.0, "seconds": 1.0,
               "ms": 1e-3, "msec": 1e-3, "millisecond": 1e-3, "milliseconds": 1e-3}


def _comment_dt(path: Path, lineno: int, comment: str) -> tuple[float, str] | None:
    """The time step [s] a comment line states, with where it was said, or None; a
    statement whose value is not a number is refused (never read as part of one)."""
    found = []
    for m in _DT_STATEMENT.finditer(comment):
        value, unit = m.group("value").rstrip(",;)"), m.group("unit").lower()
        if not value and not m.group("sep"):
            continue
        glued = re.fullmatch(rf"({FLOAT.pattern})([a-zA-Z]+)", value)
        if glued and glued.group(2).lower() in _TIME_UNITS:
            value, unit = glued.group(1), glued.group(2).lower()
        if not value[:1].isdigit() and value[:1] not in "+-." and not m.group("sep"):
            continue  # "time step computed later": not a statement of its value
        number = number_or_none(value)
        if number is None:
            raise MissingTimeStepError(
                path, f"comment line {lineno} {comment!r} states a time step that cannot be "
                f"read: {not_a_number(value)}; correct the comment, or remove it and pass "
                "dt= (--dt)")
        factor = _TIME_UNITS.get(unit, 1.0)
        found.append((number * factor, f"comment line {lineno}: {comment!r}"))
    if len({f[0] for f in found}) > 1:
        raise MissingTimeStepError(path, f"comment line {lineno} {comment!r} states two time "
                                   "steps")
    return found[0] if found else None


def _comment_unit(path: Path, lineno: int, comment: str) -> tuple[str, str] | None:
    """The unit a comment line states (``# units: g``, ``The units are (g)``), or None;
    a statement naming no known unit is refused."""
    m = _UNIT_STATEMENT.search(comment)
    if not m:
        return None
    for tok in m.group("rest").replace("(", " ").replace(")", " ").split():
        name = unit_name(tok)
        if name is not None and name in UNIT_FACTORS:
            return name, f"comment line {lineno}: {comment!r}"
    if m.group("sep") or m.group("rest").strip(" :=") == "":
        raise RecordUnitError(path, f"comment line {lineno} {comment!r} states no unit urmx "
                              f"knows ({', '.join(UNIT_FACTORS)}, gal = cm/s2); correct the "
                              "comment or remove it and pass unit= (--unit)")
    return None


#: bytes of text parsed at a time
_BLOCK = 1 << 18

_TIME_NAME = re.compile(r"^(?:time|t)(?:[ _]*[\[(]?\s*(?P<u>s|sec|ms)\s*[\])]?)?$", re.I)
_ACC_NAME = re.compile(r"^(?:ground[ _]?acc(?:eleration)?|acceleration|accel|acc|ag|a)"
                       r"(?P<rest>.*)$", re.I)
_RATE_STATEMENT = re.compile(
    r"\b(?:sampling rate|sample rate|sampling frequency|samples per second|sps)\b"
    r"\s*(?P<sep>=|:|\bis\b|\bof\b)?\s*(?P<value>[^\s;]*)\s*(?P<unit>\w*)", re.I)


def _blocks(raw: bytes, encoding: str):
    """(number of the first line, lines) of the decoded text, a block at a time; blocks
    end at a line break, so line numbers are those of the whole text."""
    if encoding.startswith("utf-16"):  # rare: decode at once
        yield 1, decode(raw, encoding).splitlines()
        return
    start, lineno = 0, 1
    if encoding == "utf-8-sig":
        start = 3
        encoding = "latin-1"
    n = len(raw)
    while start < n:
        end = raw.find(b"\n", min(start + _BLOCK, n))
        end = n if end < 0 else end + 1
        lines = raw[start:end].decode(encoding).splitlines()
        yield lineno, lines
        lineno += len(lines)
        start = end


def header_names(line: str) -> list[str] | None:
    """The column names of a header row (comma-, semicolon- or tab-separated, or separated
    by spaces when no name holds one), or None when `line` is not a row of names."""
    s = line.strip()
    if not s or is_numeric_line(s) or not re.match(r"[A-Za-z\"']", s):
        return None
    sep = "," if "," in s else ";" if ";" in s else "\t" if "\t" in s else None
    names = [n.strip().strip("\"'").strip() for n in (s.split(sep) if sep else s.split())]
    if not names or any(not n or not re.match(r"[A-Za-z]", n) for n in names):
        return None
    return names


def _column_kind(name: str) -> tuple[str, str | None] | None:
    """("time", unit) or ("acc", unit) of a column name, or None when the name says
    neither; a unit the name holds is returned as urmx names it (None: none)."""
    m = _TIME_NAME.match(name.strip())
    if m:
        return "time", (m.group("u") or "s").lower().replace("sec", "s")
    m = _ACC_NAME.match(name.strip())
    if not m:
        return None
    rest = m.group("rest").strip()
    if not rest:
        return "acc", None
    inner = re.fullmatch(r"[\[(]\s*(.+?)\s*[\])]", rest) or re.fullmatch(r"[_ ]+(.+)", rest)
    if inner:
        unit = unit_name(inner.group(1))
        if unit is not None:
            return "acc", unit
        # acc_x, acc_ns_g: a component label, perhaps followed by a unit
        tail = re.fullmatch(r"(?:[A-Za-z0-9]+[_ ]+)?[\[(]?\s*(.+?)\s*[\])]?", inner.group(1))
        unit = unit_name(tail.group(1)) if tail else None
        if unit is not None or re.fullmatch(r"[A-Za-z0-9]+", inner.group(1)):
            return "acc", unit
    return None


def _comment_rate(path: Path, lineno: int, comment: str) -> tuple[float, str] | None:
    """The time step [s] a comment stating a sampling rate gives (``# sampling rate = 100
    Hz`` -> 0.01 s), with where it was said, or None; a rate that is not a positive number
    is refused with the file, the line and the comment."""
    m = _RATE_STATEMENT.search(comment)
    if not m or (not m.group("value") and not m.group("sep")):
        return None
    value = m.group("value").rstrip(",;)")
    glued = re.fullmatch(r"([-+.\d][\d.eE+-]*)(hz|sps)", value, re.I)
    if glued:
        value = glued.group(1)
    rate = number_or_none(value)
    if rate is None or not np.isfinite(rate) or rate <= 0:
        raise MissingTimeStepError(path, f"comment line {lineno} {comment!r} states a sampling "
                                   f"rate that is not a positive number ({value!r}); correct "
                                   "the comment, or remove it and pass dt= (--dt)")
    return 1.0 / rate, f"comment line {lineno}: {comment!r}"


def parse_columns(path: Path, raw: bytes, encoding: str) -> list[Channel]:
    """Plain number columns, a block of text at a time (module docstring)."""
    comments, names, head_line = [], None, None
    vals, widths, linenos, first = [], [], [], True
    for lineno, lines in _blocks(raw, encoding):
        if first:
            _decimal_commas(path, lines, lineno)
            first = False
        toks, w, nos = [], [], []
        for i, ln in enumerate(lines, lineno):
            s = ln.strip()
            if not s:
                continue
            if s[0] == "#":
                comments.append((i, s))
                continue
            if names is None and not w and not widths:
                names = header_names(s)
                if names is not None:
                    head_line = i
                    continue
            r = s.replace(",", " ").replace(";", " ").split()
            toks += r
            w.append(len(r))
            nos.append(i)
        if toks:
            vals.append(_block_values(path, toks, w, nos))
            widths.append(np.array(w, dtype=np.int16))
            linenos.append(np.array(nos, dtype=np.int32))
    values = np.concatenate(vals) if len(vals) != 1 else vals[0]
    del vals
    w = np.concatenate(widths) if widths else np.empty(0, dtype=np.int16)
    nos = np.concatenate(linenos) if linenos else np.empty(0, dtype=np.int32)
    if values.size == 1:
        raise TruncatedRecordError(path, f"the file holds a single number ({values[0]:g}), not "
                                   "an acceleration history: is it the right file?")
    ch = Channel(values, None, None, unit_from_file=False, note="plain numbers")
    _column_comments(path, ch, comments)
    if names is not None:
        return _headed(path, ch, names, head_line, w, nos)
    if w.size > 2 and bool((w == 2).all()) and _time_like(np.diff(values[0::2])):
        _time_column(path, ch, values[0::2], values[1::2], nos)
        ch.note = "plain numbers, (time, acceleration) columns"
    elif w.size > 2 and w.min() == w.max() >= 3 and \
            bool(np.all(np.diff(values[0::int(w[0])]) > 0)):
        k = int(w[0])
        raise RecordError(path, f"every line holds {k} numbers and the first column increases "
                          f"like a time: the columns are ambiguous (a time and {k - 1} "
                          "accelerations?), and urmx never guesses between acceleration "
                          "columns; give the file a header row naming them (e.g. time,acc_x_g,"
                          "acc_y_g) and choose one with channel= (--channel), or keep one "
                          "acceleration column")
    return [ch]


def _decimal_commas(path: Path, lines: list[str], lineno: int) -> None:
    """Refuse numbers written with a decimal comma (``0,005``), which a comma-separated
    reading would split in two: all of the first 50 data lines look like one."""
    body = list(itertools.islice(((i, s.strip()) for i, s in enumerate(lines, lineno)
                                  if s.strip() and not s.strip().startswith("#")), 50))
    if body and header_names(body[0][1]) is not None:
        body = body[1:]
    if body and all(DECIMAL_COMMA.fullmatch(s) for _, s in body):
        raise RecordError(path, f"line {body[0][0]}: {not_a_number(body[0][1])}")


def _block_values(path: Path, toks: list[str], w: list[int], nos: list[int]) -> np.ndarray:
    """The numbers of a block's tokens; a token that is not one is named with its line."""
    try:
        return np.array(toks, dtype=float)
    except ValueError:
        k = 0
        for n, i in zip(w, nos, strict=True):
            bad = next((tk for tk in toks[k:k + n] if not is_float(tk)), None)
            if bad is not None:
                raise RecordError(path, f"line {i} is not numbers: {' '.join(toks[k:k + n])[:80]!r}"
                                  f" ({not_a_number(bad)})") from None
            k += n
        raise


def _column_comments(path: Path, ch: Channel, comments: list[tuple[int, str]]) -> None:
    """The time step (or sampling rate), unit and point count the comment lines state."""
    dts = [d for i, c in comments for d in (_comment_dt(path, i, c), _comment_rate(path, i, c))
           if d]
    units = [u for u in (_comment_unit(path, i, c) for i, c in comments) if u]
    for found, what in ((dts, "time steps"), (units, "units")):
        if len({f[0] for f in found}) > 1:
            raise (MissingTimeStepError if what == "time steps" else RecordUnitError)(
                path, f"comments state two {what}: {found[0][1]} and {found[1][1]}")
    if dts:
        ch.dt, ch.extra["dt_source"] = dts[0]
    if units:
        ch.unit, ch.extra["unit_source"] = units[0]
        ch.unit_from_file = True
    n_head = find_groups(r"(\d+)\s+points", "\n".join(c for _, c in comments))
    if n_head:
        ch.extra["npts_comment"] = int(n_head[0])


def _time_column(path: Path, ch: Channel, t: np.ndarray, a: np.ndarray,
                 nos: np.ndarray) -> None:
    """Make `t` [s] the channel's sample times and `a` its values; the times must be
    finite and increase strictly (the first bad one is named with its line)."""
    if not np.isfinite(t).all():
        k = int(np.argmax(~np.isfinite(t)))
        raise NonFiniteError(path, f"line {nos[k]}: time {t[k]} is not finite")
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.argmax(steps <= 0))
        raise RecordError(
            path, f"line {nos[k + 1]}: time {t[k + 1]:g} s does not increase "
            f"(line {nos[k]} has {t[k]:g} s); the first column of a (time, "
            "acceleration) file must increase strictly")
    ch.times, ch.values = t, a


def _headed(path: Path, ch: Channel, names: list[str], head_line: int, w: np.ndarray,
            nos: np.ndarray) -> list[Channel]:
    """The channels of a file with a header row: one per acceleration column, with the
    unit its name states, the time column's times (module docstring)."""
    k = len(names)
    off = np.flatnonzero(w != k)
    if off.size:
        raise RecordError(path, f"line {nos[off[0]]} holds {w[off[0]]} values but the header "
                          f"row (line {head_line}) names {k} columns: {', '.join(names)}")
    kinds = [_column_kind(n) for n in names]
    unknown = [n for n, kd in zip(names, kinds, strict=True) if kd is None]
    if unknown:
        raise RecordError(path, f"the header row (line {head_line}) names a column "
                          f"{unknown[0]!r} that is neither time nor acceleration: name it time "
                          "or t (time [s], t_ms) or acc, acceleration (with its unit: acc_g, "
                          "acc [m/s2], acceleration (cm/s2)), or remove the column")
    times = [i for i, kd in enumerate(kinds) if kd[0] == "time"]
    accs = [i for i, kd in enumerate(kinds) if kd[0] == "acc"]
    if len(times) > 1 or not accs:
        what = "two time columns" if len(times) > 1 else "no acceleration column"
        raise RecordError(path, f"the header row (line {head_line}) names {what}: "
                          f"{', '.join(names)}")
    table = ch.values.reshape(-1, k)
    out = []
    for i in accs:
        c = Channel(np.ascontiguousarray(table[:, i]), ch.unit, ch.dt,
                    channel=names[i] if len(accs) > 1 else "",
                    unit_from_file=ch.unit_from_file, extra=dict(ch.extra),
                    note=f"columns named in a header row: {', '.join(names)}")
        unit = kinds[i][1]
        if unit is not None:
            if ch.unit is not None and ch.unit != unit:
                raise RecordUnitError(path, f"column {names[i]!r} states unit {unit!r} but "
                                      f"{ch.extra['unit_source']} states {ch.unit!r}")
            c.unit, c.unit_from_file = unit, True
            c.extra["unit_source"] = f"column name {names[i]!r}, line {head_line}"
        if times:
            j = times[0]
            scale = 1e-3 if kinds[j][1] == "ms" else 1.0
            _time_column(path, c, table[:, j] * scale, c.values, nos)
        out.append(c)
    return out


def _time_like(steps: np.ndarray) -> bool:
    """Whether a first column with these differences is a time column: it increases
    throughout (however unevenly), or nearly all its steps (a duplicate or reversal aside)
    lie within half of the median step, which is not zero; acceleration values in pairs
    go up and down instead."""
    with np.errstate(invalid="ignore"):
        if np.all(steps > 0):
            return True
        med = float(np.median(steps))
        return med != 0.0 and bool(np.mean(np.abs(steps - med) <= 0.5 * abs(med)) >= 0.9)
