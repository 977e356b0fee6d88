"""Small synthetic records of the plug-in kind tests, each set under its own name (the values
the tests' expected numbers rest on); every set is sampled at `DT`.

- `TOY_ACC`, `TOY_SCALE`: "quake" (a pulse +2.0, -1.0 m s-2) and "shake" (-3.0, +1.0),
  50 samples each (`tests/test_kinds.py`, the toy kind);
- `SWEEP_ACC`, `SWEEP_SCALE`: the toy "quake" alone (`tests/test_cells.py`, the sweep kind);
- `PULSE`, `PULSE_SCALE`: a 2 Hz sine of 3.0 m s-2, 150 samples (`tests/test_cells.py`, the
  real kernel);
- `SAMPLING_ACC`, `SAMPLING_SCALE`: two decaying sines of 4 s, "quake" 2 Hz 3.0 m s-2 and
  "shake" 1.2 Hz 2.5 m s-2 (`tests/test_sampling.py`, `tests/test_kinds.py`).

And the text of synthetic PEER NGA AT2 record files, from one template: `at2_text` (four
header lines, then data lines), `AT2_ROWS` (its default data: eight values in g) and
`at2_rows` (data lines from numbers). The tests assert exact messages, digests and values
on these files, so each caller states what it changes and the rest stays byte for byte
(`tests/test_bad_inputs.py`, `tests/test_readers.py`, `tests/test_records.py`,
`tests/test_reliability.py`, `tests.helpers.own_records.write_at2`)."""

from __future__ import annotations

import numpy as np

DT = 0.01

TOY_ACC = {"quake": np.r_[np.zeros(5), 2.0, -1.0, np.zeros(43)],
           "shake": np.r_[np.zeros(5), -3.0, 1.0, np.zeros(43)]}
TOY_SCALE = {"quake": 1.0, "shake": 1.0}

SWEEP_ACC = {"quake": np.r_[np.zeros(5), 2.0, -1.0, np.zeros(43)]}
SWEEP_SCALE = {"quake": 1.0}

PULSE = {"pulse": 3.0 * np.sin(2 * np.pi * 2.0 * np.arange(150) * 0.01)}
PULSE_SCALE = {"pulse": 1.0}

_t = np.arange(400) * DT
SAMPLING_ACC = {"quake": 3.0 * np.sin(2 * np.pi * 2.0 * _t) * np.exp(-0.3 * _t),
                "shake": 2.5 * np.sin(2 * np.pi * 1.2 * _t) * np.exp(-0.2 * _t)}
SAMPLING_SCALE = {"quake": 1.0, "shake": 1.0}

AT2_TITLE = "Test, 1/1/2000, Somewhere, 90"
AT2_ROWS = "  1.0E-02  2.0E-02  3.0E-02 -2.0E-02 -1.0E-02\n  0.0E+00  1.0E-02  0.0E+00\n"


def at2_rows(values, fmt: str = ".7E", sep: str = "  ") -> str:
    """`values` as AT2 data lines: five a line, each written with `fmt`, joined by `sep`."""
    return "\n".join(sep.join(format(v, fmt) for v in values[i:i + 5])
                     for i in range(0, len(values), 5)) + "\n"


def at2_text(rows: str = AT2_ROWS, *, title: str = AT2_TITLE, unit: str = "G", npts=8,
             dt: str = ".0100", npts_line: str | None = None) -> str:
    """A PEER NGA AT2 record's text: the database line, `title`, the units line (``UNITS OF
    unit``), the line ``NPTS=  npts, DT=   dt SEC`` (or `npts_line` whole), then `rows` as
    they are. The defaults: eight values in g at dt 0.01 s."""
    line = f"NPTS=  {npts}, DT=   {dt} SEC" if npts_line is None else npts_line
    return (f"PEER NGA STRONG MOTION DATABASE RECORD\n{title}\n"
            f"ACCELERATION TIME SERIES IN UNITS OF {unit}\n{line}\n{rows}")


def knet_text(counts, *, scale: tuple[int, int] = (3920, 6182761), freq_hz: int = 100,
              direction: str = "E-W", max_acc_gal: float = 0.0) -> str:
    """A K-NET ASCII record's text (NIED's format: 17 header lines, then the integer counts
    eight a line), with the fields ObsPy's K-NET reader and urmx read set from the
    arguments and made-up station and event fields. The K-NET and KiK-net samples are not
    shipped (NIED's data policy forbids passing their files on), so a clone tests its
    reader on this."""
    counts = [int(c) for c in counts]
    header = [("Origin Time", "2000/01/01 00:00:00"), ("Lat.", "35.0"), ("Long.", "139.0"),
              ("Depth. (km)", "10"), ("Mag.", "5.0"), ("Station Code", "SYN001"),
              ("Station Lat.", "35.1"), ("Station Long.", "139.1"),
              ("Station Height(m)", "10"), ("Record Time", "2000/01/01 00:00:05"),
              ("Sampling Freq(Hz)", f"{freq_hz}Hz"),
              ("Duration Time(s)", str(len(counts) // freq_hz)), ("Dir.", direction),
              ("Scale Factor", f"{scale[0]}(gal)/{scale[1]}"),
              ("Max. Acc. (gal)", f"{max_acc_gal:.3f}"),
              ("Last Correction", "2000/01/01 00:00:05"), ("Memo.", "")]
    lines = [f"{name:<18}{value}" for name, value in header]
    lines += ["".join(f"{c:>9}" for c in counts[i:i + 8]) + " "
              for i in range(0, len(counts), 8)]
    return "\n".join(lines) + "\n"
