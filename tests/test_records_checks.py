"""What a record file holds is checked, not assumed (issue 33 item 4 and 5; issue 34 rules 3,
4 and 7): real files of each kind from ObsPy's own test data (or built with ObsPy from
them) are refused with one line saying what was found, read with ``allow_unusual`` with
the override written to the processing steps (and so to a study archive), and an
accelerometer MiniSEED with its response is accepted; CSV files with a header row read to
the same trace as the bare numbers; manifest values are validated where they are read;
reading N samples takes memory proportional to N."""

from __future__ import annotations

import os
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

import urmx
import urmx.records as R
from urmx.config import data_dir
from urmx.errors import InputError
from urmx.records import checks

OBSPY = Path(__import__("obspy").__file__).parent
SAC_HHZ = OBSPY / "signal/tests/data/CRLZ.HHZ.10.NZ.SAC"  # broadband seismometer, float
SAC_BHE = OBSPY / "io/sac/tests/data/LMOW.BHE.SAC"
SAC_VOLTS = OBSPY / "io/sac/tests/data/seism.sac"  # IDEP = IVOLTS
MSEED_BHN = OBSPY / "io/mseed/tests/data/fullseed.mseed"  # BHN, BHZ, BHE counts
MSEED_HNZ = OBSPY / "io/ascii/tests/data/miniseed_record.mseed"  # CI.AGO HNZ counts
GSE_CALIB = OBSPY / "io/gse2/tests/data/acc.gse"  # CALIB 7.248


def _sac_with_idep(tmp_path: Path, idep: str) -> Path:
    """LMOW.BHE.SAC with its header stating `idep` and its channel a strong-motion one
    (HNE), so that only the stated quantity is wrong."""
    import obspy

    tr = obspy.read(str(SAC_BHE))[0]
    tr.data = (tr.data / np.abs(tr.data).max() * 200.0).astype(np.float32)  # 0.2 g in cm/s2
    tr.stats.channel = "HNE"
    tr.stats.sac = {"idep": {"IVEL": 7, "IDISP": 6, "IACC": 8}[idep]}
    out = tmp_path / f"lmow-{idep}.sac"
    tr.write(str(out), format="SAC")
    return out


@pytest.mark.parametrize("idep, quantity", [("IVEL", "velocity"), ("IDISP", "displacement")])
def test_sac_stating_velocity_or_displacement_is_refused(tmp_path, idep, quantity):
    path = _sac_with_idep(tmp_path, idep)
    with pytest.raises(R.UnusualRecordError, match=f"IDEP = {idep}: it holds {quantity}, not "
                       "acceleration.*allow_unusual=True"):
        R.read(path, unit="cm/s2")
    tr = R.read(path, unit="cm/s2", allow_unusual=True)[0]
    assert any(s.startswith(f"urmx: allow_unusual overrode: channel 'HNE': its SAC header "
                            f"states IDEP = {idep}") for s in tr.stats.processing)
    # the same file stating acceleration reads without a word
    ok = R.read(_sac_with_idep(tmp_path, "IACC"), unit="cm/s2")[0]
    assert not any("overrode" in s for s in ok.stats.processing)
    np.testing.assert_array_equal(ok.data, tr.data)


@pytest.mark.parametrize("path, channel, what", [
    (SAC_HHZ, "HHZ", "a high-gain seismometer"),
    (MSEED_BHN, "BHN", "a high-gain seismometer"),
    (SAC_VOLTS, None, "IDEP = IVOLTS"),
])
def test_seismometer_files_are_refused(path, channel, what):
    """The red team's files: read with --unit cm/s2 they gave PGA 9.64 g, PGV 1,087 m/s.
    Now the channel code or the header says what they are."""
    with pytest.raises(R.UnusualRecordError, match=what):
        R.read(path, unit="cm/s2", channel=channel)
    tr = R.read(path, unit="cm/s2", channel=channel, allow_unusual=True)[0]
    assert what in next(s for s in tr.stats.processing if "overrode" in s)


def test_an_override_keeps_every_problem_in_the_processing():
    """HHZ in counts read as cm/s2 on purpose: the seismometer channel and the impossible
    velocity are both written down."""
    tr = R.read(SAC_HHZ, unit="cm/s2", allow_unusual=True)[0]
    overrides = [s for s in tr.stats.processing if "overrode" in s]
    assert "SEED code of a high-gain seismometer" in overrides[0]
    assert any("would have PGV" in s and "beyond the 5 m/s and 10 m" in s for s in overrides)


def test_gse_calibration_is_refused():
    with pytest.raises(R.UnusualRecordError, match=r"instrument calibration \(CALIB 7.248"):
        R.read(GSE_CALIB, unit="cm/s2")
    tr = R.read(GSE_CALIB, unit="cm/s2", allow_unusual=True)[0]
    assert any("overrode" in s and "CALIB 7.248" in s for s in tr.stats.processing)


def _response_inventory(tmp_path: Path, gain: float) -> Path:
    """A StationXML file for CI.AGO..HNZ: a flat accelerometer of `gain` counts per m s-2
    (built with ObsPy)."""
    from obspy import UTCDateTime
    from obspy.core.inventory import Channel, Inventory, Network, Station
    from obspy.core.inventory.response import Response

    resp = Response.from_paz(zeros=[], poles=[], stage_gain=gain, input_units="M/S**2",
                             output_units="COUNTS")
    cha = Channel("HNZ", "", 34.1, -118.1, 0.0, 0.0, sample_rate=100.0, response=resp,
                  start_date=UTCDateTime(2000, 1, 1))
    sta = Station("AGO", 34.1, -118.1, 0.0, channels=[cha])
    path = tmp_path / "ago.xml"
    Inventory(networks=[Network("CI", stations=[sta])], source="urmx test").write(
        str(path), format="STATIONXML")
    return path


def test_accelerometer_miniseed_needs_its_response(tmp_path):
    """CI.AGO HNZ (an accelerometer, counts): refused without a response, read to m s-2
    with one (counts / gain, within the response removal's taper and water level)."""
    import obspy

    counts = obspy.read(str(MSEED_HNZ))[0].data.astype(float)
    with pytest.raises(R.UnusualRecordError, match=r"integers \(int32\) and no instrument "
                       "response"):
        R.read(MSEED_HNZ, unit="m/s2")
    forced = R.read(MSEED_HNZ, unit="m/s2", allow_unusual=True)[0]
    assert any("overrode" in s and "no instrument response" in s
               for s in forced.stats.processing)
    gain = 400.0  # counts per m s-2: the record's +-857 counts about its mean are 2.1 m/s2
    tr = R.read(MSEED_HNZ, response=_response_inventory(tmp_path, gain))[0]
    assert tr.stats.channel == "HNZ"
    assert tr.stats.record.unit_in_file == "m/s2"
    assert not any("overrode" in s for s in tr.stats.processing)
    assert any("response of ago.xml removed" in s for s in tr.stats.processing)
    expected = (counts - counts.mean()) / gain  # remove_response demeans first
    middle = slice(40, -40)  # away from the 5 % taper at each end
    np.testing.assert_allclose(tr.data[middle], expected[middle], rtol=0,
                               atol=1e-3 * np.abs(expected).max())


def test_pgv_and_pgd_bounds(records_dir):
    """El Centro S00E (PGV 0.333 m/s, the published 0.335 m/s; PGD 0.158 m) passes; the
    same record x 16 (PGA 5.6 g: within the PGA range) has PGV 5.34 m/s and is refused."""
    tr = R.load("elcentro", records_dir)
    pgv, pgd = checks.motion(tr.data, tr.stats.delta)
    assert pgv == pytest.approx(0.333, abs=0.001) and pgd == pytest.approx(0.158, abs=0.001)
    assert checks.motion_problem(tr.data, tr.stats.delta, "as given") is None
    problem = checks.motion_problem(16 * tr.data, tr.stats.delta, "as given")
    assert "PGV 5.34 m/s" in problem
    # a sine of 1 m/s2 at 1 Hz: v = 1/(2 pi) m/s, d = 1/(2 pi)^2 m, exactly
    dt = 0.001
    t = np.arange(0, 20, dt)
    pgv, pgd = checks.motion(np.sin(2 * np.pi * t), dt)
    assert pgv == pytest.approx(1 / (2 * np.pi), rel=2e-3)
    assert pgd == pytest.approx(1 / (2 * np.pi) ** 2, rel=2e-2)


# -- a stated unit must agree with the values (issue 34 rule 4) -------------------------


def _at2(tmp_path: Path, src: Path, name: str, unit_line: str | None = None,
         factor: float = 1.0, npts: str | None = None) -> Path:
    lines = src.read_text(encoding="latin-1").splitlines(keepends=True)
    if unit_line is not None:
        lines[2] = unit_line
    if npts is not None:
        lines[3] = f"NPTS= {npts}, DT=   .0050 SEC\n"
        lines = lines[:4]
    body = [" ".join(f"{float(v) * factor:.7E}" for v in ln.split()) + "\n"
            for ln in lines[4:]]
    out = tmp_path / name
    out.write_text("".join(lines[:4] + body), encoding="latin-1")
    return out


def test_at2_header_and_values_must_agree(records_dir, tmp_path):
    """The Darfield AT2 (0.198 g): its values in m/s2 under UNITS OF G read as a 1.94 g
    record; its values in g under UNITS OF M/S2 as a 0.0202 g one. Both are refused with
    both readings, and read on purpose with allow_unusual (the override kept)."""
    src = Path(R.manifest(records_dir)["christchurch"]["path"])
    in_ms2 = _at2(tmp_path, src, "ms2.AT2", factor=9.80665)
    with pytest.raises(R.UnusualRecordError, match=r"states unit 'g' \(header\), which makes "
                       r"it an unusually strong record of PGA 1.94 g; read as m/s2 its PGA "
                       r"would be 0.198 g"):
        R.read(in_ms2)
    units_line = "ACCELERATION TIME SERIES IN UNITS OF M/S2\n"
    in_g = _at2(tmp_path, src, "g.AT2", unit_line=units_line)
    with pytest.raises(R.UnusualRecordError, match=r"states unit 'm/s2' \(header\), which "
                       r"makes it a weak record of PGA 0.0202 g; read as g its PGA would be "
                       r"0.198 g"):
        R.read(in_g)
    tr = R.read(in_g, allow_unusual=True)[0]
    assert any("overrode" in s and "0.0202 g" in s for s in tr.stats.processing)
    # the original, stating g over values in g, reads without a word
    assert not any("overrode" in s for s in R.read(src)[0].stats.processing)
    with pytest.raises(R.PointCountError, match=r"line 4 states NPTS= 0: a record has at "
                       "least 2 samples"):
        R.read(_at2(tmp_path, src, "empty.AT2", npts="0"))
    with pytest.raises(R.UnusualRecordError, match="states a unit of velocity, not "
                       "acceleration"):
        R.read(_at2(tmp_path, src, "vel.AT2", unit_line="TIME SERIES IN UNITS OF CM/S\n"))


def test_an_override_reaches_the_archive(records_dir, make_study, tmp_path):
    """A study's own record read with allow_unusual: the archive's record_processing
    says what was overridden."""
    src = Path(R.manifest(records_dir)["christchurch"]["path"])
    _at2(tmp_path, src, "g.AT2", unit_line="ACCELERATION TIME SERIES IN UNITS OF M/S2\n")
    path = make_study('[study]\nname = "override"\nwalls = ["s12"]\ndiaphragms = ["D5"]\n'
                      'records = ["odd"]\ncor = 0.8\n\n[records.odd]\nfile = "g.AT2"\n'
                      "allow_unusual = true\n")
    ds = urmx.run_study(path, scheduler="serial", progress=False)
    processing = str(ds.record_processing.sel(record="odd").item())
    assert "urmx: allow_unusual overrode: channel 'W': the file states unit 'm/s2'" in processing


# -- CSV files with a header row (issue 33 item 5) ---------------------------------------


def _write(path: Path, head: str | None, rows) -> Path:
    lines = ([head] if head is not None else []) + [",".join(f"{v:.6f}" for v in r)
                                                   for r in rows]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_csv_with_a_header_row_reads_as_the_bare_numbers(records_dir, tmp_path):
    acc = R.load("elcentro", records_dir).data / R.STANDARD_GRAVITY
    t = np.arange(acc.size) * 0.02
    bare = R.read(_write(tmp_path / "bare.csv", None, zip(t, acc, strict=True)), unit="g")[0]
    one = R.read(_write(tmp_path / "one.txt", None, ((a,) for a in acc)), unit="g",
                 dt=0.02)[0]
    np.testing.assert_array_equal(bare.data, one.data)
    for head, kw in (("time,acc_g", {}), ("t [s], acceleration (g)", {}),
                     ("time_ms,acc [g]", {}), ("time,acc", {"unit": "g"})):
        times = t * 1000 if "ms" in head else t
        tr = R.read(_write(tmp_path / "h.csv", head, zip(times, acc, strict=True)), **kw)[0]
        np.testing.assert_array_equal(tr.data, bare.data)
        assert tr.stats.delta == pytest.approx(0.02, rel=1e-9)
    tr = R.read(_write(tmp_path / "acc.csv", "acc_g", ((a,) for a in acc)), dt=0.02)[0]
    np.testing.assert_array_equal(tr.data, bare.data)
    with pytest.raises(R.RecordUnitError, match="does not state its unit"):
        R.read(_write(tmp_path / "nounit.csv", "time,acc", zip(t, acc, strict=True)))


def test_csv_columns_are_never_guessed(tmp_path):
    t = np.arange(400) * 0.01
    a = 0.2 * np.sin(2 * np.pi * t)
    three = _write(tmp_path / "three.txt", None, zip(t, a, -a, strict=True))
    with pytest.raises(R.RecordError, match="every line holds 3 numbers and the first column "
                       "increases like a time: the columns are ambiguous"):
        R.read(three, unit="g")
    named = _write(tmp_path / "named.csv", "time,acc_x_g,acc_y_g", zip(t, a, -a, strict=True))
    with pytest.raises(R.ChannelError, match=r"holds 2 channels \(acc_x_g, acc_y_g\)"):
        R.read_channel(named)
    y = R.read_channel(named, channel="acc_y_g")
    np.testing.assert_allclose(y.data, -a * R.STANDARD_GRAVITY, atol=1e-5)  # 6 decimals
    odd = _write(tmp_path / "odd.csv", "time,pressure", zip(t, a, strict=True))
    with pytest.raises(R.RecordError, match="column 'pressure' that is neither time nor "
                       "acceleration"):
        R.read(odd, unit="g")


def test_a_sampling_rate_is_read_like_a_time_step(tmp_path):
    f = tmp_path / "rate.txt"
    f.write_text("# sampling rate = 100 Hz\n" + "\n".join(f"{v:.5f}" for v in
                 0.1 * np.sin(np.arange(500) * 0.1)) + "\n")
    assert R.read(f, unit="g")[0].stats.delta == pytest.approx(0.01)
    with pytest.raises(R.MissingTimeStepError, match=r"file states dt=0.01 s \(comment line "
                       r"1: '# sampling rate = 100 Hz'\) but dt=0.02 was given"):
        R.read(f, unit="g", dt=0.02)
    f.write_text("# sampling rate = 0 Hz\n1\n2\n")
    with pytest.raises(R.MissingTimeStepError, match="states a sampling rate that is not a "
                       "positive number"):
        R.read(f, unit="g")


# -- manifest values are validated where they are read (issue 34 rule 3) ----------------


@pytest.mark.parametrize("key, value, needs", [
    ("scale_factor", "0", "a positive number"), ("scale_factor", "-0.5", "a positive number"),
    ("scale_factor", "nan", "a positive number"), ("dt", "0", "a positive time step"),
    ("unit", '"furlong"', "one of g, m/s2"), ("npts", "1.5", "a whole number of points"),
])
def test_manifest_values_are_checked(records_dir, tmp_path, key, value, needs):
    entry = dict(R.manifest(records_dir)["elcentro"], id="mine")
    path = R.write_manifest([entry], tmp_path / "m.toml")
    text = path.read_text()
    path.write_text("\n".join(f"{key} = {value}" if ln.startswith(f"{key} = ") else ln
                              for ln in text.splitlines()) + "\n")
    with pytest.raises(R.ManifestError, match=rf"m.toml: record #1 \('mine'\): {key} = .* "
                       f"must be {needs}"):
        R.manifest(records_dir, path)


# -- memory proportional to the record (issue 34 rule 7) --------------------------------


def test_reading_n_samples_takes_memory_proportional_to_n(tmp_path):
    """A generated single-column record of 300,000 samples (2.9 MB of text): the traced
    peak while reading it is the file's bytes plus at most 6 x 8N (measured: 5.1 x 8N; the
    samples, the converted copy, two arrays for the velocity and displacement check and 6
    bytes a line of bookkeeping). Reading it as one Python object per value, as before,
    took about 39 x 8N."""
    n = 300_000
    k = np.arange(n)
    values = 0.2 * np.sin(k * 0.05) + 0.01 * np.sin(k * 1.7)
    path = tmp_path / "long.txt"
    np.savetxt(path, values, fmt="%.6f")
    size = os.path.getsize(path)
    tracemalloc.start()
    try:
        s = R.read_channel(path, dt=0.005, unit="g", allow_unusual=True)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert s.data.size == n
    assert peak <= size + 6 * 8 * n, f"peak {peak / 8 / n:.1f} x 8N"


# -- implausible walls and diaphragms (issue 33 item 4) ---------------------------------


def test_slenderness_and_diaphragm_frequency_are_checked():
    with pytest.raises(InputError, match=r"slenderness height/thickness = 6/0.05 = 120 lies "
                       "above the plausible 40"):
        urmx.Wall(thickness=0.05, height=6.0, crack_ratio=0.6, mass=500.0)
    assert urmx.Wall(thickness=0.05, height=6.0, crack_ratio=0.6, mass=500.0,
                     allow_unusual=True).allow_unusual
    urmx.Wall(thickness=0.15, height=6.0, crack_ratio=0.6, mass=500.0)  # h/t 40: plausible
    kw = dict(thickness=0.23, height=3.6, crack_ratio=0.6, density=1800.0, wall_length=5.0,
              diaphragm_weight=0.5, plan_area=50.0)
    with pytest.raises(InputError, match="diaphragm_frequency=200 Hz lies above the 20 Hz a "
                       "flexible timber diaphragm can have.*rigid"):
        urmx.Wall.in_building(**kw, diaphragm_frequency=200.0)
    w = urmx.Wall.in_building(**kw, diaphragm_frequency=20.0)
    assert w.diaphragm_frequency() == pytest.approx(20.0)
    assert urmx.Wall.in_building(**kw, diaphragm_frequency=200.0, allow_unusual=True)


def test_no_catalog_wall_or_diaphragm_trips_the_new_bounds():
    from urmx.catalog import load_catalog
    from urmx.model import MAX_DIAPHRAGM_FREQUENCY, MAX_SLENDERNESS

    cat = load_catalog()
    assert max(s.wall.height / s.wall.thickness for s in cat.walls.values()) \
        <= MAX_SLENDERNESS
    assert not any(s.wall.allow_unusual for s in cat.walls.values())
    flexible = [s.wall.diaphragm_frequency() for s in cat.walls.values()
                if np.isfinite(s.wall.diaphragm_frequency())]
    assert max(flexible) <= MAX_DIAPHRAGM_FREQUENCY


def test_format_says_what_sniffing_cannot(records_dir, tmp_path, capsys):
    """An AT2 whose first line is not PEER's and whose fourth is in the NGA-West2 order
    ("10800  .0050  NPTS, DT") is no format urmx can tell from its first bytes; --format
    peer reads it, in `urmx records show` and `urmx simulate` alike."""
    from urmx.cli import main

    src = Path(R.manifest(records_dir)["christchurch"]["path"])
    lines = src.read_bytes().split(b"\r\n")
    lines[0], lines[3] = b"Darfield 2010, PRPC W", b"  10800   .0050   NPTS, DT"
    odd = tmp_path / "prpc.txt"
    odd.write_bytes(b"\r\n".join(lines))
    assert main(["records", "show", str(odd)]) == 2
    assert "unknown record format" in capsys.readouterr().err
    assert main(["records", "show", str(odd), "--format", "peer"]) == 0
    out = capsys.readouterr().out
    assert "(peer channel W), dt 0.005 s, 10800 points" in out and "0.1981 g" in out
    wall = data_dir("catalog") / "examples/benchmark-wall.toml"
    assert main(["simulate", str(wall), str(odd), "--format", "peer"]) == 0
    assert main(["simulate", str(wall), "christchurch", "--format", "peer"]) == 2
    assert "--format and --response apply to record files" in capsys.readouterr().err


def test_cosmos_velocity_units_are_refused(sample_records, tmp_path):
    src = sample_records / "formats/cosmos/us1000hyfh_akbmrp_AKBMR--n.1000hyfh.BNZ.--.acc.V2c"
    text = src.read_text(encoding="latin-1")
    assert R.read(src)[0].stats.channel == "BNZ"
    odd = tmp_path / "vel.V2c"
    odd.write_text(text.replace("units=cm/sec2", "units=cm/sec", 1), encoding="latin-1")
    with pytest.raises(R.UnusualRecordError, match=r"states units=cm/sec \(velocity\), not an "
                       "acceleration"):
        R.read(odd)


def test_records_list_says_which_folder_each_record_comes_from(tmp_path, capsys):
    """A folder of the user's that holds one manifest record (El Centro): that record comes
    from it, every other from the shipped records."""
    from urmx.cli import main
    from urmx.config import shipped_records

    mine = tmp_path / "mine"
    (mine / "elcentro1940").mkdir(parents=True)
    name = "elcentro1940/elcentro_S00E_1940.dat"
    (mine / name).write_bytes((shipped_records() / name).read_bytes())
    assert main(["records", "list", "--records", str(mine), "--set", "paper"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == f"yours: 1 records from {mine} (your records folder)"
    assert out[1] == f"shipped: 2 records from {shipped_records()} (shipped with urmx)"
    assert out[3].split()[:2] == ["elcentro", "yours"]
    assert out[4].split()[:2] == ["nahanni", "shipped"]
    assert R.load("elcentro", mine).stats.npts == 2688
