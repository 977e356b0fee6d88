"""What several test modules share, kept once (issue 35; ARCHITECTURE.md): synthetic records,
stand-in kernels and study snippets, one module per study they serve, and small helpers. These
are not test modules: test modules import from here (and from ``tests/fixtures/``) and never
from one another (``tests/test_structure.py``). Fixtures that serve these records or make
record folders are in ``tests/conftest.py``.

- `kernel`: walls, real records and differences for the kernel's physics tests
  (test_kernel, test_simulate);
- `grid_study`: the small grid study, its two records and `fake_kernel` (test_study,
  test_cells, test_study_file; `tests.fixtures.pinned`);
- `gaps_study`: the "gaps" grid and IDA studies, their pulse records and stand-ins
  (test_reliability, test_cluster, test_cells; `tests.fixtures.pinned`);
- `ida_study`: the IDA stand-ins `study_kernel` and `stiff_kernel`, their records and studies
  (test_fragility, test_risk, test_statistics; `tests.fixtures.pinned`);
- `own_records`: a folder of one's own synthetic AT2 records and the study on it
  (test_cells, test_nothing_silent);
- `own_files`: the study on record files beside the study file (test_study_file, test_cells);
- `synthetic`: small synthetic records of the plug-in kind tests (`TOY_ACC`, `SWEEP_ACC`,
  `PULSE`, `SAMPLING_ACC`, sampled at `DT`; test_kinds, test_cells, test_sampling) and the
  one template of synthetic PEER AT2 record files, `at2_text`, `at2_rows`, `AT2_ROWS`
  (test_bad_inputs, test_readers, test_records, test_reliability; `own_records`);
- `runs`: `Interrupt` (what a stand-in kernel raises for Ctrl-C), `same_run` and
  `fallback_version`.
"""
