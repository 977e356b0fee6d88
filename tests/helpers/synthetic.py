"""Small synthetic records of the plug-in kind tests, each set under its own name (the values
the tests' expected numbers rest on); every set is sampled at `DT`.

- `TOY_ACC`, `TOY_SCALE`: "quake" (a pulse +2.0, -1.0 m s-2) and "shake" (-3.0, +1.0),
  50 samples each (`tests/test_kinds.py`, the toy kind);
- `SWEEP_ACC`, `SWEEP_SCALE`: the toy "quake" alone (`tests/test_cells.py`, the sweep kind);
- `PULSE`, `PULSE_SCALE`: a 2 Hz sine of 3.0 m s-2, 150 samples (`tests/test_cells.py`, the
  real kernel);
- `SAMPLING_ACC`, `SAMPLING_SCALE`: two decaying sines of 4 s, "quake" 2 Hz 3.0 m s-2 and
  "shake" 1.2 Hz 2.5 m s-2 (`tests/test_sampling.py`)."""

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
