"""The researcher's notebooks run top to bottom (nbclient) and their cells hold the values
they claim: ``docs/fragility.ipynb`` on its small grid, ``docs/own-study.ipynb`` on its own
wall and record files (a study, the study extended by a record, the archive's provenance)."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from .fixtures.records import record_file, records_file

NOTEBOOK = Path(__file__).resolve().parent.parent / "docs" / "fragility.ipynb"
OWN_STUDY = NOTEBOOK.parent / "own-study.ipynb"


def test_fragility_notebook_runs(records_dir, tmp_path, monkeypatch):
    records_file("library/catalog.tsv")  # the FEMA P695 library the notebook's grid uses
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    monkeypatch.setenv("URMX_RECORDS", str(records_dir))
    monkeypatch.delenv("MPLBACKEND", raising=False)  # the kernel draws inline
    nb = nbformat.read(NOTEBOOK, as_version=4)
    assert all(not c.get("outputs") for c in nb.cells if c.cell_type == "code")  # stored clean
    nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    text = {}
    for i, cell in enumerate(nb.cells):
        out = []
        for o in cell.get("outputs", []):
            assert o.output_type != "error", o
            out.append(o.get("text", "") or str(o.get("data", {}).get("text/plain", "")))
        text[i] = "\n".join(out)
    joined = "\n".join(text.values())
    assert "collapse PGA" in joined and "censored: False" in joined
    assert "True {'wall': 3, 'diaphragm': 3, 'record': 8, 'cor': 1" in joined  # lazy, sizes
    assert "stripes:" in joined
    assert "90 % interval" in joined and "collapses per year" in joined  # issue 26
    assert any(o.output_type == "display_data" and "image/png" in o.get("data", {})
               for c in nb.cells for o in c.get("outputs", []))  # the fragility curve


def _execute(path: Path, records_dir, tmp_path, monkeypatch):
    """Execute the notebook at `path` in `tmp_path` (stored without outputs, none an error);
    return it and its text outputs joined."""
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    monkeypatch.setenv("URMX_RECORDS", str(records_dir))
    monkeypatch.delenv("MPLBACKEND", raising=False)  # the kernel draws inline
    nb = nbformat.read(path, as_version=4)
    assert all(not c.get("outputs") for c in nb.cells if c.cell_type == "code")
    nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    outputs = [o for c in nb.cells for o in c.get("outputs", [])]
    assert not [o for o in outputs if o.output_type == "error"], outputs
    return nb, "\n".join(o.get("text", "") or str(o.get("data", {}).get("text/plain", ""))
                         for o in outputs)


def test_own_study_notebook_runs(sample_records, tmp_path, monkeypatch):
    """The notebook reads two format samples (GeoNet V2A, PEER AT2) and a shipped record,
    from the records folder that holds the samples (`sample_records`: the shipped
    records)."""
    from urmx.provenance import attrs

    records_dir = sample_records

    files = {"wtmc": "formats/geonet/20161113_110259_WTMC_20.V2A",
             "gilroy": "formats/peer/RSN763_LOMAP_GIL067.AT2",
             "s00e": "elcentro1940/elcentro_S00E_1940.dat"}
    paths = {k: record_file(v) for k, v in files.items()}
    nb, joined = _execute(OWN_STUDY, records_dir, tmp_path, monkeypatch)
    # the multi-channel file: its channels, and refused without one
    assert "holds 3 channels (N28W, S62W, UP)" in joined
    assert "channel S62W: geonet, mm/s2, dt 0.02 s, 8192 points, PGA 0.812 g" in joined
    assert "study wall == builder's wall: True" in joined
    # first run: every cell computed; the extension: only the new record's 1 x 2 cells
    assert "first run: 4 cells, 4 computed, 0 reused" in joined
    assert "extended run: 6 cells, 2 computed, 4 reused from the archive, 0 from parts" \
        in joined
    assert "old cells bitwise equal: True" in joined
    # provenance read back from the archive: this code, and each record's file and checksum
    ours = attrs()
    assert f"urmx_version: {ours['urmx_version']}\n" in joined
    assert f"kernel_source_hash: {ours['kernel_source_hash']}\n" in joined
    assert "grid archive of study 'my-house'" in joined
    for rid, path in paths.items():
        digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
        assert f"{rid}: {Path(path).name} " in joined and f"sha256 {digest}" in joined
    assert "wtmc: 20161113_110259_WTMC_20.V2A channel S62W [mm/s2] dt 0.02 s" in joined
    assert "s00e: elcentro_S00E_1940.dat channel - [cm/s2] dt 0.02 s" in joined
    assert any(o.output_type == "display_data" and "image/png" in o.get("data", {})
               for c in nb.cells for o in c.get("outputs", []))  # the figure
    docs = OWN_STUDY.parent
    assert not list(docs.glob("*.nc")) and not list(docs.glob("*.toml"))  # nothing in docs/


def test_predictors_notebook_runs(records_dir, tmp_path, monkeypatch):
    """docs/predictors.ipynb (issue 37) on its small wall population: the design, one
    wall's predictors, the run, the ranking, the report and urmx_rule."""
    records_file("library/catalog.tsv")
    nb, joined = _execute(NOTEBOOK.parent / "predictors.ipynb", records_dir, tmp_path,
                          monkeypatch)
    assert "walls drawn: 40" in joined and "h/t <= 35: True" in joined
    assert "static_acceleration" in joined and "effective_period" in joined
    assert "capacities: 80 |" in joined
    assert "predictor_slenderness" in joined and "predictor_frequency_ratio" in joined
    assert "single pga" in joined and "recommended" in joined
    assert "REPORT.md" in joined and "numbers.json" in joined
    assert "registered: True" in joined and "urmx_rule:" in joined
    assert any(o.output_type == "display_data" and "image/png" in o.get("data", {})
               for c in nb.cells for o in c.get("outputs", []))
