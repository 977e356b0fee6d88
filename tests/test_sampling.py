"""The sampling study kind and the modelling-uncertainty toolkit (`urmx.uncertainty`): the
sampler's marginals match the requested distributions (seeded, KS tests), samples are
reproducible from the seed, bad tables and invalid samples are refused at load naming the
parameter (and nothing runs), a sample's values reach the wall and the analysis, a study
gives bitwise the same archive twice and after a SIGKILL and resume, its batches run on
numpy alone, the fits with modelling uncertainty are those of the capacities, and the
sensitivity indices recover the Ishigami function's closed form within their confidence."""

from __future__ import annotations

import json
import math
import os
import pickle
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scipy import stats

import urmx
from urmx.catalog import CatalogError
from urmx.study.file import load_study
from urmx.uncertainty import (
    ParameterError,
    apply,
    lognormal_fit,
    modelling_fit,
    parse_distribution,
    parse_sampling,
    prcc,
    sobol_indices,
    unit_design,
    variance_split,
)

from .fixtures.signals import killed_after_parts
from .helpers.synthetic import DT
from .helpers.synthetic import SAMPLING_ACC as ACC
from .helpers.synthetic import SAMPLING_SCALE as SCALE

ROOT = Path(__file__).resolve().parent.parent

# ---- the sampler ---------------------------------------------------------------------------

DISTRIBUTIONS = {
    "uniform": {"distribution": "uniform", "low": 0.78, "high": 0.83},
    "normal": {"distribution": "normal", "mean": 75.0, "std": 3.0},
    "truncated-normal": {"distribution": "normal", "mean": 75.0, "std": 3.0, "low": 72.0,
                         "high": 85.0},
    "lognormal": {"distribution": "lognormal", "median": 1.0, "beta": 0.2},
    "truncated-lognormal": {"distribution": "lognormal", "median": 1.0, "beta": 0.3,
                            "low": 0.8, "high": 1.5},
}


@pytest.mark.parametrize("method,n", [("lhs", 400), ("sobol", 512), ("random", 2000)])
@pytest.mark.parametrize("name", list(DISTRIBUTIONS))
def test_the_marginals_are_the_requested_distributions(name, method, n):
    """A KS test of each marginal against scipy's distribution (p > 0.01; the draw is
    seeded, so the test is deterministic), within the truncation bounds, and the sample
    mean within 4 standard errors of the distribution's."""
    table = DISTRIBUTIONS[name]
    s = parse_sampling({"samples": n, "seed": 11, "method": method,
                        "parameters": {"cor" if name == "uniform" else "mass": table}})
    (values,) = s.draw()[1].values()
    dist = next(iter(s.parameters.values())).frozen()
    assert values.shape == (n,) and values.dtype == np.float64
    assert stats.kstest(values, dist.cdf).pvalue > 0.01
    if "low" in table:
        assert values.min() >= table["low"] and values.max() <= table["high"]
    if name in ("uniform", "normal", "truncated-normal"):
        assert abs(values.mean() - dist.mean()) < 4 * dist.std() / math.sqrt(n)
    if name == "lognormal":
        assert np.median(values) == pytest.approx(1.0, abs=0.03)
        assert np.log(values).std() == pytest.approx(0.2, rel=0.08)


def test_a_choice_draws_each_value_as_often():
    s = parse_sampling({"samples": 300, "seed": 1, "parameters": {
        "impact": {"distribution": "choice", "values": ["scale", "contact"]},
        "damping": {"distribution": "choice", "values": [0.08, 0.10, 0.12]}}})
    _, values = s.draw()
    assert sorted(set(values["impact"])) == ["contact", "scale"]
    counts = [int(np.sum(values["damping"] == v)) for v in (0.08, 0.10, 0.12)]
    assert counts == [100, 100, 100]  # a Latin hypercube: one stratum per sample
    assert int(np.sum(values["impact"] == "scale")) == 150
    r = parse_sampling({"samples": 3000, "seed": 2, "method": "random", "parameters": {
        "damping": {"distribution": "choice", "values": [0.08, 0.12]}}}).draw()[1]["damping"]
    assert stats.binomtest(int(np.sum(r == 0.08)), 3000, 0.5).pvalue > 0.01


def test_the_same_seed_gives_the_same_samples_and_another_seed_others():
    table = {"samples": 16, "seed": 5, "method": "lhs",
             "parameters": {"cor": DISTRIBUTIONS["uniform"], "pmr": DISTRIBUTIONS["normal"]}}
    for method in ("lhs", "sobol", "random", "saltelli"):
        t = dict(table, method=method)
        a, b = parse_sampling(t).draw(), parse_sampling(t).draw()
        assert a[0].tobytes() == b[0].tobytes()
        assert all(a[1][k].tobytes() == b[1][k].tobytes() for k in a[1])
        c = parse_sampling(dict(t, seed=6)).draw()
        assert not np.array_equal(a[0], c[0])
    assert parse_sampling(dict(table, method="saltelli")).size == 16 * (2 + 2)
    lhs = unit_design(16, 2, "lhs", 5)  # one point per stratum of each column
    assert all(sorted(np.floor(lhs[:, i] * 16)) == list(range(16)) for i in range(2))


@pytest.mark.parametrize("table,key,message", [
    ({"distribution": "gamma"}, "distribution", "not one of uniform"),
    ({"distribution": "uniform", "low": 1.0}, "distribution", "needs 'high'"),
    ({"distribution": "uniform", "low": 1.0, "high": 1.0}, "high", "must be below"),
    ({"distribution": "uniform", "low": 0, "high": 1, "mean": 2}, "mean", "unknown key"),
    ({"distribution": "normal", "mean": 75, "std": 0}, "std", "must be above 0"),
    ({"distribution": "normal", "mean": 75, "std": 3, "low": 99, "high": 100}, "low",
     "far in one tail"),
    ({"distribution": "lognormal", "median": -1, "beta": 0.2}, "median", "above 0"),
    ({"distribution": "lognormal", "median": 1, "beta": 0.2, "low": -1}, "low", "negative"),
    ({"distribution": "choice", "values": []}, "values", "non-empty list"),
    ({"distribution": "choice", "values": [1, 1]}, "values", "repeats"),
    ({"distribution": "choice", "values": [1, "a"]}, "values", "mixes"),
    ({"distribution": "uniform", "low": "a", "high": 1}, "low", "finite number"),
    ([1, 2], "", "inline table"),
])
def test_bad_distributions_are_refused_naming_the_key(table, key, message):
    with pytest.raises(ParameterError, match=message) as info:
        parse_distribution(table)
    assert info.value.key == key and isinstance(info.value, urmx.UrmxError)


# ---- a sample applied to a wall ----------------------------------------------------------

def test_a_sample_replaces_wall_fields_and_scales_the_supports(make_wall):
    wall = make_wall()  # rigid base, flexible top
    f0 = wall.diaphragm_frequency("top")
    w = apply(wall, {"pmr": 80.0, "crack_ratio": 0.6, "kappa": 0.05, "frequency": 1.2,
                     "damping": 0.08, "cor": 0.5, "impact": "contact"})
    assert (w.pmr, w.crack_ratio, w.kappa, w.top_damping) == (80.0, 0.6, 0.05, 0.08)
    assert w.diaphragm_frequency("top") == pytest.approx(1.2 * f0, rel=1e-12)
    assert w.top_stiffness == pytest.approx(1.44 * wall.top_stiffness, rel=1e-12)
    assert w.bottom_stiffness == "rigid" and w.bottom_damping == 0.0  # a rigid one stays
    m = apply(wall, {"mass": 1.3, "frequency": 0.9})  # the frequency is kept as sampled
    assert m.mass == pytest.approx(1.3 * wall.mass, rel=1e-12)
    assert m.diaphragm_frequency("top") == pytest.approx(0.9 * f0, rel=1e-12)
    k = apply(wall, {"stiffness": 2.0})
    assert k.top_stiffness == 2.0 * wall.top_stiffness
    assert apply(wall, {"cor": 0.7}) is wall


# ---- study files: refused at load, naming the parameter ----------------------------------------

STUDY = """\
[study]
name = "sampled"
walls = ["s08", "s16"]
diaphragms = ["D1", "D4/both"]
records = ["quake", "shake"]
cor = [0.8]

[study.sampling]
samples = 5
seed = 3

[study.sampling.parameters]
cor = { distribution = "uniform", low = 0.78, high = 0.83 }
pmr = { distribution = "normal", mean = 75, std = 3, low = 65, high = 85 }
crack_ratio = { distribution = "normal", mean = 0.667, std = 0.05, low = 0.55, high = 0.78 }
frequency = { distribution = "lognormal", median = 1.0, beta = 0.2 }
damping = { distribution = "uniform", low = 0.08, high = 0.12 }
impact = { distribution = "choice", values = ["scale", "contact"] }
"""
IDA = '\n[study.ida]\nim = "pga"\nrtol = 0.02\n'


@pytest.mark.parametrize("old,new,where", [
    ("high = 85 }", "high = 120 }", r":14: study\.sampling\.parameters\.pmr\.high: pmr: "
                                    r"high=120 lies outside its valid range \(0, 100\]"),
    ("samples = 5", "samples = 0", r":9: study\.sampling\.samples: 0 must be"),
    ("seed = 3", "seed = 3\nmethod = \"sobol\"", r":9: study\.sampling\.samples: 5 must be a "
                                               "power of 2"),
    ("seed = 3", "seed = 3\nmethod = \"latin\"", r":11: study\.sampling\.method: 'latin'"),
    ("seed = 3", "seed = 3\nsize = 2", r":11: study\.sampling\.size: unknown key"),
    ("seed = 3\n", "", r":8: study\.sampling\.seed: missing"),
    ("cor = { distribution", "kor = { distribution", r":13: study\.sampling\.parameters\.kor:"
                                                      r" 'kor' cannot be sampled"),
    ('"scale", "contact"', '"scale", "slide"', r":18: study\.sampling\.parameters\.impact\."
                                                r"values: impact is drawn as a choice"),
    ("damping = { distribution", "stiffness = { distribution",
     r":16: study\.sampling\.parameters\.frequency: stiffness and frequency"),
    ("cor = [0.8]", "cor = [0.7, 0.8]", r":6: study\.cor: a sampling study runs one cor"),
    ('cor = [0.8]', 'cor = [0.8]\nimpact = ["scale", "contact"]',
     r":7: study\.impact: a sampling study cannot have impact as a dimension"),
])
def test_bad_sampling_tables_are_refused_at_load(make_study, old, new, where):
    path = make_study(STUDY.replace(old, new), "bad.toml")
    with pytest.raises(CatalogError, match=r"bad\.toml" + where):
        load_study(path)


def test_an_invalid_sample_is_refused_at_load_naming_the_parameter_and_never_run(
        make_study, use_records, tmp_path):
    """A PMR drawn outside (0, 100] (an untruncated normal reaching past 100), and a PMR
    that leaves no plateau with the sampled kappa, are refused when the study is loaded,
    naming the parameter, the sample and the value; `urmx run` exits 2 with that one line
    and leaves no archive and no parts."""
    use_records(ACC, SCALE, DT)
    text = STUDY.replace("mean = 75, std = 3, low = 65, high = 85", "mean = 95, std = 4")
    path = make_study(text, "pmr.toml")
    with pytest.raises(CatalogError, match=r"pmr\.toml:14: study\.sampling\.parameters\.pmr: "
                       r"sample \d+: pmr=\d+\.\d+ lies outside its valid range \(0, 100\]"):
        load_study(path)
    out = tmp_path / "pmr.nc"
    with pytest.raises(CatalogError, match="parameters.pmr"):
        urmx.run_study(path, out=out, scheduler="serial", progress=False)
    assert not out.exists() and not (tmp_path / "pmr.nc.parts").exists()
    kappa = STUDY.replace("damping = {", 'kappa = { distribution = "uniform", low = 0.32, '
                          "high = 0.4 }\ndamping = {")
    path = make_study(kappa, "kappa.toml")
    with pytest.raises(CatalogError, match=r"study\.sampling\.parameters\.pmr: sample \d+ "
                       r"\(pmr=[\d.]+, kappa=[\d.]+\) makes no valid wall 's08' on diaphragm "
                       r"'D1': Wall kappa="):
        load_study(path)
    done = subprocess.run([sys.executable, "-m", "urmx.cli", "run", str(make_study(
        text, "cli.toml")), "--out", str(tmp_path / "cli.nc")], capture_output=True,
        text=True, cwd=ROOT)
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1
    assert "parameters.pmr" in done.stderr and not (tmp_path / "cli.nc").exists()


# ---- running a sampling study --------------------------------------------------------------------

SLEEP = "URMX_SAMPLING_SLEEP"


def slow_kernel(wall, ground_acceleration, dt, **kw):
    """`urmx.kernel.run`, after sleeping $URMX_SAMPLING_SLEEP seconds (a killed run's
    batches take time)."""
    from urmx.kernel import run

    time.sleep(float(os.environ.get(SLEEP, "0")))
    return run(wall, ground_acceleration, dt, **kw)


@pytest.fixture
def sampled(make_study, use_records):
    use_records(ACC, SCALE, DT)
    return make_study(STUDY, "sampled.toml")


def _no_history(ds: xr.Dataset) -> xr.Dataset:
    ds = ds.copy()
    # this run's line (an extended archive lists the earlier runs' after it)
    ds.attrs["history"] = ds.attrs["history"].splitlines()[0].split(" ", 1)[1]
    return ds


def _bitwise(a: xr.Dataset, b: xr.Dataset) -> None:
    """Identical, and every variable's bytes the same."""
    xr.testing.assert_identical(_no_history(a), _no_history(b))
    for name in a.variables:
        x, y = a[name].values, b[name].values
        if x.dtype.kind in "OUS" or y.dtype.kind in "OUS":  # strings: by value
            assert x.tolist() == y.tolist(), name
        else:
            assert x.tobytes() == y.tobytes(), name


def test_a_time_history_study_runs_each_sample_as_drawn(sampled, tmp_path):
    """The archive's sample coordinates are the draw; each cell is the kernel's analysis of
    the sample's wall (pmr, crack height, the diaphragm's frequency and damping) at the
    sample's cor and impact law, bit for bit; the same seed gives bitwise the same archive."""
    from urmx.kernel import run

    study = load_study(sampled)
    assert study.kind == "sampling" and study.settings.size == 5
    ds = urmx.run_study(sampled, out=tmp_path / "a.nc", scheduler="serial", progress=False,
                        batch_size=3)
    assert ds.instability_ratio.dims == ("wall", "diaphragm", "record", "sample")
    _, values = study.settings.sampling.draw()
    for name in ("cor", "pmr", "crack_ratio", "damping"):
        assert np.array_equal(ds[name].values, values[name])
    assert list(ds.impact.values) == list(values["impact"])
    assert np.array_equal(ds.frequency_factor.values, values["frequency"])
    assert np.array_equal(ds.sample_unit.values, study.settings.unit)
    assert list(ds.parameter.values) == ["cor", "pmr", "crack_ratio", "frequency", "damping",
                                         "impact"]
    assert "pmr" not in ds.wall.coords and ds.attrs["sampling_method"] == "lhs"
    assert json.loads(ds.attrs["sampling_parameters"])["cor"]["low"] == 0.78
    spec, d = study.walls[1], study.diaphragms[1]  # s16 between two D4 diaphragms
    base = study.wall(spec, d)
    for j in range(5):
        s = {k: (v[j] if k == "impact" else float(v[j])) for k, v in values.items()}
        wall = apply(base, s)
        assert wall.pmr == s["pmr"] and wall.bottom_damping == s["damping"]
        assert float(ds.cell_frequency.sel(wall="s16", diaphragm="D4/both", sample=j)) == \
            pytest.approx(s["frequency"] * base.diaphragm_frequency("top"), rel=1e-12)
        r = run(wall, ACC["shake"], DT, cor=s["cor"], impact=s["impact"])
        cell = ds.sel(wall="s16", diaphragm="D4/both", record="shake", sample=j)
        assert float(cell.peak_crack_displacement) == r["peak_crack_displacement"]
    assert len(set(values["impact"])) == 2 and ds.status.isin([0, 1]).all()
    _bitwise(ds, urmx.run_study(sampled, scheduler="serial", progress=False, batch_size=3))
    _bitwise(ds, urmx.open_study(tmp_path / "a.nc").load())


RUN = f"""\
import sys
import urmx
import {__name__} as T
from tests.fixtures.pinned import served

with served(T.ACC, T.SCALE, T.DT):
    urmx.run_study(sys.argv[1], out=sys.argv[2], scheduler="serial", progress=False,
                   batch_size=1, kernel=T.slow_kernel)
"""


def _counting(calls: list) -> Callable:
    """`slow_kernel`, counting its analyses in `calls` (under slow_kernel's name: the same
    cell keys)."""
    def counted(*args, **kw):
        calls.append(1)
        return slow_kernel(*args, **kw)

    counted.__module__, counted.__qualname__ = __name__, "slow_kernel"
    return counted


def test_a_killed_sampling_study_resumes_to_the_same_archive_bit_for_bit(sampled, tmp_path):
    """SIGKILL a real `run_study` subprocess after a few batches; the run again, with
    another batch size, resumes from its parts (computing only the other cells) and writes
    bitwise the archive of an uninterrupted run."""
    out, parts = tmp_path / "killed.nc", tmp_path / "killed.nc.parts"
    total = 2 * 2 * 2 * 5  # cells, one a batch at batch_size 1
    kept = killed_after_parts(["-c", RUN, str(sampled), str(out)], parts, 3,
                              env=dict(os.environ, **{SLEEP: "0.3"}))
    assert 3 <= kept < total and not out.exists()
    calls: list = []
    ds = urmx.run_study(sampled, out=out, scheduler="serial", progress=False, batch_size=3,
                        kernel=_counting(calls))
    assert len(calls) == total - kept and not parts.exists()
    _bitwise(ds, urmx.run_study(sampled, scheduler="serial", progress=False, batch_size=1,
                                kernel=slow_kernel))


@pytest.mark.parametrize("method,extra", [("sobol", ""), ("random", ""), ("sobol", IDA)])
def test_a_design_extended_by_more_samples_computes_only_the_new_ones(make_study,
                                                                        use_records, tmp_path,
                                                                        method, extra):
    """A cell is keyed by its sample's values (not its index or the design): a ``sobol`` or
    ``random`` design of the same seed with twice the samples keeps its first points, so
    the run into the same archive takes their cells from it, computes only the new
    samples', and writes bitwise what a fresh run of the larger design writes; the batches
    are cut over the sample dimension."""
    from urmx.study import engine

    use_records(ACC, SCALE, DT)
    calls: list = []
    counted = _counting(calls)

    def study(n):
        return make_study(STUDY.replace("samples = 5\nseed = 3", f"samples = {n}\nseed = 3\n"
                                        f'method = "{method}"') + extra, f"{method}.toml")

    out = tmp_path / "ext.nc"
    first = urmx.run_study(study(4), out=out, scheduler="serial", progress=False,
                           batch_size=3, kernel=counted).load()
    analyses = len(calls)
    assert analyses == 2 * 2 * 2 * 4 or extra
    from urmx.records import Record

    recs = {k: Record(k, ACC[k], DT) for k in ACC}
    # with IDA each chain of walls (warm starts, `urmx.fragility.capacity`) stays whole
    size, walls = (6, [0, 1]) if extra else (3, [0])
    blocks = [b.block for b, _ in urmx.study.batch_tasks(load_study(study(8)), recs, size)]
    assert {len(b["sample"]) for b in blocks} == {3, 2}
    assert len(blocks) == 2 * 2 * 3 * (1 if extra else 2)
    assert sorted(j for b in blocks if b["wall"] == walls and b["diaphragm"] == [1]
                  and b["record"] == [1] for j in b["sample"]) == list(range(8))
    calls.clear()
    ds = urmx.run_study(study(8), out=out, scheduler="serial", progress=False, batch_size=3,
                        kernel=counted).load()
    run = engine.last_run()
    assert (run.from_archive, run.computed) == (32, 32)
    old = ds.isel(sample=slice(0, 4), intensity_step=slice(0, first.sizes.get(
        "intensity_step", 0))) if extra else ds.isel(sample=slice(0, 4))
    for name in [n for n in first.data_vars if "sample" in first[n].dims]:
        assert np.asarray(first[name].values).tobytes() == np.asarray(
            old[name].values).tobytes(), name
    new = len(calls)
    assert new == 32 or extra
    calls.clear()
    _bitwise(ds, urmx.run_study(
        study(8), scheduler="serial", progress=False, batch_size=3, kernel=counted))
    assert len(calls) == analyses + new  # a fresh run computes the reused cells too


def test_an_ida_sampling_study_fits_records_and_samples_together(make_study, use_records):
    """With [study.ida] each cell is the collapse capacity of the sample's wall at its cor
    and impact law (as `urmx.fragility.collapse_capacity` finds it); the fits per sample
    are over the records, the total over records and samples, with its parts."""
    from urmx.fragility import collapse_capacity
    from urmx.records import Record

    use_records(ACC, SCALE, DT)
    path = make_study(STUDY.replace("samples = 5", "samples = 4") + IDA, "ida.toml")
    study = load_study(path)
    assert study.kind == "sampling-ida" and study.settings.ida.rtol == 0.02
    ds = urmx.run_study(path, scheduler="serial", progress=False)
    cap = ds.collapse_intensity
    assert cap.dims == ("wall", "diaphragm", "record", "sample") and ds.sample.size == 4
    assert ds.median_collapse_intensity.dims == ("wall", "diaphragm", "sample")
    base = study.wall(study.walls[0], study.diaphragms[0])
    s = study.settings.sample(2)
    direct = collapse_capacity(apply(base, s), Record("quake", ACC["quake"], DT), im="pga",
                               cor=s["cor"], impact=s["impact"], rtol=0.02)
    assert float(cap.sel(wall="s08", diaphragm="D1", record="quake", sample=2)) == \
        direct.capacity
    c = ds.sel(wall="s16", diaphragm="D1")
    table = c.collapse_intensity.transpose("sample", "record").values
    cen = c.censored.transpose("sample", "record").values
    for j in range(4):
        m, b = lognormal_fit(table[j], cen[j])
        assert float(c.median_collapse_intensity.sel(sample=j)) == m
        assert float(c.dispersion.sel(sample=j)) == b
    m, b = lognormal_fit(table, cen)
    assert (float(c.total_median_collapse_intensity), float(c.total_dispersion)) == (m, b)
    disp = c.dispersion.values
    assert float(c.record_dispersion) == pytest.approx(np.sqrt(np.mean(disp ** 2)))
    assert float(c.model_dispersion) == pytest.approx(
        np.std(np.log(c.median_collapse_intensity.values), ddof=1))
    assert ds.attrs["intensity_measure"] == "pga" and ds.rocking_period.dims == (
        "wall", "diaphragm", "sample")
    assert np.all(np.isfinite(ds.predominant_frequency.values))
    from urmx.study import kinds, summary

    assert summary.kind_of(ds) == "sampling-ida"
    assert kinds.get("sampling-ida").counts(ds) == {"collapsed": int((ds.censored == 0).sum()),
                                                "censored": int(ds.censored.sum()),
                                                "missing": 0}


HEAVY = ("xarray", "dask", "distributed", "obspy", "pandas", "SALib")
BATCH = """\
import json, pickle, sys
from urmx.study import kinds
from urmx.study.clients import record_samples

name, task, acc = pickle.load(open(sys.argv[1], "rb"))
out = kinds.get(name).run(task, record_samples(acc))
assert all(isinstance(v, type(acc)) for v in out.values())
print(json.dumps(sorted({m.split(".")[0] for m in sys.modules} & set(sys.argv[2:]))))
"""


@pytest.mark.parametrize("extra", ["", IDA])
def test_a_sampling_batch_imports_numpy_only(make_study, use_records, tmp_path, extra):
    from urmx.records import Record

    use_records(ACC, SCALE, DT)
    study = load_study(make_study(STUDY + extra, "batch.toml"))
    (batch, task), *_ = urmx.study.batch_tasks(study, {"quake": Record("quake", ACC["quake"],
                                                                        DT),
                                                       "shake": Record("shake", ACC["shake"],
                                                                       DT)})
    job = tmp_path / "job.pickle"
    job.write_bytes(pickle.dumps((study.kind, task, ACC["quake"])))
    done = subprocess.run([sys.executable, "-c", BATCH, str(job), *HEAVY],
                          capture_output=True, text=True, check=True, cwd=ROOT)
    assert json.loads(done.stdout.splitlines()[-1]) == []


def test_the_catalog_sampling_study_loads():
    study = load_study("uncertainty-ida")
    assert study.kind == "sampling-ida" and study.settings.ida is not None
    assert study.settings.sampling.parameters["cor"].args == (0.78, 0.83)
    assert set(study.settings.values["impact"]) == {"scale", "contact"}
    assert len(study.records) == 40


# ---- sensitivity ---------------------------------------------------------------------------

A, B = 7.0, 0.1  # the Ishigami function's constants


def ishigami(u: np.ndarray) -> np.ndarray:
    x = -math.pi + 2 * math.pi * u
    return np.sin(x[:, 0]) + A * np.sin(x[:, 1]) ** 2 + B * x[:, 2] ** 4 * np.sin(x[:, 0])


def ishigami_indices() -> tuple[np.ndarray, np.ndarray]:
    """The closed-form first-order and total Sobol' indices (Ishigami & Homma 1990)."""
    v1 = 0.5 * (1 + B * math.pi ** 4 / 5) ** 2
    v2 = A ** 2 / 8
    v13 = B ** 2 * math.pi ** 8 * (1 / 18 - 1 / 50)
    v = v1 + v2 + v13
    return np.array([v1, v2, 0.0]) / v, np.array([v1 + v13, v2, v13]) / v


def test_sobol_indices_recover_the_ishigami_function_within_their_confidence():
    s1, st = ishigami_indices()
    assert s1 == pytest.approx([0.3139, 0.4424, 0.0], abs=1e-4)
    u = unit_design(1024, 3, "saltelli", seed=7)
    si = sobol_indices(u, ishigami(u), "saltelli", seed=7)
    assert np.all(np.abs(si["S1"] - s1) <= si["S1_conf"]), si
    assert np.all(np.abs(si["ST"] - st) <= si["ST_conf"]), si
    assert np.all(si["S1_conf"] < 0.1) and np.all(si["ST_conf"] < 0.1)
    u = unit_design(2000, 3, "lhs", seed=7)  # any design: RBD-FAST's first order
    si = sobol_indices(u, ishigami(u), "lhs", seed=7)
    assert np.all(np.abs(si["S1"] - s1) <= si["S1_conf"]), si
    assert np.all(np.isnan(si["ST"]))


def test_partial_rank_correlations_find_what_drives_a_function():
    """x2 and x3 enter the Ishigami function symmetrically (no monotone trend): their PRCC
    intervals hold 0; x1 drives it upwards. On a monotone function with noise the PRCC
    orders the inputs by their weight."""
    u = unit_design(2000, 3, "lhs", seed=3)
    r = prcc(u, ishigami(u))
    assert r["low"][0] > 0.3 and all(r["low"][i] < 0 < r["high"][i] for i in (1, 2))
    rng = np.random.default_rng(0)
    x = rng.random((400, 3))
    y = np.exp(2 * x[:, 0]) - x[:, 1] + 0.1 * rng.normal(size=400)
    r = prcc(x, y)
    assert r["prcc"][0] > 0.9 and r["prcc"][1] < -0.5 and r["low"][2] < 0 < r["high"][2]
    assert r["p"][0] < 1e-10
    assert np.all(np.isnan(prcc(x[:4], y[:4])["low"]))  # no degrees of freedom left


def test_the_variance_split_recovers_known_components():
    """ln C = sample effect (sd 0.3) + record effect (sd 0.5) + interaction (sd 0.1): the
    random-effects estimates find the three variances (100 samples x 60 records)."""
    rng = np.random.default_rng(4)
    t = rng.normal(0, 0.3, (100, 1)) + rng.normal(0, 0.5, (1, 60)) \
        + rng.normal(0, 0.1, (100, 60))
    v = variance_split(t)
    assert v["model"] == pytest.approx(0.09, rel=0.2)
    assert v["record"] == pytest.approx(0.25, rel=0.3)
    assert v["interaction"] == pytest.approx(0.01, rel=0.1)
    assert v["model_share"] + v["record_share"] + v["interaction_share"] == pytest.approx(1)
    t[3, 5] = np.nan  # a sample with a missing cell is left out
    assert variance_split(t)["samples"] == 99


def test_the_modelling_fit_parts_add_up():
    rng = np.random.default_rng(8)
    ln = rng.normal(0, 0.25, (40, 1)) + rng.normal(1.0, 0.4, (1, 40))
    f = modelling_fit(np.exp(ln))
    assert f["total_median"] == pytest.approx(math.exp(ln.mean()))
    assert f["total_dispersion"] == pytest.approx(ln.std())
    assert math.hypot(f["record_dispersion"], f["model_dispersion"]) == pytest.approx(
        f["total_dispersion"], rel=0.05)
    assert f["model_dispersion"] == pytest.approx(0.25, rel=0.3)


# ---- the report ------------------------------------------------------------------------------

def test_the_uncertainty_report_answers_from_the_archive(make_study, use_records, tmp_path):
    """`urmx uncertainty-report` writes REPORT.md and its figures from a sampling IDA
    archive; its numbers are the archive's (the dispersions, the law's effect, the
    strongest parameter); any other archive is refused in one line."""
    import urmx.analysis.sampling as UA
    from urmx.cli import main
    from urmx.reports.sampling import write_report

    use_records(ACC, SCALE, DT)
    path = make_study(STUDY.replace("samples = 5", "samples = 10") + IDA, "rep.toml")
    ds = urmx.run_study(path, out=tmp_path / "rep.nc", scheduler="serial", progress=False)
    out = tmp_path / "report"
    assert main(["uncertainty-report", str(tmp_path / "rep.nc"), "--out", str(out)]) == 0
    text = (out / "REPORT.md").read_text()
    if ds.attrs["urmx_git_commit"] != "none":  # a checkout: the code that made it
        assert f"made at commit `{ds.attrs['urmx_git_commit'][:12]}`" in text
    for name in ("sensitivity.png", "parameters.png", "spread.png", "fragility.png",
                 "impact_law.png"):
        assert (out / name).stat().st_size > 1000 and f"({name})" in text
    spr, sens = UA.spread(ds), UA.sensitivity(ds)
    beta = spr.total_dispersion.values
    assert f"the dispersion is {beta.min():.2g} to {beta.max():.2g}" in text
    # R^2, the variance shares and PRCC side by side (issue 38), the ranking by share where
    # the linear model explains enough
    assert "### Variance shares beside PRCC" in text
    c = sens.isel(wall=0, diaphragm=0)
    p0 = str(sens.parameter.values[0])
    assert (f"{100 * float(c.share.sel(parameter=p0)):.0f} % "
            f"[{100 * float(c.share_low.sel(parameter=p0)):.0f}-") in text
    linear = int((sens.r2 >= 0.7).sum())
    assert f"in {linear} of 4 wall and diaphragm cells R^2 >= 0.7" in text
    assert np.all((sens.r2 > 0) & (sens.r2 <= 1))
    eff = UA.law_effect(ds)
    assert np.all(np.isfinite(eff)) and f"{float(eff.min()):.3g} to" in text
    assert sens.prcc.dims == ("wall", "diaphragm", "parameter") and np.all(np.isfinite(
        sens.prcc_low))
    assert np.allclose(spr.model_share + spr.record_share + spr.interaction_share, 1.0)
    assert write_report(ds, tmp_path / "again").read_text() == text.replace(
        str(out), str(tmp_path / "again"))
    plain = urmx.run_study(make_study(STUDY.replace("[study.sampling]", "[study.nothing]")
                                      .split("[study.nothing]")[0], "grid.toml"),
                           out=tmp_path / "grid.nc", scheduler="serial", progress=False)
    assert "sample" not in plain.dims
    done = subprocess.run([sys.executable, "-m", "urmx.cli", "uncertainty-report",
                           str(tmp_path / "grid.nc"), "--out", str(tmp_path / "x")],
                          capture_output=True, text=True, cwd=ROOT)
    said = done.stderr.strip().splitlines()  # the alias's note, then the one-line error
    assert done.returncode == 2 and len(said) == 2 and "replaced by `urmx report`" in said[0]
    assert "not a sampling-study archive" in done.stderr


def test_a_sampling_ida_study_extended_by_a_wall_starts_it_from_the_archive(make_study,
                                                                            use_records,
                                                                            tmp_path):
    """With [study.ida], each sample's walls form a warm-start chain: a wall added at the
    end of the list is computed from the capacities of the wall before it taken from the
    earlier archive (per diaphragm, record and sample), and the archive equals a fresh
    run's bit for bit; the walls before it are taken over, not computed."""
    from urmx.study import engine

    use_records(ACC, SCALE, DT)
    calls: list = []
    counted = _counting(calls)
    three = STUDY.replace('walls = ["s08", "s16"]', 'walls = ["s08", "s16", "s24"]') + IDA
    out = tmp_path / "grow.nc"
    urmx.run_study(make_study(STUDY + IDA, "grow.toml"), out=out, scheduler="serial",
                   progress=False, kernel=counted)
    ds = urmx.run_study(make_study(three, "grow.toml"), out=out, scheduler="serial",
                        progress=False, kernel=counted).load()
    run = engine.last_run()
    assert (run.from_archive, run.computed) == (2 * 2 * 2 * 5, 2 * 2 * 5)
    _bitwise(ds, urmx.run_study(make_study(three, "fresh.toml"), scheduler="serial",
                                progress=False, kernel=counted))
