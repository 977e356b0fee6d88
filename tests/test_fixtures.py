"""The test suite's own guard rails: a missing records folder fails a CI run."""

from __future__ import annotations

import pytest

from urmx.config import shipped_records

from .fixtures import records as fixture
from .fixtures.records import record_file, records_folder, samples_folder


@pytest.mark.parametrize("ci", ["true", "1"])
def test_missing_records_fail_under_ci(monkeypatch, tmp_path, ci):
    monkeypatch.setenv("CI", ci)
    monkeypatch.setenv("URMX_RECORDS", str(tmp_path / "nowhere"))
    with pytest.raises(pytest.fail.Exception, match=r"URMX_RECORDS.*CI is set"):
        records_folder()
    monkeypatch.delenv("URMX_RECORDS")
    monkeypatch.chdir(tmp_path)  # no urmx.toml here either: the shipped records
    assert records_folder() == shipped_records()


@pytest.mark.parametrize("ci", [None, "", "false", "0"])
def test_missing_records_skip_elsewhere(monkeypatch, tmp_path, ci):
    if ci is None:
        monkeypatch.delenv("CI", raising=False)
    else:
        monkeypatch.setenv("CI", ci)
    monkeypatch.setenv("URMX_RECORDS", str(tmp_path / "nowhere"))
    with pytest.raises(pytest.skip.Exception, match="URMX_RECORDS"):
        records_folder()


def test_the_format_samples_are_found_in_the_shipped_records_and_their_absence_is_said(
        monkeypatch, tmp_path):
    """The format samples are shipped (``records/formats``): with no ``$URMX_RECORDS``, or
    one that lacks them, they are found there, with nothing beside the checkout; a folder
    whose marker sample is missing everywhere fails under CI and skips elsewhere."""
    monkeypatch.delenv("URMX_RECORDS", raising=False)
    assert samples_folder() == shipped_records()
    assert record_file(fixture.MARKER) == shipped_records() / fixture.MARKER
    monkeypatch.setenv("URMX_RECORDS", str(tmp_path))  # a folder of one's own, no samples
    assert samples_folder() == shipped_records()
    monkeypatch.setattr(fixture, "MARKER", "no/such/sample.AT2")
    monkeypatch.setenv("CI", "true")
    with pytest.raises(pytest.fail.Exception, match="sample.AT2.*CI is set"):
        samples_folder()
    monkeypatch.setenv("CI", "")
    with pytest.raises(pytest.skip.Exception, match="format samples are not found"):
        samples_folder()


def test_a_record_file_is_looked_for_in_the_users_folder_then_the_shipped_one(
        monkeypatch, tmp_path):
    """`record_file` takes a file from ``$URMX_RECORDS`` first (how a K-NET sample, which
    is not shipped, reaches its tests), then from the shipped records; a file no folder
    holds fails under CI and skips elsewhere, naming the folders it looked in."""
    own = tmp_path / "formats" / "knet" / "SYN0010001010000.EW"
    own.parent.mkdir(parents=True)
    own.write_text("x", encoding="ascii")
    monkeypatch.setenv("URMX_RECORDS", str(tmp_path))
    assert record_file("formats/knet/SYN0010001010000.EW") == own
    assert record_file(fixture.MARKER) == shipped_records() / fixture.MARKER
    monkeypatch.setenv("CI", "true")
    with pytest.raises(pytest.fail.Exception, match=r"no/such\.AT2 is not found in .*CI is set"):
        record_file("no/such.AT2")
    monkeypatch.setenv("CI", "")
    with pytest.raises(pytest.skip.Exception, match=str(tmp_path)):
        record_file("no/such.AT2")


def test_a_file_of_the_records_in_use_is_found_there_and_its_absence_is_said(monkeypatch,
                                                                              tmp_path):
    """`records_file` reads the records folder in use (``$URMX_RECORDS``, else the shipped
    records, which hold the FEMA P695 library: no shared folder is needed for it); a file
    missing there fails under CI and skips elsewhere."""
    from .fixtures.records import records_file

    monkeypatch.delenv("URMX_RECORDS", raising=False)
    shipped = records_file("library/catalog.tsv")
    assert shipped == records_folder() / "library" / "catalog.tsv" and shipped.is_file()
    (tmp_path / "manifest.toml").write_text("", encoding="utf-8")
    monkeypatch.setenv("URMX_RECORDS", str(tmp_path))
    monkeypatch.setenv("CI", "true")
    with pytest.raises(pytest.fail.Exception, match="catalog.tsv is missing.*CI is set"):
        records_file("library/catalog.tsv")
    monkeypatch.setenv("CI", "")
    with pytest.raises(pytest.skip.Exception, match="missing from the records folder"):
        records_file("library/catalog.tsv")
