"""Tests for urmx.records: readers against PROVENANCE.md, errors, measures, manifest, CLI."""

from __future__ import annotations

import csv
import hashlib
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

import urmx.records as R
from urmx import UrmxWarning
from urmx.config import shipped_records

from .fixtures.records import record_file
from .helpers.synthetic import at2_rows, at2_text

G_N = 9.80665  # standard gravity g_n [m s-2] (records in units of g)


# -- the shipped records and format samples, against PROVENANCE.md ----------------------
# (file, read kwargs, channel, dt [s], npts, PGA [g] from PROVENANCE.md)
PROVENANCE = [
    ("elcentro1940/elcentro_S00E_1940.dat", {"dt": 0.02, "unit": "cm/s2"}, "", 0.02, 2688,
     0.3484),
    ("elcentro1940/ELC-180", {"dt": 0.01, "unit": "g"}, "", 0.01, 3949, 0.3129),
    ("nahanni1985/NS1-010", {"dt": 0.005, "unit": "g"}, "", 0.005, 4038, 0.9778),
    ("bigbear1992/ce23583r_HESPERIA.RAW", {}, "090", 0.005, 12001, 0.0579),
    ("bigbear1992/ce23583r_HESPERIA.RAW", {}, "UP", 0.005, 12001, 0.0420),
    ("bigbear1992/ce23583r_HESPERIA.RAW", {}, "180", 0.005, 12001, 0.0906),
    ("darfield2010/RSN6953_DARFIELD_PRPCW.AT2", {}, "W", 0.005, 10800, 0.1981),
    ("formats/peer/RSN763_LOMAP_GIL067.AT2", {}, "067", 0.005, 7999, 0.3585),
    ("formats/peer/RSN763_LOMAP_GIL337.AT2", {}, "337", 0.005, 7999, 0.3266),
    ("formats/geonet/20161113_110259_WTMC_20.V1A", {}, "N28W", 0.005, 65536, 1.1243),
    ("formats/geonet/20161113_110259_WTMC_20.V1A", {}, "S62W", 0.005, 65536, 0.9412),
    ("formats/geonet/20161113_110259_WTMC_20.V1A", {}, "UP", 0.005, 65536, 3.2163),
    ("formats/geonet/20161113_110259_WTMC_20.V2A", {}, "N28W", 0.02, 8192, 0.9925),
    ("formats/geonet/20161113_110259_WTMC_20.V2A", {}, "S62W", 0.02, 8192, 0.8123),
    ("formats/geonet/20161113_110259_WTMC_20.V2A", {}, "UP", 0.02, 8192, 1.8377),
    ("formats/cosmos/us1000hyfh_akbmrp_AKBMR--n.1000hyfh.BNZ.--.acc.V2c", {}, "BNZ", 0.005,
     42000, 0.0070),
    ("formats/knet/AOM0011801241951.EW", {}, "EW", 0.01, 10200, 4.078 / 980.665),
    ("formats/knet/AOM0011801241951.NS", {}, "NS", 0.01, 10200, 4.954 / 980.665),
    ("formats/knet/AOM0011801241951.UD", {}, "UD", 0.01, 10200, 2.240 / 980.665),
    # weak motion (0.14 and 0.62 gal): below PGA_RANGE_G, read on purpose
    ("formats/kiknet/NGNH311106302345.NS1", {"allow_unusual": True}, "NS1", 0.01, 12000,
     0.141 / 980.665),
    ("formats/kiknet/NGNH311106302345.NS2", {"allow_unusual": True}, "NS2", 0.01, 12000,
     0.618 / 980.665),
    ("formats/kiknet/AICH040010061330.NS2", {}, "NS2", 0.005, 28600, 5.605 / 980.665),
    ("formats/dmg/CE89146.V1", {}, "360", 0.005, 13200, 0.0792),
    ("formats/dmg/CE89146.V1", {}, "UP", 0.005, 13200, 0.0211),
    ("formats/dmg/CE89146.V1", {}, "090", 0.005, 13200, 0.0453),
    ("formats/dmg/CE89146.V2", {}, "360", 0.005, 12000, 0.0788),
    ("formats/dmg/CE89146.V2", {}, "UP", 0.005, 12000, 0.0209),
    ("formats/dmg/CE89146.V2", {}, "090", 0.005, 12000, 0.0451),
    ("formats/smc/0111a.smc", {}, "360", 0.005, 6001, 0.1065),
    ("formats/usc/017m30bt.s0a", {}, "N08W", 0.02, 1887, 0.2472),
]


@pytest.mark.parametrize(("file", "kwargs", "channel", "dt", "npts", "pga_g"), PROVENANCE,
                         ids=[f"{p[0].split('/')[-1]}-{p[2]}" for p in PROVENANCE])
def test_reads_provenance_record(file, kwargs, channel, dt, npts, pga_g):
    st = R.read(record_file(file), **kwargs)
    tr = st.select(channel=channel)[0] if channel else st[0]
    assert tr.stats.delta == pytest.approx(dt, rel=1e-9)
    assert tr.stats.npts == npts
    assert np.abs(tr.data).max() / G_N == pytest.approx(pga_g, abs=6e-5, rel=1e-3)
    assert tr.stats.units == "m/s2"
    assert tr.stats.processing[0].startswith("urmx.records.read")


def test_knet_file_of_known_counts(tmp_path):
    """The K-NET/KiK-net reader on a synthetic file (the NIED samples are not shipped):
    counts x scale factor in gal, mean removed, to m/s2, at the stated sampling rate; the
    header's peak is the record's; the format is detected from the text."""
    from urmx.records import readers

    from .helpers.synthetic import knet_text

    t = np.arange(1203) * 0.01
    counts = np.round(-12000 + 4000 * np.sin(2 * np.pi * 1.5 * t) * np.exp(-t)).astype(int)
    gal = (counts - counts.mean()) * 3920 / 6182761
    path = tmp_path / "SYN0010001010000.NS"
    path.write_text(knet_text(counts, direction="N-S", max_acc_gal=np.abs(gal).max()),
                    encoding="ascii")
    assert readers.detect_format(path) == "knet"
    (tr,) = R.read(path)
    assert (tr.stats.channel, tr.stats.delta, tr.stats.npts) == ("NS", 0.01, 1203)
    assert tr.stats.units == "m/s2"
    np.testing.assert_allclose(tr.data, gal * 0.01, rtol=0, atol=1e-15)
    assert tr.stats.record.header_pga == pytest.approx(np.abs(gal).max() * 0.01, abs=5e-6)


@pytest.mark.parametrize("file", ["formats/peer/RSN763_LOMAP_GIL067.AT2",
                                  "formats/geonet/20161113_110259_WTMC_20.V2A",
                                  "formats/dmg/CE89146.V2", "formats/smc/0111a.smc",
                                  "formats/usc/017m30bt.s0a"])
def test_pga_matches_header(sample_records, file):
    """Headers that state a peak agree with the data (AT2: PROVENANCE, no header peak)."""
    for tr in R.read(sample_records / file):
        pga = np.abs(tr.data).max()
        header = tr.stats.record.header_pga
        if header is None:  # PEER AT2 headers carry no peak
            assert pga / G_N == pytest.approx(0.3585, abs=5e-5)
        else:
            assert pga == pytest.approx(header, rel=2e-3)


@pytest.mark.parametrize(("file", "channel", "dt", "pga_g"), [
    ("bigbear1992/NEWPORT.RAW", "090", 0.005, 0.0549),
    ("bigbear1992/NEWPORT.RAW", "360", 0.005, 0.0432),
    ("formats/smc/891018_1.sma-1.0444a.smc", "065", 0.001, 0.0818),
    ("formats/usc/017m30cc.y0a", "N00W", 0.004, 0.4064),
])
def test_uneven_records_resampled_with_warning(sample_records, file, channel, dt, pga_g):
    with pytest.warns(UrmxWarning, match="unevenly sampled"):
        st = R.read(sample_records / file)
    tr = st.select(channel=channel)[0]
    assert tr.stats.delta == dt
    assert np.abs(tr.data).max() / G_N == pytest.approx(pga_g, rel=0.02)
    assert any("resampled" in step for step in tr.stats.processing)


def test_penzien_el_centro_comment_count_warns(records_dir):
    with pytest.warns(UrmxWarning, match="1559 points but the file holds 1560"):
        tr = R.read(records_dir / "elcentro1940/elcentro.dat")[0]
    assert (tr.stats.delta, tr.stats.npts) == (0.02, 1560)
    assert np.abs(tr.data).max() / G_N == pytest.approx(0.3188, abs=5e-5)


@pytest.mark.parametrize(("file", "match"), [
    ("formats/cosmos/NP8040-n.1000hyfh.HNE.01.V0c", "raw digitiser counts"),
    ("formats/dmg/CE89146.V3", "spectra, no acceleration history"),
])
def test_refused_files(sample_records, file, match):
    with pytest.raises(R.UnsupportedRecordError, match=match) as err:
        R.read(sample_records / file)
    assert Path(file).name in str(err.value)


# -- clear errors -------------------------------------------------------------------------


@pytest.fixture
def at2(tmp_path):
    def make(npts_header=8, values=None, unit="G"):
        values = np.arange(1, 9) * 0.01 if values is None else values
        path = tmp_path / "rec.AT2"
        path.write_text(at2_text(at2_rows(values), unit=unit, npts=npts_header))
        return path
    return make


def test_good_synthetic_at2(at2):
    tr = R.read(at2())[0]
    assert tr.stats.npts == 8 and tr.stats.delta == 0.01
    np.testing.assert_allclose(tr.data, np.arange(1, 9) * 0.01 * G_N, rtol=1e-12)


@pytest.mark.parametrize(("make_kwargs", "read_kwargs", "error", "match"), [
    ({"npts_header": 12}, {}, R.TruncatedRecordError, "announces 12 points but the file holds 8"),
    ({"npts_header": 6}, {}, R.PointCountError, "wrong point count"),
    ({"values": np.array([0.1, np.nan, 0.2])}, {}, R.NonFiniteError, "NaN"),
    ({"npts_header": 3, "values": np.array([0.1, np.inf, 0.2])}, {}, R.NonFiniteError, "NaN"),
    ({}, {"unit": "cm/s2"}, R.RecordUnitError, r"states unit 'g' \(header\) but unit='cm/s2'"),
    ({}, {"unit": "gal"}, R.RecordUnitError, "not one of"),
    ({"unit": "FURLONGS"}, {}, R.RecordUnitError, "unknown unit"),
    ({}, {"dt": 0.02}, R.MissingTimeStepError, "file states dt=0.01"),
    ({}, {"format": "mseed"}, R.UnknownFormatError, "ObsPy cannot read"),
])
def test_clear_errors(at2, make_kwargs, read_kwargs, error, match):
    if "values" in make_kwargs and "npts_header" not in make_kwargs:
        make_kwargs["npts_header"] = len(make_kwargs["values"])
    path = at2(**make_kwargs)
    with pytest.raises(error, match=match) as err:
        R.read(path, **read_kwargs)
    assert isinstance(err.value, ValueError)
    assert str(path) in str(err.value)


def test_truncated_real_files(sample_records, tmp_path):
    for name in ("formats/peer/RSN763_LOMAP_GIL067.AT2",
                 "formats/geonet/20161113_110259_WTMC_20.V2A", "formats/dmg/CE89146.V2"):
        lines = (sample_records / name).read_bytes().splitlines(keepends=True)
        cut = tmp_path / Path(name).name
        cut.write_bytes(b"".join(lines[: len(lines) // 2 + 7]))
        with pytest.raises(R.RecordError, match=str(cut)):
            R.read(cut)


def test_unknown_format_and_unit_mistakes(tmp_path, records_dir):
    junk = tmp_path / "notes.txt"
    junk.write_text("this is not\nan accelerogram\n")
    with pytest.raises(R.UnknownFormatError, match="unknown record format"):
        R.read(junk)
    empty = tmp_path / "empty.dat"
    empty.write_text("")
    with pytest.raises(R.UnknownFormatError, match="empty"):
        R.read(empty)
    src = records_dir / "elcentro1940/elcentro_S00E_1940.dat"
    with pytest.raises(R.RecordUnitError, match="unit is wrong"):
        R.read(src, dt=0.02, unit="g")  # cm/s2 values taken for g: PGA 342 g
    with pytest.raises(R.RecordUnitError, match="does not state its unit"):
        R.read(src, dt=0.02)
    with pytest.raises(R.MissingTimeStepError, match="pass dt="):
        R.read(src, unit="cm/s2")
    with pytest.raises(FileNotFoundError, match="does not exist"):
        R.read(tmp_path / "missing.AT2")


# -- measures: closed forms ---------------------------------------------------------------


def _trace(data, dt):
    from obspy import Trace

    tr = Trace(np.asarray(data, dtype=float))
    tr.stats.delta = dt
    return tr


def test_arias_intensity_of_a_sine():
    amp, f, dt, cycles = 2.0, 2.0, 0.001, 10
    t = np.arange(int(round(cycles / f / dt)) + 1) * dt
    ds = R.measures(_trace(amp * np.sin(2 * np.pi * f * t), dt))
    closed = np.pi / (2 * G_N) * amp**2 * t[-1] / 2  # pi/(2g) * integral of A^2 sin^2
    assert float(ds.arias_intensity) == pytest.approx(closed, rel=1e-6)
    assert float(ds.significant_duration) == pytest.approx(0.9 * t[-1], rel=2e-3)
    assert float(ds.pga) == pytest.approx(amp, rel=1e-6)
    for var in ds.data_vars.values():
        assert var.attrs["units"] and var.attrs["long_name"]


def test_response_spectrum_zero_period_limit(records_dir):
    tr = R.load("elcentro", records_dir)
    pga = np.abs(tr.data).max()
    rs = R.response_spectrum(tr, periods=[0.0, 1e-9])
    assert float(rs.psa[0]) == pga
    assert float(rs.psa[1]) == pytest.approx(pga, rel=1e-6)
    assert float(rs.sa[1]) == pytest.approx(pga, rel=1e-6)
    assert rs.psa.attrs["units"] == "m s-2" and rs.period.attrs["units"] == "s"


def test_harmonic_input_at_resonance():
    """u(t) = -(a0/w^2)/(2 zeta) [e^{-zeta w t}(cos wd t + zeta/sqrt(1-zeta^2) sin wd t)
    - cos w t] for ground acceleration a0 sin(w t) with the oscillator at resonance."""
    period, zeta, a0 = 0.5, 0.05, 1.0
    w = 2 * np.pi / period
    dt = period / 4000
    t = np.arange(int(round(6 * period / dt)) + 1) * dt
    u = R.sdof_displacement(a0 * np.sin(w * t), dt, period, zeta)
    wd = w * np.sqrt(1 - zeta**2)
    closed = -(a0 / w**2) / (2 * zeta) * (
        np.exp(-zeta * w * t) * (np.cos(wd * t) + zeta / np.sqrt(1 - zeta**2) * np.sin(wd * t))
        - np.cos(w * t))
    scale = np.abs(closed).max()
    assert np.abs(u - closed).max() / scale < 1e-6
    rs = R.response_spectrum(_trace(a0 * np.sin(w * t), dt), periods=[period], damping=zeta)
    assert float(rs.sd[0]) == pytest.approx(scale, rel=1e-6)


def test_fourier_and_frequency_range_of_a_sine():
    dt, f = 0.005, 4.0
    t = np.arange(8000) * dt
    tr = _trace(np.sin(2 * np.pi * f * t) * np.hanning(t.size), dt)
    lo, hi = R.significant_frequency_range(tr)
    assert lo < f < hi and hi - lo < 0.2
    fas = R.fourier_spectrum(tr)
    assert fas.attrs["units"] == "m s-1" and fas.frequency.attrs["units"] == "Hz"
    assert float(fas.frequency[int(np.argmax(fas.values))]) == pytest.approx(f, rel=0.03)


@pytest.mark.parametrize("n, dt", [(150, 0.02), (2688, 0.02), (10998, 0.0025)])
def test_banded_konno_ohmachi_is_the_full_weight_matrix(n, dt):
    """The banded smoothing (each centre sums only the bins of its main lobe) gives the
    full weight matrix's result to rounding, zeros where it has zeros (no bin in a band);
    a bandwidth that changes the band changes the result (the comparison can fail)."""
    import importlib

    M = importlib.import_module("urmx.records.measures")  # (urmx.records.measures is the function)

    acc = np.random.default_rng(n).standard_normal(n)
    freq, amp = M._fas(acc, dt)
    centres = np.geomspace(0.05, 0.5 / dt, 300)
    banded = M._konno_ohmachi(freq, amp, centres, 40.0)
    full = M._konno_ohmachi_full(freq, amp, centres, 40.0)
    assert np.array_equal(banded == 0, full == 0)
    assert np.max(np.abs(banded - full)) <= 1e-13 * np.max(full)
    assert np.max(np.abs(M._konno_ohmachi(freq, amp, centres, 20.0) - full)) > 1e-3 * np.max(full)


def test_processing_steps_recorded(records_dir):
    tr = R.load("christchurch", records_dir)
    out = R.process(tr, freqmin=0.1, freqmax=25.0, dt=0.01, target_pga=0.185 * G_N)
    assert out.stats.delta == 0.01
    assert np.abs(out.data).max() == pytest.approx(0.185 * G_N, rel=1e-12)
    steps = " ".join(out.stats.processing)
    for word in ("detrend", "taper", "filter", "resample", "urmx.records.scale"):
        assert word in steps
    assert len(tr.stats.processing) < len(out.stats.processing)  # input untouched


# -- manifest -----------------------------------------------------------------------------


def test_manifest_paper_records(records_dir):
    m = R.manifest(records_dir)
    for rid in ("elcentro", "nahanni", "christchurch", "bigbear"):
        assert rid in m and Path(m[rid]["path"]).is_file()
    assert sum(e["set"] == "fema-p695-far-field" for e in m.values()) == 40
    assert "p695-01-mul009" in m
    assert m["elcentro"]["paper_scale_factor"] == 0.5 == m["elcentro"]["scale_factor"]
    assert m["nahanni"]["paper_scale_factor"] == 4.0 and m["nahanni"]["substitute"]
    assert m["christchurch"]["file"] == "darfield2010/RSN6953_DARFIELD_PRPCW.AT2"


@pytest.mark.parametrize(("rid", "npts", "dt", "pga_g", "scaled_pga_g"), [
    ("elcentro", 2688, 0.02, 0.3484, None),
    ("nahanni", 4038, 0.005, 0.9778, 0.92),
    ("christchurch", 10800, 0.005, 0.1981, 0.185),
    ("bigbear", 12001, 0.005, 0.0906, None),
])
def test_load_paper_records(records_dir, rid, npts, dt, pga_g, scaled_pga_g):
    tr = R.load(rid, records_dir)
    assert (tr.stats.npts, tr.stats.delta) == (npts, dt)
    pga = np.abs(tr.data).max() / G_N
    assert pga == pytest.approx(pga_g, abs=5e-5)
    if scaled_pga_g is not None:
        assert pga * tr.stats.record.scale_factor == pytest.approx(scaled_pga_g, rel=1e-6)


def test_checksum_mismatch_and_missing_file(records_dir, tmp_path):
    fake = tmp_path / "elcentro1940"
    fake.mkdir()
    data = (records_dir / "elcentro1940/elcentro_S00E_1940.dat").read_bytes()
    (fake / "elcentro_S00E_1940.dat").write_bytes(data.replace(b"12.540", b"12.541", 1))
    with pytest.raises(R.ChecksumError, match="elcentro_S00E_1940.dat.*satish-annigeri"):
        R.load("elcentro", tmp_path)
    # the user's folder wins only for the records it holds: nahanni from the shipped one
    assert R.load("nahanni", tmp_path).stats.npts == 4038
    assert R.manifest(tmp_path)["nahanni"]["folder"] == str(shipped_records())
    with pytest.raises(R.ManifestError, match="did you mean"):
        R.load("elcentr", tmp_path)
    own = tmp_path / "manifest.toml"  # a record of the folder's own manifest, file missing
    entry = dict(R.manifest()["nahanni"], id="mine", file="gone/NS1-010")
    R.write_manifest([entry], own)
    with pytest.raises(FileNotFoundError, match="gone/NS1-010.*maddyblue/slammer"):
        R.load("mine", tmp_path)


def test_a_manifest_is_parsed_once_while_its_file_stays_the_same(tmp_path, monkeypatch):
    """A study loads each record through the manifest: it is parsed and checked once, and
    again as soon as its file changes (an edit of the same size is seen by its time);
    what a caller changes in an entry does not reach the next caller."""
    import importlib
    import os

    M = importlib.import_module("urmx.records.manifest")
    parsed = []
    parse = M._parse_manifest
    own = tmp_path / "manifest.toml"
    monkeypatch.setattr(M, "_parse_manifest",
                        lambda src: (src == own and parsed.append(src)) or parse(src))
    R.write_manifest([dict(R.manifest()["nahanni"], id="mine")], own)
    first = M._read_manifest(own)
    first[0]["dt"] = -1.0  # a caller's change stays its own
    again = M._read_manifest(own)
    assert len(parsed) == 1 and again[0]["dt"] == R.manifest()["nahanni"]["dt"]
    st = own.stat()
    own.write_text(own.read_text().replace('id = "mine"', 'id = "ours"'))
    os.utime(own, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    assert [e["id"] for e in M._read_manifest(own)] == ["ours"] and len(parsed) == 2


def test_shipped_records_are_the_manifests():
    """Every file of the shipped records folder but the format samples (their own test
    follows) is a record file of the manifest with its SHA-256 (or one of the folder's own
    documents), and PROVENANCE.md lists each with that SHA-256: the records travel with
    their attribution."""
    import hashlib

    folder = shipped_records()
    entries = R.manifest(folder)
    by_file = {e["file"]: e["sha256"] for e in entries.values()}
    provenance = (folder / "PROVENANCE.md").read_text(encoding="utf-8")
    own = {"manifest.toml", "PROVENANCE.md", "INGEST.md", "library/catalog.tsv"}
    files = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()
                   and not p.relative_to(folder).as_posix().startswith("formats/"))
    assert set(files) - own == set(by_file)  # no file without a record, no record without
    for rel, digest in by_file.items():
        assert hashlib.sha256((folder / rel).read_bytes()).hexdigest() == digest, rel
        assert f"| `{rel}` |" in provenance and f"`{digest}`" in provenance, rel
    assert len(by_file) == 47 and sum((folder / f).stat().st_size for f in by_file) < 4.5e6


def shipped_samples() -> list[dict]:
    """The format samples' manifest (``records/formats/manifest.toml``)."""
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib
    text = (shipped_records() / "formats" / "manifest.toml").read_text(encoding="utf-8")
    return tomllib.loads(text)["sample"]


def samples_problems(folder: Path, samples: list[dict]) -> list[str]:
    """What is wrong with the format samples of a records folder against their manifest:
    a file without an entry or an entry without its file, a SHA-256 that differs, a file
    PROVENANCE.md does not list with that SHA-256, a file urmx reads as another format, or
    reads where the manifest says it refuses it (or the other way round)."""
    from urmx.records import readers

    problems = []
    rows = {}
    for line in (folder / "PROVENANCE.md").read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("| `formats/") and len(cells) > 2:
            rows[cells[0].strip("`")] = cells[-1].strip("`")
    listed = {s["file"] for s in samples}
    found = {p.relative_to(folder).as_posix() for p in (folder / "formats").rglob("*")
             if p.is_file()} - {"formats/manifest.toml"}
    problems += [f"{f}: no entry" for f in sorted(found - listed)]
    problems += [f"{f}: no file" for f in sorted(listed - found)]
    for s in samples:
        path = folder / s["file"]
        if not path.is_file():
            continue
        if hashlib.sha256(path.read_bytes()).hexdigest() != s["sha256"]:
            problems.append(f"{s['file']}: sha256 differs")
        if rows.get(s["file"]) != s["sha256"]:
            problems.append(f"{s['file']}: its PROVENANCE.md row lacks its sha256")
        try:
            outcome = readers.detect_format(path)
            with warnings.catch_warnings():  # (the film records are resampled: said)
                warnings.simplefilter("ignore", UrmxWarning)
                R.read(path, allow_unusual=True)
        except readers.UnsupportedRecordError:
            outcome = "refused"
        except R.RecordError as exc:
            outcome = f"an error ({exc})"
        expected = s["format"] if s["reads"] else "refused"
        if outcome != expected:
            problems.append(f"{s['file']}: urmx gives {outcome}, manifest {expected}")
    return problems


def test_shipped_format_samples_are_their_manifests(tmp_path):
    """The 13 reader-format samples ship in ``records/formats`` (a clone runs the readers'
    tests alone; the K-NET and KiK-net ones do not ship, NIED's terms): each is in its
    manifest with its SHA-256, in its own row of PROVENANCE.md with that SHA-256, and read
    as the manifest's format (two refused: raw counts, spectra). The check finds a changed
    byte, a stray file, a missing file, a row with another SHA-256 and a wrong format."""
    samples = shipped_samples()
    assert len(samples) == 13
    assert {s["format"] for s in samples} == {"peer", "geonet", "cosmos", "dmg", "smc"}
    assert not (shipped_records() / "formats" / "knet").exists()
    assert [s["file"] for s in samples if not s["reads"]] == [
        "formats/cosmos/NP8040-n.1000hyfh.HNE.01.V0c", "formats/dmg/CE89146.V3"]
    assert samples_problems(shipped_records(), samples) == []
    bad = tmp_path / "records"
    shutil.copytree(shipped_records(), bad)
    target = bad / samples[0]["file"]
    data = bytearray(target.read_bytes())
    last = max(i for i, b in enumerate(data) if chr(b).isdigit())  # still a number
    data[last] = ord("5") if data[last] != ord("5") else ord("6")
    target.write_bytes(bytes(data))
    (bad / "formats" / "peer" / "stray.AT2").write_text("x", encoding="utf-8")
    (bad / "formats" / "peer" / "manifest.toml").write_text("", encoding="utf-8")
    gone = bad / "formats" / "usc" / "017m30bt.s0a"
    gone.unlink()
    provenance = bad / "PROVENANCE.md"
    text = provenance.read_text(encoding="utf-8")
    sha = {s["file"]: s["sha256"] for s in samples}
    v2a, v1a = (sha[f"formats/geonet/20161113_110259_WTMC_20.{e}"] for e in ("V2A", "V1A"))
    row = next(ln for ln in text.splitlines() if ln.startswith("| `formats/geonet/") and
               ln.rstrip().endswith(f"`{v2a}` |"))
    provenance.write_text(text.replace(row, row.replace(v2a, v1a)), encoding="utf-8")
    wrong = [dict(s, format="geonet") if s["format"] == "smc" else
             dict(s, reads=True) if s["file"].endswith(".V3") else s for s in samples]
    assert samples_problems(bad, wrong) == [
        "formats/peer/manifest.toml: no entry",
        "formats/peer/stray.AT2: no entry",
        "formats/usc/017m30bt.s0a: no file",
        f"{samples[0]['file']}: sha256 differs",
        "formats/geonet/20161113_110259_WTMC_20.V2A: its PROVENANCE.md row lacks its sha256",
        "formats/dmg/CE89146.V3: urmx gives refused, manifest dmg",
        "formats/smc/0111a.smc: urmx gives smc, manifest geonet",
        "formats/smc/891018_1.sma-1.0444a.smc: urmx gives smc, manifest geonet"]


def test_library_against_catalog(records_dir):
    with open(records_dir / "library/catalog.tsv") as fh:
        catalog = {r["path"]: r for r in csv.DictReader(fh, delimiter="\t")}
    lib = [e for e in R.manifest(records_dir).values() if e["set"] == "fema-p695-far-field"]
    assert len(lib) == len(catalog) == 40
    for e in lib:
        tr = R.load(e["id"], records_dir)
        ds = R.measures(tr)
        R.response_spectrum(tr)
        row = catalog[e["file"].removeprefix("library/")]
        assert tr.stats.delta == float(row["dt_s"]) and tr.stats.npts == int(row["npts"])
        assert float(ds.pga) / G_N == pytest.approx(float(row["pga_g"]), abs=5e-5)


# -- command line -------------------------------------------------------------------------


def test_cli(records_dir, sample_records, tmp_path, capsys):
    from urmx.cli import main

    assert main(["records", "--records", str(records_dir), "list", "--set", "paper"]) == 0
    assert "nahanni" in capsys.readouterr().out
    assert main(["records", "--records", str(records_dir), "show", "elcentro"]) == 0
    out = capsys.readouterr().out
    assert "arias_intensity" in out and "0.3484 g" in out
    assert main(["records", "show", str(sample_records / "formats/dmg/CE89146.V3")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "CE89146.V3" in err and "Traceback" not in err
    png = tmp_path / "nahanni.png"
    assert main(["records", "--records", str(records_dir), "plot", "nahanni", "--out",
                 str(png)]) == 0
    assert png.stat().st_size > 10_000


def test_plot_has_three_panels(records_dir):
    from urmx.records.plot import plot_record

    fig = plot_record(R.load("elcentro", records_dir), paper_range_hz=(0.2, 7.0))
    assert len(fig.axes) == 3 and len(fig.axes[1].patches) == 2
    assert fig.axes[1].get_xlabel() == "frequency [Hz]"


def test_read_copy_elsewhere_detects_format_from_content(sample_records, tmp_path):
    """The file name carries no hint: the content decides."""
    for src in ("formats/peer/RSN763_LOMAP_GIL067.AT2", "formats/geonet/"
                "20161113_110259_WTMC_20.V2A", "formats/dmg/CE89146.V2", "formats/smc/0111a.smc"):
        dst = tmp_path / "record.bin"
        shutil.copy(sample_records / src, dst)
        assert R.detect_format(dst) == R.detect_format(sample_records / src)
        assert len(R.read(dst)) >= 1


def test_obspy_formats_and_columns(tmp_path):
    from obspy import Trace

    tr = Trace(np.sin(np.arange(500) * 0.1) * 0.3)
    tr.stats.delta = 0.01
    sac = tmp_path / "rec.sac"
    tr.write(str(sac), format="SAC")
    with pytest.raises(R.RecordUnitError, match="does not state its unit"):
        R.read(sac)
    st = R.read(sac, unit="g")
    assert st[0].stats.delta == pytest.approx(0.01)
    np.testing.assert_allclose(st[0].data, tr.data * G_N, rtol=1e-6)
    two = tmp_path / "two_columns.txt"
    t = np.array([0.0, 0.01, 0.021, 0.03, 0.04])
    two.write_text("\n".join(f"{a} {b}" for a, b in zip(t, [0, 1, 2, 1, 0], strict=True)))
    with pytest.warns(UrmxWarning, match="unevenly sampled"):
        out = R.read(two, format="slammer", unit="cm/s2", dt=0.01)[0]
    assert out.stats.npts == 5 and out.data.max() == pytest.approx(0.01 * (1 + 10 / 11))
    two.write_text("\n".join(f"{0.02 * k} {k}" for k in range(6)))
    even = R.read(two, unit="m/s2")[0]  # an even time column: no warning, dt from it
    assert even.stats.delta == pytest.approx(0.02) and even.data[-1] == 5


def test_relative_records_folder_is_made_absolute(tmp_path, monkeypatch):
    """A relative $URMX_RECORDS (`URMX_RECORDS=../my/records`) means the
    caller's working folder; records_dir returns it absolute, so that a worker or notebook
    kernel started in another folder reads the same one."""
    from urmx.config import records_dir

    (tmp_path / "my" / "records").mkdir(parents=True)
    (tmp_path / "checkout").mkdir()
    monkeypatch.chdir(tmp_path / "checkout")
    monkeypatch.setenv("URMX_RECORDS", "../my/records")
    found = records_dir()
    assert found.is_absolute()
    monkeypatch.chdir(tmp_path)  # elsewhere, the returned path names the same folder
    assert found.is_dir() and found.resolve() == (tmp_path / "my" / "records").resolve()
