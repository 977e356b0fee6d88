"""The test suite's own guard rails: a missing records folder fails a CI run."""

from __future__ import annotations

import pytest

from .fixtures.records import record_file, records_folder


@pytest.mark.parametrize("ci", ["true", "1"])
def test_missing_records_fail_under_ci(monkeypatch, tmp_path, ci):
    monkeypatch.setenv("CI", ci)
    monkeypatch.setenv("URMX_RECORDS", str(tmp_path / "nowhere"))
    with pytest.raises(pytest.fail.Exception, match=r"URMX_RECORDS.*CI is set"):
        records_folder()
    monkeypatch.delenv("URMX_RECORDS")
    monkeypatch.chdir(tmp_path)  # no urmx.toml here either
    with pytest.raises(pytest.fail.Exception, match="set URMX_RECORDS"):
        records_folder()


@pytest.mark.parametrize("ci", [None, "", "false", "0"])
def test_missing_records_skip_elsewhere(monkeypatch, tmp_path, ci):
    if ci is None:
        monkeypatch.delenv("CI", raising=False)
    else:
        monkeypatch.setenv("CI", ci)
    monkeypatch.setenv("URMX_RECORDS", str(tmp_path / "nowhere"))
    with pytest.raises(pytest.skip.Exception, match="URMX_RECORDS"):
        records_folder()


def test_a_missing_file_in_the_folder_fails_under_ci(monkeypatch, tmp_path):
    monkeypatch.setenv("CI", "true")
    monkeypatch.setenv("URMX_RECORDS", str(tmp_path))
    assert records_folder() == tmp_path
    with pytest.raises(pytest.fail.Exception, match="elcentro.dat is missing"):
        record_file("elcentro.dat")
