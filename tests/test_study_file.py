"""Study files that say what they do (issues 22, 25, 29): own record files with their
provenance in the archive, own walls that keep their own diaphragm, one reference of every
key (`docs/study-files.md`) held to the loader, every value refused at load that would
fail later (or silently do something else), and t_rest as a study key (issue 32)."""

from __future__ import annotations

import hashlib
import re
import shutil
import unicodedata
from pathlib import Path

import numpy as np
import pytest

import urmx
import urmx.catalog as C
import urmx.study as st
import urmx.study.file as F
from urmx import kernel
from urmx.catalog import CatalogError, load_catalog
from urmx.study import kinds
from urmx.study.cells import Cells
from urmx.study.file import load_study
from urmx.study.kinds import grid as grid_kind
from urmx.study.samples import resolve_records

from .fixtures.records import record_file
from .helpers.grid_study import ACC, DT, SCALE
from .helpers.own_files import AT2, OWN_FILES, PLAIN, V2A

DOCS = Path(__file__).resolve().parent.parent / "docs" / "study-files.md"

GRID = """\
[study]
name = "small"
walls = ["s12", "s18"]
diaphragms = ["D1"]
records = ["elcentro"]
cor = [0.8]
"""


@pytest.fixture
def own_study(tmp_path) -> Path:
    """The three record files copied into ``data/`` beside the study file ``OWN_FILES``."""
    data = tmp_path / "data"
    data.mkdir()
    for rel, name in ((AT2, None), (V2A, None), (PLAIN, "my-record.txt")):
        src = record_file(rel)
        shutil.copy(src, data / (name or src.name))
    path = tmp_path / "study.toml"
    path.write_text(OWN_FILES, encoding="utf-8")
    return path


def _refused(make_study, text: str, *needles: str, name: str = "s.toml") -> str:
    path = make_study(text, name)
    with pytest.raises(CatalogError) as err:
        load_study(path)
    message = str(err.value)
    for needle in needles:
        assert needle in message, message
    return message


def _line(text: str, needle: str) -> int:
    return next(i for i, ln in enumerate(text.splitlines(), 1) if needle in ln)


# ---- own records and an own wall, end to end -------------------------------------------------

def test_own_records_and_wall_run_with_provenance_and_equal_simulate(own_study, tmp_path):
    study = load_study(own_study)
    assert study.records == ["gilroy", "wtmc", "mine"]
    out = tmp_path / "own.nc"
    urmx.run_study(study, out=out, scheduler="serial", progress=False)
    ds = urmx.open_study(out).load()
    data = own_study.parent / "data"
    files = {"gilroy": data / "RSN763_LOMAP_GIL067.AT2",
             "wtmc": data / "20161113_110259_WTMC_20.V2A", "mine": data / "my-record.txt"}
    sha = {r: hashlib.sha256(f.read_bytes()).hexdigest() for r, f in files.items()}
    assert list(ds.record_sha256.values) == [sha[r] for r in study.records]
    assert list(ds.record_file.values) == ["data/RSN763_LOMAP_GIL067.AT2",
                                           "data/20161113_110259_WTMC_20.V2A",
                                           "data/my-record.txt"]
    assert list(ds.record_format.values) == ["peer", "geonet", "columns"]
    assert list(ds.record_channel.values) == ["067", "S62W", ""]
    assert list(ds.record_unit.values) == ["g", "mm/s2", "cm/s2"]
    assert list(ds.record_dt.values) == [0.005, 0.02, 0.02]
    assert list(ds.record_npts.values) == [7999, 8192, 2688]
    assert list(ds.scale_factor.values) == [1.0, 1.0, 2.0]
    assert list(ds.record_source.values) == [f"study study.toml [records.{r}]"
                                             for r in study.records]
    assert "cm/s2 -> m/s2" in ds.record_processing.values[2]
    # the wall kept its own diaphragm: the archive's values are those of a direct simulate
    wall = urmx.Wall(thickness=0.23, height=3.2, crack_ratio=0.6, mass=6000.0,
                     top_stiffness=1.2e6, top_mass=5000.0, top_damping=0.12)
    traces = {"gilroy": urmx.records.read(files["gilroy"])[0],
              "wtmc": urmx.records.read(files["wtmc"], channel="S62W")[0],
              "mine": urmx.records.read(files["mine"], dt=0.02, unit="cm/s2")[0]}
    checked = 0
    for rid, trace in traces.items():
        for cor in (0.75, 0.85):
            direct = urmx.simulate(wall, trace, scale=2.0 if rid == "mine" else 1.0, cor=cor)
            cell = ds.sel(wall="mine", diaphragm="specimen", record=rid, cor=cor)
            for name in ("instability_ratio", "peak_top_displacement", "peak_crack_displacement",
                         "base_impacts"):
                assert float(cell[name]) == float(direct[name]), (rid, cor, name)
                checked += 1
    assert checked == 24


def test_the_record_digest_follows_the_file(own_study):
    """A record file that changes (here only a header line: the samples are the same) is
    another record for the batch keys: its cells are never reused."""
    study = load_study(own_study)
    before = resolve_records(study)["gilroy"]
    at2 = own_study.parent / "data" / "RSN763_LOMAP_GIL067.AT2"
    lines = at2.read_text().splitlines(keepends=True)
    lines[1] = lines[1].replace("Loma Prieta", "Loma Prieta (edited)")
    at2.write_text("".join(lines))
    after = resolve_records(load_study(own_study))["gilroy"]
    assert np.array_equal(before.acceleration, after.acceleration)
    assert after.sha256 != before.sha256 and after.digest != before.digest


def test_an_own_record_file_is_never_the_output(own_study):
    """`--out` naming a record file the study file declares (``[records.<id>] file``) is
    refused before any work, and the file is left as it was."""
    from urmx.errors import OutputError
    from urmx.study import run_study

    at2 = own_study.parent / "data" / "RSN763_LOMAP_GIL067.AT2"
    before = at2.read_bytes()
    with pytest.raises(OutputError, match="is the file of record 'gilroy'"):
        run_study(own_study, out=at2, scheduler="serial", progress=False)
    assert at2.read_bytes() == before


def test_a_folder_of_records_is_one_id_per_file(tmp_path, make_study):
    suite = tmp_path / "data" / "suite"
    suite.mkdir(parents=True)
    for name in ("RSN763_LOMAP_GIL067.AT2", "RSN763_LOMAP_GIL337.AT2"):
        shutil.copy(record_file(f"formats/peer/{name}"), suite / name)
    (suite / "notes.txt").write_text("not a record\n")
    text = GRID.replace('["elcentro"]', '["elcentro", "suite"]') + (
        '\n[records.suite]\nfolder = "data/suite"\npattern = "*.AT2"\n\n'
        '[study.scale_factor]\nsuite = 1.5\n')
    study = load_study(make_study(text))
    assert study.records == ["elcentro", "suite/RSN763_LOMAP_GIL067",
                             "suite/RSN763_LOMAP_GIL337"]
    recs = resolve_records(study)
    assert [recs[r].scale_factor for r in study.records[1:]] == [1.5, 1.5]
    assert recs["suite/RSN763_LOMAP_GIL337"].file == "data/suite/RSN763_LOMAP_GIL337.AT2"
    assert recs["suite/RSN763_LOMAP_GIL337"].channel == "337"
    assert recs["elcentro"].source == "manifest records/manifest.toml"
    assert recs["elcentro"].file == "elcentro1940/elcentro_S00E_1940.dat"
    assert recs["elcentro"].sha256 == urmx.records.manifest()["elcentro"]["sha256"]


@pytest.mark.parametrize("old, new, pattern", [
    # a multi-channel file without a channel lists its channels, with the table's line
    ('channel = "S62W"\n', "", r"bad\.toml:21: records\.wtmc: .*3 channels \(N28W, S62W, UP\)"),
    ("dt = 0.02\n", "", r"records\.mine: data/my-record\.txt: .*dt="),  # plain: no time step
    ('"data/my-record.txt"', '"data/gone.txt"', r"bad\.toml:26: records\.mine\.file: "
     r".*gone\.txt' does not exist"),
    ('"gilroy", "wtmc", "mine"', '"gilroy", "wtmc"', r"records\.mine: declared but "
     r"study\.records does not name 'mine'"),
    ("scale = 2.0", "scale = inf", r"records\.mine\.scale: inf must be a positive"),
    ("[records.gilroy]\n", f'[records.gilroy]\nsha256 = "{"0" * 64}"\n',
     r"records\.gilroy\.sha256: .*the file changed"),
    ("[records.mine]\n", '[records.mine]\nchanel = "X"\n', r"records\.mine\.chanel: "
     r"unknown key 'chanel' \(did you mean 'channel'"),
    ('unit = "cm/s2"', 'unit = "furlongs"', r"records\.mine\.unit: 'furlongs' is not one"),
    ("dt = 0.02", "dt = 1e-7\nallow_unusual = true", r"records\.mine: data/my-record\.txt: "
     r"time step dt=1e-07 s is not above the kernel's merged-impact window"),
])
def test_bad_own_records_are_refused_with_their_table(own_study, old, new, pattern):
    text = own_study.read_text()
    assert old in text
    path = own_study.with_name("bad.toml")
    path.write_text(text.replace(old, new))
    with pytest.raises(CatalogError, match=pattern):
        resolve_records(load_study(path))


def test_an_own_record_with_a_manifest_id_needs_override(own_study):
    text = own_study.read_text().replace('"gilroy", "wtmc", "mine"', '"gilroy", "wtmc", '
                                         '"elcentro"').replace("[records.mine]",
                                                               "[records.elcentro]")
    path = own_study.with_name("clash.toml")
    path.write_text(text)
    with pytest.raises(CatalogError, match=r"records\.elcentro: record id 'elcentro' is also "
                       r"a records-manifest id.*override = true"):
        resolve_records(load_study(path))
    path.write_text(text.replace("scale = 2.0", "scale = 2.0\noverride = true"))
    rec = resolve_records(load_study(path))["elcentro"]
    assert rec.file == "data/my-record.txt" and rec.scale_factor == 2.0


def test_records_allow_unusual_passes_the_plausibility_check(tmp_path, make_study):
    (tmp_path / "strong.txt").write_text("0.0\n12.0\n-3.0\n0.5\n0.0\n")  # 12 g
    text = GRID.replace('["elcentro"]', '["strong"]') + (
        '\n[records.strong]\nfile = "strong.txt"\ndt = 0.01\nunit = "g"\n')
    path = make_study(text)
    with pytest.raises(CatalogError, match=r"records\.strong: strong\.txt: .*PGA 12 g"):
        resolve_records(load_study(path))
    path.write_text(text + "allow_unusual = true\n")
    assert resolve_records(load_study(path))["strong"].pga == pytest.approx(12 * 9.80665)


# ---- own walls ------------------------------------------------------------------------------

def test_a_wall_with_its_own_diaphragm_keeps_it(own_study):
    study = load_study(own_study)
    spec = study.walls[0]
    assert spec.own_supports == ("top_mass", "top_stiffness", "top_damping")
    w = study.wall(spec, study.diaphragms[0])
    assert (w.top_stiffness, w.top_mass, w.top_damping, w.bottom_rigid) == (1.2e6, 5000.0,
                                                                           0.12, True)


def test_a_wall_with_its_own_diaphragm_on_listed_diaphragms_is_refused(make_study):
    """Before: its top_stiffness and top_mass were silently replaced by D1's and the
    building's."""
    text = GRID.replace('["s12", "s18"]', '["s12", "mine"]') + (
        "\n[walls.mine]\nthickness = 0.23\nheight = 3.2\ncrack_ratio = 0.6\nmass = 6000.0\n"
        "top_stiffness = 1.2e6\ntop_mass = 5000.0\n")
    _refused(make_study, text, f"s.toml:{_line(text, 'walls =')}: study.walls: wall 'mine' "
             "states its own supports (top_mass, top_stiffness)", 'supports = "specimen"')
    _refused(make_study, GRID.replace('["s12", "s18"]', '["west"]'),
             "wall 'west' states its own supports")


def test_a_wall_in_building_terms_is_the_builder_s_wall(make_study):
    text = GRID.replace('["s12", "s18"]', '["b1", "b2"]').replace('["D1"]', '["specimen"]') \
        .replace("cor = [0.8]", 'cor = [0.8]\nsupports = "specimen"') + (
        "\n[walls.b1]\nthickness = 0.23\nheight = 3.5\ncrack_ratio = 0.667\ndensity = 1800.0\n"
        "wall_length = 8.0\ndiaphragm_weight = 0.5\nplan_area = 120.0\n"
        "diaphragm_frequency = 2.5\nsupports = \"both\"\n"
        "\n[walls.b2]\nthickness = 0.23\nheight = 3.5\ncrack_ratio = 0.667\ndensity = 1800.0\n"
        "wall_length = 8.0\n")
    study = load_study(make_study(text))
    b1, b2 = study.walls
    assert b1.wall == urmx.Wall.in_building(
        thickness=0.23, height=3.5, crack_ratio=0.667, density=1800.0, wall_length=8.0,
        diaphragm_weight=0.5, plan_area=120.0, diaphragm_frequency=2.5, supports="both")
    assert b1.wall.diaphragm_frequency("top") == pytest.approx(2.5)
    assert b2.wall.mass == 8 / 15 * 2 * 1800.0 * 0.23 * 3.5 * 8.0 and b2.wall.top_rigid
    assert b1.own_supports and not b2.own_supports
    bad = text.replace("diaphragm_frequency = 2.5", "diaphragm_frequency = 2.5\n"
                       "diaphragm_stiffness = 1e6")
    _refused(make_study, bad, "walls.b1: a wall with its own diaphragm takes exactly one")
    _refused(make_study, text.replace("plan_area = 120.0\n", "plan_area = 120.0\n"
                                      "mass = 100.0\n"), "walls.b1.mass: a wall in building")


def test_parametric_walls_on_diaphragms_are_the_builder_s_walls():
    """`Study.wall` builds every parametric cell with `urmx.Wall.in_building` (the pinned
    batch keys show these are bitwise the walls of before)."""
    multi = load_study("paper-multi-storey")
    b = multi.catalog.building
    for spec in multi.walls:
        for d in multi.diaphragms:
            w = spec.wall
            assert multi.wall(spec, d).to_dict() == urmx.Wall.in_building(
                thickness=w.thickness, height=w.height, crack_ratio=w.crack_ratio,
                density=b.density, wall_length=b.wall_length,
                diaphragm_weight=b.diaphragm_weight, plan_area=b.plan_area,
                diaphragm_stiffness=d.stiffness, damping=d.damping, supports="both").to_dict()


WALL = "\n[walls.mine]\nthickness = 0.23\nheight = 3.2\ncrack_ratio = 0.6\nmass = 6000.0\n"


@pytest.mark.parametrize("change, key, needle", [
    ("thickness = 350", "walls.mine.thickness", "350 millimetres is 0.35 m"),
    ("height = 3200", "walls.mine.height", "3200 millimetres is 3.2 m"),
    ("mass = 0.5", "walls.mine.mass", "plausible 1-1e+07 kg (in tonnes? 0.5 tonnes"),
    ("mass = 6000.0\nbottom_mass = 0.001", "walls.mine.bottom_mass", "bottom_mass=0.001 kg"),
    ("mass = 6000.0\nbottom_stiffness = -5.0", "walls.mine.bottom_stiffness", "greater than"),
])
def test_implausible_wall_values_name_file_key_and_line(make_study, change, key, needle):
    """Before, a ``bottom_mass`` error was reported under ``mass`` (the key was found by
    substring)."""
    field = change.split(" =")[0]
    text = GRID.replace('["s12", "s18"]', '["mine"]').replace('["D1"]', '["specimen"]') \
        .replace("cor = [0.8]", 'cor = [0.8]\nsupports = "specimen"') \
        + WALL.replace(f"{field} = " + {"thickness": "0.23", "height": "3.2",
                                         "mass": "6000.0"}[field], change)
    last = change.splitlines()[-1].split(" =")[0]
    _refused(make_study, text, f"s.toml:{_line(text, last + ' =')}: {key}: ", needle)
    if "millimetres" in needle or "1e+07" in needle:
        study = load_study(make_study(text + "allow_unusual = true\n", "ok.toml"))
        assert study.walls[0].wall.allow_unusual


# ---- what a study file says it does (issue 25) -----------------------------------------------

@pytest.mark.parametrize("table, text", [
    ("walls.s12", "[walls.s12]\nthickness = 0.3\nheight = 3.6\ncrack_ratio = 0.6\n"
                  "mass = 9000.0\n"),
    ("diaphragms.D1", "[diaphragms.D1]\nstiffness = 2e6\n"),
])
def test_an_own_item_with_a_catalog_id_needs_override(make_study, table, text):
    """Before, it silently replaced the catalog's item."""
    full = GRID + "\n" + text
    _refused(make_study, full, f"s.toml:{_line(full, '[' + table)}: {table}: ",
             "is already a", "override = true")
    study = load_study(make_study(full + "override = true\n", "ok.toml"))
    if table == "walls.s12":
        assert study.walls[0].wall.thickness == 0.3 and not study.walls[0].parametric
    else:
        assert study.diaphragms[0].stiffness == 2e6
    _refused(make_study, GRID + "\n[walls.x9]\nthickness = 0.3\nheight = 3.6\n"
             "crack_ratio = 0.6\nmass = 9000.0\noverride = true\n",
             "walls.x9.override: the catalog has no wall 'x9' to override")


@pytest.mark.parametrize("extra, key", [
    ("[[study.history]]\nwall = \"s18\"\n\n[[study.history]]\nwal = \"s18\"\n",
     "study.history[1].wal"),
    ("[diaphragms.soft]\nstiffness = 1e6\ndampnig = 0.1\n", "diaphragms.soft.dampnig"),
    ("[walls.mine]\nthickness = 0.23\nheight = 3.2\ncrack_ratio = 0.6\nmass = 6000.0\n"
     "top_stifness = 1e6\n", "walls.mine.top_stifness"),
    ("[records.r]\nfile = \"r.txt\"\nuint = \"g\"\n", "records.r.uint"),
])
def test_misspelt_keys_are_refused_everywhere(make_study, extra, key):
    """Before, ``wal`` in a history table and a misspelt diaphragm key were ignored."""
    text = GRID + "\n" + extra
    bad = key.rsplit(".", 1)[1]
    _refused(make_study, text, f"s.toml:{_line(text, bad + ' =')}: {key}: unknown ",
             f"key {bad!r} (did you mean")


def test_ids_are_compared_in_one_normal_form(make_study):
    nfd, nfc = unicodedata.normalize("NFD", "mé"), unicodedata.normalize("NFC", "mé")
    assert nfd != nfc
    wall = "thickness = 0.23\nheight = 3.2\ncrack_ratio = 0.6\nmass = 6000.0\n"
    # one id: the study lists it in the other normal form than its table
    text = GRID.replace('["s12", "s18"]', f'["{nfd}"]') + f'\n[walls."{nfc}"]\n' + wall
    study = load_study(make_study(text))
    assert [w.id for w in study.walls] == [nfc]
    # the same id twice: refused (before, these were two walls)
    text = GRID.replace('["s12", "s18"]', f'["{nfc}", "{nfd}"]') + (
        f'\n[walls."{nfc}"]\n{wall}\n[walls."{nfd}"]\n{wall}')
    header = _line(text, f'[walls."{nfd}"]')
    _refused(make_study, text, f"s.toml:{header}: walls.{nfc}: ",
             "same text in different Unicode normal forms")
    text = GRID.replace('["s12", "s18"]', f'["{nfc}", "{nfd}"]') + f'\n[walls."{nfc}"]\n' + wall
    _refused(make_study, text, "study.walls: has repeated values")


def test_parametric_walls_without_thickness_is_a_catalog_error(tmp_path, make_study):
    """Before: KeyError."""
    cat = tmp_path / "cat"
    shutil.copytree(C.catalog_dir(), cat)
    building = cat / "building.toml"
    good = building.read_text()
    building.write_text(good.replace("thickness = 0.230\n", ""))
    with pytest.raises(CatalogError, match=r"building\.toml:\d+: parametric_walls\.thickness: "
                       "missing"):
        load_catalog(cat)
    with pytest.raises(CatalogError, match="parametric_walls.thickness: missing"):
        load_study(make_study(GRID.replace('name = "small"', 'name = "small"\ncatalog = "cat"')))
    building.write_text(good.replace("density = 1800.0", "densty = 1800.0"))
    with pytest.raises(CatalogError, match=r"building\.densty: unknown key 'densty'"):
        load_catalog(cat)


IDA = GRID.replace('["s12", "s18"]', '["s08", "s24"]') + "\n[study.ida]\nmax_intensity = {}\n"


def test_an_ida_study_that_can_learn_nothing_says_so_at_load(make_study):
    """Before, ``max_intensity = 1e-9`` censored every cell at its first analysis without a
    word."""
    text = IDA.format("1e-9")
    _refused(make_study, text, f"s.toml:{_line(text, 'max_intensity')}: "
             "study.ida.max_intensity: 1e-09 m s-2 lies below where the collapse search "
             "starts in every cell", "nothing could be learnt")
    assert load_study(make_study(IDA.format("9.81"), "ok.toml")).settings.max_intensity == 9.81


# ---- load-time checks (issue 29) ------------------------------------------------------------

def test_a_range_of_too_many_values_is_refused_before_it_is_built(make_study):
    """Before: a 9e8-value list, MemoryError after 88 s."""
    text = GRID.replace("cor = [0.8]", "cor = {start = 0.1, stop = 0.9, step = 1e-9}")
    _refused(make_study, text, f"s.toml:{_line(text, 'cor =')}: study.cor: range start=0.1, "
             "stop=0.9, step=1e-09 makes 8e+08 values, more than the 10,000,000")
    _refused(make_study, GRID.replace("cor = [0.8]", "cor = {start = 0, stop = 1e308, "
                                      "step = 1e-308}"), "makes inf values")
    _refused(make_study, GRID.replace("cor = [0.8]", "cor = {start = 0.7, stop = 0.9, "
                                      "step = 0.01, stpe = 1}"), "study.cor.stpe: unknown key")
    _refused(make_study, GRID.replace("cor = [0.8]", 'cor = {start = "a", stop = 0.9, '
                                      "step = 0.1}"), "range start='a' is not a finite number")


@pytest.mark.parametrize("old, new, needle", [
    ("cor = [0.8]", "cor = [0.0, 0.8]", "study.cor: 0.0 must lie in (0, 1]"),
    ("cor = [0.8]", "cor = [0.8]\ntail = nan", "study.tail: nan must be a finite duration"),
    ("cor = [0.8]", "cor = [0.8]\ntail = inf", "study.tail: inf must be a finite duration"),
    ("cor = [0.8]", "cor = [0.8]\nscale = [0.0, 1.0]", "study.scale: 0.0: a scale must be "
     "positive"),
    ("cor = [0.8]", "cor = [0.8]\nscale = [-1.0]", "study.scale: -1.0: a scale must be "
     "positive"),
    ("cor = [0.8]", "cor = [0.8]\n[study.scale_factor]\nelcentro = inf",
     "study.scale_factor.elcentro: inf must be a positive, finite number"),
    ("cor = [0.8]", "cor = [0.8]\n[diaphragms.soft]\nstiffness = 1e6\ndamping = nan",
     "diaphragms.soft.damping: nan must be a ratio"),
])
def test_values_the_kernel_would_refuse_are_refused_at_load(make_study, old, new, needle):
    """Before, each passed loading and failed in the kernel with no file or key (or, for a
    zero scale and a NaN damping, ran)."""
    _refused(make_study, GRID.replace(old, new), "s.toml:", needle)


def test_an_ida_cor_of_zero_is_refused_at_load(make_study):
    _refused(make_study, IDA.format("9.81").replace("cor = [0.8]", "cor = [0.0]"),
             "study.cor: 0.0 must lie in (0, 1]")


# ---- one reference of every key --------------------------------------------------------------

def documented(text: str) -> dict[str, set[str]]:
    """Table -> keys of the reference: a heading's first code span names a table; each row
    of the tables under it whose first cell holds code spans lists its keys."""
    out: dict[str, set[str]] = {}
    table = None
    for line in text.splitlines():
        if line.startswith("#"):
            spans = re.findall(r"`([^`]+)`", line)
            table = spans[0] if spans else None
            if table:
                out.setdefault(table, set())
        elif table and line.startswith("|") and not line.startswith("|---"):
            first = line.split("|")[1]
            out[table] |= set(re.findall(r"`([^`]+)`", first))
    return out


def differences(text: str, keys: dict[str, tuple[str, ...]]) -> list[str]:
    """What the reference lacks or has beyond the loader's keys, one line each."""
    doc = documented(text)
    out = []
    for table in sorted(set(keys) | set(doc)):
        loader, written = set(keys.get(table, ())), doc.get(table)
        if written is None:
            out.append(f"{table}: a table the loader reads, not in the reference")
            continue
        if table not in keys:
            out.append(f"{table}: in the reference, not a table the loader reads")
        out += [f"{table}.{k}: accepted by the loader, not described" for k in
                sorted(loader - written)]
        out += [f"{table}.{k}: described, not accepted by the loader" for k in
                sorted(written - loader)]
    return out


def test_the_reference_describes_exactly_the_loader_s_keys():
    assert differences(DOCS.read_text(encoding="utf-8"), F.file_keys()) == []


def test_the_reference_check_fails_on_an_undocumented_key(monkeypatch):
    """The check fails when the loader gains a key the reference lacks, or the reference
    describes one the loader does not accept."""
    text = DOCS.read_text(encoding="utf-8")
    keys = dict(F.file_keys())
    keys["[records.<id>]"] = (*keys["[records.<id>]"], "encoding")
    assert differences(text, keys) == ["[records.<id>].encoding: accepted by the loader, "
                                       "not described"]
    removed = text.replace("| `tail` |", "| tail |")
    assert differences(removed, F.file_keys()) == ["[study].tail: accepted by the loader, "
                                                   "not described"]
    # the loader reads the declaration itself: a key declared is accepted, and only then
    monkeypatch.setitem(F.STUDY_FILE_KEYS, "[[study.history]]",
                        ("wall", "diaphragm", "record", "cor", "label"))
    assert differences(text, F.file_keys()) == ["[[study.history]].label: accepted by the "
                                                "loader, not described"]


@pytest.mark.parametrize("table", ["[study]", "[study.pairs]", "[study.scale_factor]",
                                   "[[study.history]]", "[walls.<id>]", "[diaphragms.<id>]",
                                   "[records.<id>]"])
def test_the_loader_refuses_a_key_outside_the_declaration(make_study, table):
    assert table in F.STUDY_FILE_KEYS
    tables = {
        "[study]": ('name = "small"', 'name = "small"\nbogus_key = 1'),
        "[study.pairs]": ("cor = [0.8]", "cor = [0.8]\n[study.pairs]\nbogus_key = []"),
        "[study.scale_factor]": ("cor = [0.8]", "cor = [0.8]\n[study.scale_factor]\n"
                                 "bogus_key = 1.0"),
        "[[study.history]]": ("cor = [0.8]", "cor = [0.8]\n[[study.history]]\nbogus_key = 1"),
        "[walls.<id>]": ("cor = [0.8]", "cor = [0.8]\n[walls.w]\nbogus_key = 1"),
        "[diaphragms.<id>]": ("cor = [0.8]", "cor = [0.8]\n[diaphragms.d]\nbogus_key = 1"),
        "[records.<id>]": ("cor = [0.8]", "cor = [0.8]\n[records.r]\nbogus_key = 1"),
    }
    old, new = tables[table]
    message = _refused(make_study, GRID.replace(old, new), "bogus_key")
    assert re.search(r"unknown (wall )?key 'bogus_key'|names a", message), message


# ---- t_rest, a study key (issue 32) ----------------------------------------------------------

REST_STUDY = """\
[study]
name = "rest"
walls = ["s08"]
diaphragms = ["D1"]
supports = "top"
records = ["quake"]
cor = [0.8]
"""


def test_a_study_key_recorded_in_the_archive_and_in_the_cells_keys(make_study, use_records):
    use_records(ACC, SCALE, DT)
    default = load_study(make_study(REST_STUDY, "a.toml"))
    same = load_study(make_study(REST_STUDY + "t_rest = 0.01\n", "b.toml"))
    other = load_study(make_study(REST_STUDY + "t_rest = 0.02\n", "c.toml"))
    assert (default.t_rest, other.t_rest) == (0.01, 0.02)
    records = st.resolve_records(default)
    every = [[0]] * 4

    def keys(study):
        return Cells(study, kinds.get("grid"), records).keys(every)

    assert keys(default)[0, 0, 0, 0] == keys(same)[0, 0, 0, 0] != keys(other)[0, 0, 0, 0]
    ds = st.run_study(other.path, scheduler="serial", progress=False)
    assert ds.attrs["t_rest"] == 0.02
    wall = other.wall(other.walls[0], other.diaphragms[0])
    direct = kernel.run(wall, ACC["quake"], DT, scale=SCALE["quake"], t_rest=0.02)
    assert float(ds["peak_top_displacement"].squeeze()) == direct["peak_top_displacement"]


def test_a_task_gives_t_rest_to_the_kernel_only_when_it_is_not_the_default():
    assert grid_kind.rest_time({"t_rest": 0.01}) == {} == grid_kind.rest_time({})
    assert grid_kind.rest_time({"t_rest": 0.02}) == {"t_rest": 0.02}


@pytest.mark.parametrize("bad", ["0.0", "-1", "\"soon\"", "inf"])
def test_a_bad_study_t_rest_is_refused(make_study, bad):
    path = make_study(REST_STUDY + f"t_rest = {bad}\n")
    with pytest.raises(CatalogError, match="study.t_rest"):
        load_study(path)
