"""Record files read as a user's would be, none silently wrong: numbers in comments, units
and time steps stated twice, time columns, values outside what strong-motion records have,
formats that are not records (compressed, archives, UTF-16, one number, text at line N,
huge sparse files), channels of multi-channel files, and own record folders indexed into a
manifest. Each case failed on the code before these checks (issues 22, 25 and 29)."""

from __future__ import annotations

import builtins
import gzip
import hashlib
import os
import shutil
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest

import urmx.records as R
from urmx import UrmxError
from urmx.cli import main
from urmx.records.readers import detect as readers  # where _detect_obspy and SNIFF_BYTES live

from .helpers.synthetic import AT2_ROWS, at2_text

G_N = 9.80665
WAVE = 0.1 * np.sin(np.arange(200) * 0.1)  # [g]


def at2(tmp_path, unit="G", dt=".0100", v0="1.0E-02", name="rec.AT2") -> Path:
    """The eight-value AT2 record of `tests.helpers.synthetic`, `v0` its first value."""
    path = tmp_path / name
    path.write_text(at2_text(AT2_ROWS.replace("1.0E-02", v0, 1), unit=unit, dt=dt))
    return path


def columns(tmp_path, header: str, name="rec.txt", values=WAVE, encoding="utf-8") -> Path:
    path = tmp_path / name
    path.write_bytes((header + "\n".join(f"{v:.6f}" for v in values) + "\n").encode(encoding))
    return path


def pairs(tmp_path, times, values=None, name="pairs.txt") -> Path:
    values = WAVE[: len(times)] if values is None else values
    path = tmp_path / name
    path.write_text("\n".join(f"{t:.4f} {a:.6f}" for t, a in zip(times, values, strict=True)))
    return path


def one_line(capsys, argv) -> str:
    """The CLI's error for `argv`: exit status 2 and one line on stderr, returned."""
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


# -- numbers in comments, and values stated twice -----------------------------------------


def test_time_step_in_a_comment_is_read_whole(tmp_path):
    """`# dt=1e-3` was read as dt = 1 s (the regular expression stopped at the 'e')."""
    tr = R.read(columns(tmp_path, "# dt=1e-3\n"), unit="g")[0]
    assert tr.stats.delta == 0.001 and tr.stats.npts == 200
    for header, dt in (("# dt = 5 ms\n", 0.005), ("# time step: 0.02 s\n", 0.02),
                       ("# 200 points at equal spacing of .01 sec\n", 0.01)):
        assert R.read(columns(tmp_path, header), unit="g")[0].stats.delta == dt


@pytest.mark.parametrize(("header", "needle"), [
    ("# dt = 0,005\n", "'0,005' is not a number (a decimal comma?"),
    ("# dt = 0.005.0\n", "'0.005.0' is not a number"),
    ("# dt: unknown\n", "'unknown' is not a number"),
])
def test_a_time_step_comment_that_is_not_a_number_is_refused(tmp_path, header, needle):
    with pytest.raises(R.MissingTimeStepError, match="comment line 1") as err:
        R.read(columns(tmp_path, header), unit="g", dt=0.01)
    assert needle in str(err.value)


def test_unit_stated_by_a_comment_and_given_must_agree(tmp_path, capsys):
    """A `units: g` comment run with --unit m/s2: the option used to win without a word."""
    path = columns(tmp_path, "# units: g\n")
    assert R.read(path, dt=0.01)[0].data.max() == pytest.approx(WAVE.max() * G_N, rel=1e-5)
    with pytest.raises(R.RecordUnitError) as err:
        R.read(path, dt=0.01, unit="m/s2")
    assert "states unit 'g' (comment line 1: '# units: g')" in str(err.value)
    assert "unit='m/s2'" in str(err.value)
    err = one_line(capsys, ["records", "show", path, "--dt", "0.01", "--unit", "m/s2"])
    assert "'g'" in err and "'m/s2'" in err
    with pytest.raises(R.RecordUnitError, match="states no unit urmx knows"):
        R.read(columns(tmp_path, "# units: furlongs/fortnight2\n"), dt=0.01)


def test_time_step_stated_by_a_comment_and_given_must_agree(tmp_path):
    path = columns(tmp_path, "# dt=1e-3\n")
    assert R.read(path, dt=0.001, unit="g")[0].stats.delta == 0.001  # the same: fine
    with pytest.raises(R.MissingTimeStepError,
                       match=r"states dt=0.001 s \(comment line 1: '# dt=1e-3'\) but dt=0.01"):
        R.read(path, dt=0.01, unit="g")


# -- (time, acceleration) columns -----------------------------------------------------------


T = np.arange(200) * 0.01


@pytest.mark.parametrize(("times", "line", "was"), [
    (np.where(T == T[4], T[3], T), 5, 0.03),         # a duplicate time at line 5
    (np.where(T == T[4], 0.025, T), 5, 0.03),         # a time going back at line 5
    (T[::-1], 2, 1.99),                               # times decreasing throughout
])
def test_time_column_must_increase_strictly(tmp_path, times, line, was):
    """Such a file was read as one series of interleaved times and values with --dt."""
    path = pairs(tmp_path, times)
    with pytest.raises(R.RecordError) as err:
        R.read(path, dt=0.01, unit="g")
    assert f"line {line}: time" in str(err.value) and f"has {was:g} s" in str(err.value)
    assert "must increase strictly" in str(err.value)


def test_time_column_and_given_dt_must_agree(tmp_path):
    path = pairs(tmp_path, np.arange(200) * 0.01)
    tr = R.read(path, unit="g")[0]
    assert tr.stats.delta == pytest.approx(0.01) and tr.stats.npts == 200
    np.testing.assert_allclose(tr.data, np.round(WAVE, 6) * G_N, rtol=1e-12)
    with pytest.raises(R.MissingTimeStepError, match="even step of 0.01 s but dt=0.02 was "
                                                      "given"):
        R.read(path, unit="g", dt=0.02)
    header = tmp_path / "commented.txt"  # a comment no longer hides the time column
    header.write_text("# time [s], acceleration [g]\n" + path.read_text())
    assert R.read(header, unit="g")[0].stats.npts == 200


def test_values_in_pairs_are_not_a_time_column(tmp_path):
    path = tmp_path / "two_per_line.txt"
    path.write_text("\n".join(f"{a:.6f} {b:.6f}" for a, b in WAVE.reshape(-1, 2)))
    tr = R.read(path, dt=0.01, unit="g")[0]
    assert tr.stats.npts == 200
    np.testing.assert_allclose(tr.data, np.round(WAVE, 6) * G_N, rtol=1e-12)


# -- values outside what strong-motion records have -----------------------------------------


def test_g_values_under_a_cm_s2_header_are_refused(tmp_path, capsys):
    """An AT2 saying CM/S2 whose values are g (PGA 0.0003 g) ran as if real."""
    path = at2(tmp_path, unit="CM/S2", v0="3.0E-01")
    with pytest.raises(R.UnusualRecordError) as err:
        R.read(path)
    message = str(err.value)
    assert "PGA 0.000306 g with unit 'cm/s2' (header)" in message
    assert "as g: 0.3 g" in message and "allow_unusual=True" in message
    assert "--allow-unusual" in one_line(capsys, ["records", "show", path])
    tr = R.read(path, allow_unusual=True)[0]  # meant: read as stated
    assert np.abs(tr.data).max() == pytest.approx(0.003)
    assert main(["records", "show", str(path), "--allow-unusual"]) == 0
    assert "0.0003 g" in capsys.readouterr().out


def test_pga_above_10_g_and_all_zeros_are_refused(tmp_path):
    with pytest.raises(R.UnusualRecordError, match="PGA 30 g with unit 'g'.*the unit is wrong"):
        R.read(at2(tmp_path, v0="3.0E+01"))
    zeros = columns(tmp_path, "", values=np.zeros(50))
    with pytest.raises(R.UnusualRecordError, match="every sample of the record is zero"):
        R.read(zeros, dt=0.01, unit="g")


@pytest.mark.parametrize(("dt", "needle"), [
    ("1000", "dt=1000 s (from the header), outside the 0.0001-0.1 s"),
    ("1e-7", "dt=1e-07 s (from the header), outside the 0.0001-0.1 s of strong-motion "
             "records (implausibly small)"),
    ("5", "dt=5 s (from the header), outside the 0.0001-0.1 s of strong-motion records "
          "(milliseconds given as seconds?)"),
])
def test_header_time_step_outside_strong_motion_records(tmp_path, dt, needle):
    """DT= 1000 was accepted; DT= 1e-7 failed later as "window=1e-06 must lie in (0, dt)"."""
    path = at2(tmp_path, dt=dt)
    with pytest.raises(R.UnusualRecordError) as err:
        R.read(path)
    assert needle in str(err.value) and "allow_unusual=True" in str(err.value)
    assert "window" not in str(err.value)
    assert R.read(path, allow_unusual=True)[0].stats.delta == float(dt)


def test_given_time_step_outside_strong_motion_records(tmp_path):
    with pytest.raises(R.UnusualRecordError, match=r"dt=0.5 s \(given\)"):
        R.read(columns(tmp_path, ""), dt=0.5, unit="g")


# -- AT2 header and data tokens -----------------------------------------------------------


@pytest.mark.parametrize(("dt", "needle"), [
    ("0.005.0", "PEER AT2 line 4: time step DT='0.005.0' is not a number"),
    ("0,005", "DT='0,005' is not a number (a decimal comma?"),
])
def test_at2_time_step_token(tmp_path, capsys, dt, needle):
    """`DT= 0.005.0` was a ValueError traceback; `DT= 0,005` became "dt=0.0"."""
    path = at2(tmp_path, dt=dt)
    with pytest.raises(R.RecordError) as err:
        R.read(path)
    assert needle in str(err.value) and "dt=0.0" not in str(err.value)
    assert needle in one_line(capsys, ["records", "show", path])


def test_at2_bad_value_is_named_with_its_line(tmp_path):
    with pytest.raises(R.RecordError, match=r"PEER AT2 line 5: '1.0E-0X' is not a number"):
        R.read(at2(tmp_path, v0="1.0E-0X"))
    with pytest.raises(R.RecordError, match=r"line 5: '1,5' is not a number \(a decimal comma"):
        R.read(at2(tmp_path, v0="1,5"))


# -- what a file is when it is not a record -------------------------------------------------


def test_text_at_line_51_is_named(tmp_path):
    path = tmp_path / "rec.txt"
    lines = [f"{v:.6f}" for v in WAVE]
    path.write_text("\n".join(lines[:50] + ["end of data: 200 values"] + lines[50:]))
    with pytest.raises(R.RecordError) as err:
        R.read(path, dt=0.01, unit="g")
    assert "line 51 is not numbers: 'end of data: 200 values' ('end' is not a number)" \
        in str(err.value)


def test_a_file_of_one_number(tmp_path):
    path = tmp_path / "one.txt"
    path.write_text("0.25\n")
    with pytest.raises(R.RecordError, match=r"holds a single number \(0.25\), not an "
                                            "acceleration history"):
        R.read(path, dt=0.01, unit="g")


@pytest.mark.parametrize(("make", "needle"), [
    (lambda p: p.write_bytes(gzip.compress(b"0.1\n0.2\n")),
     "file is gzip-compressed, not a record file: decompress it first (gunzip FILE)"),
    (lambda p: zipfile.ZipFile(p, "w").writestr("rec.AT2", at2_text()),
     "file is a zip archive, not a record file: unpack it first (unzip FILE)"),
    (lambda p: p.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(100)), "an HDF5 or netCDF-4 file"),
    (lambda p: p.write_text("<!DOCTYPE html>\n<html><body>Not found</body></html>\n"),
     "an HTML page"),
    (lambda p: p.write_bytes(bytes(range(1, 200)) * 10),
     "unknown record format: a binary file starting with bytes 01 02 03 04"),
    (lambda p: p.write_text("Station list\nWTMC 42.6 173.0\n"),
     "unknown record format: a text file whose first line is 'Station list'"),
])
def test_not_a_record_says_what_it_is(tmp_path, capsys, make, needle):
    """gzip, zip and other files were all "unknown record format", with no hint."""
    path = tmp_path / "rec.dat"
    make(path)
    with pytest.raises(R.UnknownFormatError) as err:
        R.read(path)
    assert needle in str(err.value)
    if "unknown record format" in needle:  # and what urmx reads
        assert "PEER NGA AT2, GeoNet V1A/V2A" in str(err.value) and "MSEED" in str(err.value)
    assert needle in one_line(capsys, ["records", "show", path])


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-le", "utf-16-be"])
def test_utf16_text_is_decoded(tmp_path, encoding):
    """UTF-16 files (Windows exports) were "unknown record format"; they are decoded."""
    path = columns(tmp_path, "# dt = 0.01 s\n# units: g\n", encoding=encoding)
    tr = R.read(path)[0]
    assert (tr.stats.delta, tr.stats.npts) == (0.01, 200)
    np.testing.assert_allclose(tr.data, np.round(WAVE, 6) * G_N, rtol=1e-12)
    assert f"decoded from {encoding.upper()}" in tr.stats.processing[1]
    utf16_at2 = tmp_path / "rec16.AT2"
    utf16_at2.write_bytes(at2(tmp_path).read_text().encode(encoding))
    assert R.read(utf16_at2)[0].stats.npts == 8


@pytest.mark.parametrize("head", [b"", b"PEER NGA STRONG MOTION DATABASE RECORD\n",
                                  bytes(range(1, 255))])
def test_huge_sparse_file_is_sniffed_not_read(tmp_path, monkeypatch, head):
    """A 2 GB sparse file took a minute and 4.3 GB before "unknown format": only the first
    `SNIFF_BYTES` bytes decide; the file is never read whole, nor given to ObsPy."""
    path = tmp_path / "huge.dat"
    path.write_bytes(head)
    os.truncate(path, 3 * 2**30)  # sparse: takes no disk space
    read = []
    real_open = builtins.open

    class Counting:
        """A file whose reads are counted."""

        def __init__(self, fh):
            self.fh = fh

        def read(self, n=-1):
            data = self.fh.read(n)
            read.append(len(data))
            return data

        def __getattr__(self, name):
            return getattr(self.fh, name)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.fh.close()

    def counting_open(file, mode="r", *args, **kwargs):
        fh = real_open(file, mode, *args, **kwargs)
        return Counting(fh) if str(file) == str(path) else fh

    def no_obspy(p):
        raise AssertionError("ObsPy's detectors were given the huge file")

    monkeypatch.setattr(builtins, "open", counting_open)
    monkeypatch.setattr(readers, "_detect_obspy", no_obspy)
    monkeypatch.setattr(Path, "read_bytes", lambda self: pytest.fail("read whole"))
    tracemalloc.start()
    try:
        with pytest.raises(UrmxError) as err:
            R.read(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert sum(read) <= readers.SNIFF_BYTES
    assert peak < 16 * 2**20
    message = str(err.value)
    if head:
        assert isinstance(err.value, R.UnusualRecordError)
        assert "file of 3.0 GiB is larger than any strong-motion record" in message
    else:
        assert "first 8192 bytes are all zero bytes (3.0 GiB)" in message


# -- NaN samples are named as such ---------------------------------------------------------


def test_measures_of_a_trace_with_nan_name_the_sample():
    """measures() of a trace with a NaN returned NaN measures."""
    from obspy import Trace

    tr = Trace(np.array([0.1, 0.2, np.nan, -0.1, 0.0]), header={"delta": 0.01})
    for call in (R.measures, R.response_spectrum, R.fourier_spectrum,
                 R.significant_duration, lambda t: R.scale(t, target_pga=1.0)):
        with pytest.raises(R.NonFiniteError) as err:
            call(tr)
        assert "the first at index 2 (nan, t = 0.02 s)" in str(err.value)
        assert "zero" not in str(err.value)
    with pytest.raises(R.NonFiniteError, match="index 2"):
        R.sdof_displacement(tr.data, 0.01, 0.5)


def test_nan_in_a_file_is_named(tmp_path):
    path = tmp_path / "nan.txt"
    path.write_text("0.1\n0.2\nnan\n-0.1\n")
    with pytest.raises(R.NonFiniteError, match="1 NaN or infinite samples of 4, the first at "
                                               "index 2"):
        R.read(path, dt=0.01, unit="g")


# -- channels -------------------------------------------------------------------------------


def test_multi_channel_file_needs_a_channel(sample_records, tmp_path, capsys):
    """`records show` silently took the first channel; `simulate` had no --channel."""
    v2 = sample_records / "formats/dmg/CE89146.V2"
    wall = Path(__file__).parent.parent / "catalog/examples/wall12.toml"
    for argv in (["records", "show", v2], ["records", "plot", v2, "--out", tmp_path / "a.png"],
                 ["simulate", wall, v2]):
        err = one_line(capsys, argv)
        assert "holds 3 channels (360, UP, 090); choose one with channel= (--channel NAME" \
            in err
    assert main(["records", "show", str(v2), "--channel", "90"]) == 0
    out = capsys.readouterr().out
    assert "channel 090" in out and "0.0451 g" in out
    err = one_line(capsys, ["records", "show", v2, "--channel", "N28W"])
    assert "no channel 'N28W': its 3 channels are 360, UP, 090" in err
    assert main(["simulate", str(wall), str(v2), "--channel", "up"]) == 0
    assert "12000 points" in capsys.readouterr().out
    st = R.read(v2, channel="360")
    assert len(st) == 1 and st[0].stats.channel == "360"
    assert np.abs(st[0].data).max() / G_N == pytest.approx(0.0788, abs=6e-5)


def test_load_takes_a_channel(records_dir):
    tr = R.load("bigbear", records_dir, channel="180")
    assert tr.stats.channel == "180"
    with pytest.raises(R.ManifestError, match="record 'bigbear' is channel '180' of "
                                              r"bigbear1992/ce23583r_HESPERIA.RAW, not 'UP'"):
        R.load("bigbear", records_dir, channel="UP")


# -- describe: one channel of one file with its provenance ----------------------------------


def test_describe_a_record_file(sample_records, monkeypatch):
    src = sample_records / "formats/peer/RSN763_LOMAP_GIL067.AT2"
    reads = []
    real = Path.read_bytes
    monkeypatch.setattr(Path, "read_bytes", lambda self: reads.append(self) or real(self))
    rf = R.describe(src)
    assert reads == [src]  # the file is read once (its first bytes sniffed before)
    assert rf.sha256 == hashlib.sha256(src.read_bytes()).hexdigest()
    assert (rf.name, rf.format, rf.channel, rf.channels, rf.unit) == (
        "RSN763_LOMAP_GIL067.AT2", "peer", "067", ("067",), "g")
    assert (rf.dt, rf.npts) == (0.005, 7999) and rf.pga_g == pytest.approx(0.3585, abs=5e-5)
    assert rf.description == "Loma Prieta, 10/18/1989, Gilroy - Gavilan Coll., 67"
    np.testing.assert_array_equal(rf.data, R.read(src)[0].data)
    assert not rf.data.flags.writeable and rf.trace().stats.delta == 0.005
    with pytest.raises(AttributeError):
        rf.dt = 0.01  # frozen
    v2a = sample_records / "formats/geonet/20161113_110259_WTMC_20.V2A"
    with pytest.raises(R.ChannelError, match=r"holds 3 channels \(N28W, S62W, UP\)"):
        R.describe(v2a)
    s62w = R.describe(v2a, channel="S62W")
    assert (s62w.channel, s62w.unit, s62w.dt, s62w.npts) == ("S62W", "mm/s2", 0.02, 8192)
    plain = R.describe(sample_records / "elcentro1940/elcentro_S00E_1940.dat", dt=0.02,
                       unit="cm/s2")
    assert (plain.format, plain.unit, plain.npts) == ("columns", "cm/s2", 2688)
    assert plain.pga_g == pytest.approx(0.3484, abs=5e-5)


# -- index: a manifest of an own folder of records ---------------------------------------------


@pytest.fixture
def suite(sample_records, tmp_path) -> Path:
    folder = tmp_path / "suite"
    (folder / "plain").mkdir(parents=True)
    for name in ("formats/peer/RSN763_LOMAP_GIL067.AT2",
                 "formats/geonet/20161113_110259_WTMC_20.V2A",
                 "formats/geonet/20161113_110259_WTMC_20.V1A"):
        shutil.copy(sample_records / name, folder)
    shutil.copy(sample_records / "elcentro1940/elcentro_S00E_1940.dat", folder / "plain")
    shutil.copy(sample_records / "elcentro1940/elcentro_S00E_1940.dat",
                folder / "plain" / "elcentro.dat")  # an id of records/manifest.toml
    (folder / "README.md").write_text("My suite\n")
    from obspy import Trace

    sac = Trace(300.0 * np.sin(np.arange(1000) * 0.05), header={"delta": 0.01})
    sac.write(str(folder / "plain" / "shake.sac"), format="SAC")  # an ObsPy format, in cm/s2
    return folder


def test_index_a_folder_and_load_every_id(suite, capsys, monkeypatch):
    assert main(["records", "index", str(suite), "--pattern", "**/*", "--dt", "0.02",
                 "--unit", "cm/s2"]) == 2  # README.md matches the explicit pattern
    assert "README.md: unknown record format" in capsys.readouterr().err
    assert main(["records", "index", str(suite), "--dt", "0.02", "--unit", "cm/s2",
                 "--pattern", "**/*.[AVds]*"]) == 0
    out = capsys.readouterr().out
    assert f"wrote {suite / 'manifest.toml'} (10 records)" in out
    entries = R.manifest(suite)  # the folder's manifest.toml joins the checkout's
    own = {k: e for k, e in entries.items() if e["set"] == "own"}
    assert sorted(own) == [
        "20161113-110259-wtmc-20-v1a-n28w", "20161113-110259-wtmc-20-v1a-s62w",
        "20161113-110259-wtmc-20-v1a-up", "20161113-110259-wtmc-20-v2a-n28w",
        "20161113-110259-wtmc-20-v2a-s62w", "20161113-110259-wtmc-20-v2a-up",
        "elcentro-s00e-1940", "own-elcentro", "rsn763-lomap-gil067", "shake"]
    assert (own["shake"]["format"], own["shake"]["dt"], own["shake"]["unit"]) == (
        "SAC", 0.01, "cm/s2")  # its dt from the file, not --dt
    assert "elcentro" in entries and entries["elcentro"]["set"] == "paper"
    at2 = own["rsn763-lomap-gil067"]
    assert (at2["format"], at2["unit"], at2["dt"], at2["npts"], at2["scale_factor"]) == (
        "peer", "g", 0.005, 7999, 1.0)
    assert at2["expected_pga_g"] == pytest.approx(0.3585, abs=5e-5)
    assert at2["event"] == "Loma Prieta, 10/18/1989, Gilroy - Gavilan Coll., 67"
    assert at2["sha256"] == hashlib.sha256((suite / at2["file"]).read_bytes()).hexdigest()
    assert own["20161113-110259-wtmc-20-v2a-s62w"]["channel"] == "S62W"
    assert (own["elcentro-s00e-1940"]["file"], own["elcentro-s00e-1940"]["dt"],
            own["elcentro-s00e-1940"]["unit"]) == ("plain/elcentro_S00E_1940.dat", 0.02,
                                                   "cm/s2")
    for rid, e in own.items():  # each id loads through the manifest as a direct read does
        given = {"columns": {"dt": 0.02, "unit": "cm/s2"}, "SAC": {"unit": "cm/s2"}}
        direct = R.read(suite / e["file"], **given.get(e["format"], {}),
                        channel=e.get("channel"))[0]
        loaded = R.load(rid, suite)
        np.testing.assert_array_equal(loaded.data, direct.data)
        assert loaded.stats.delta == direct.stats.delta
    monkeypatch.setenv("URMX_RECORDS", str(suite))
    assert main(["records", "list", "--set", "own"]) == 0
    assert capsys.readouterr().out.count("\n") == 2 + 10  # folder line, heading, records
    (suite / "plain" / "elcentro.dat").write_text("1\n2\n")  # edited since: refused
    with pytest.raises(R.ChecksumError, match="own-elcentro"):
        R.load("own-elcentro", suite)


def test_index_skips_what_is_not_a_record_without_a_pattern(suite, capsys, tmp_path):
    out = tmp_path / "elsewhere.toml"
    with pytest.raises(R.MissingTimeStepError, match="plain/elcentro.dat: columns file does "
                                                     "not carry its time step"):
        R.index(suite, pattern="**/*.dat", unit="cm/s2")
    assert main(["records", "index", str(suite), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "skipped README.md: unknown record format: a text file whose first line is " \
        "'My suite'" in text
    assert "wrote" in text and "(7 records)" in text  # the two plain files are in plain/
    entries = R.manifest(path=out)
    e = entries["rsn763-lomap-gil067"]
    assert e["manifest"] == str(out) and e["file"] == "RSN763_LOMAP_GIL067.AT2"
    tr = R.load("rsn763-lomap-gil067", suite, manifest=out)
    assert tr.stats.npts == 7999 and tr.stats.record.sha256 == e["sha256"]
