"""The researcher's notebook ``docs/fragility.ipynb`` runs top to bottom (nbclient) on its
small grid, and its cells hold the values they claim."""

from __future__ import annotations

from pathlib import Path

import pytest

from .fixtures.records import record_file

NOTEBOOK = Path(__file__).resolve().parent.parent / "docs" / "fragility.ipynb"


def test_fragility_notebook_runs(records_dir, tmp_path, monkeypatch):
    record_file("library/catalog.tsv")  # the FEMA P695 library the notebook's grid uses
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
