"""The variable registry (``urmx/variables.toml``): every data variable and coordinate urmx
writes carries the registry's ``long_name`` and, where it is dimensional, its ``units``."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

import urmx
from urmx import variables
from urmx.netcdf import write_netcdf
from urmx.study import open_study, run_study

STUDY = """\
[study]
name = "registry-walk"
walls = ["s12", "s18"]
diaphragms = ["D1", "D5"]
supports = "top"
records = ["elcentro"]
cor = [0.8]
scale = [0.5, 1.0]
impact = ["scale", "contact"]
damping = [0.12]

[[study.history]]
wall = "s18"
diaphragm = "D1"
record = "elcentro"
cor = 0.8
"""


def registry_problems(ds: xr.Dataset | xr.DataArray, scope: str | None = None) -> list[str]:
    """What is wrong with the attributes of every variable and coordinate of `ds`: a name
    the registry lacks, a long_name or units that differ from it, a numeric variable with
    no units (only flag variables, with ``flag_values``, may have none)."""
    if isinstance(ds, xr.DataArray):
        ds = ds.to_dataset()
    im = ds.attrs.get("intensity_measure")  # IDA archives: units follow the measure
    context = variables.intensity_context(im) if im else {}
    problems = []
    for name, var in ds.variables.items():
        try:
            want = variables.attrs(str(name), scope, **context)
        except KeyError:
            problems.append(f"{name}: not in the registry")
            continue
        if var.attrs.get("long_name") != want["long_name"]:
            problems.append(f"{name}: long_name {var.attrs.get('long_name')!r}, registry "
                            f"{want['long_name']!r}")
        if "units" in want:
            if var.attrs.get("units") != want["units"]:
                problems.append(f"{name}: units {var.attrs.get('units')!r}, registry "
                                f"{want['units']!r}")
        elif var.dtype.kind in "biuf" and "flag_values" not in var.attrs:
            problems.append(f"{name}: numeric, but the registry gives no units")
    return problems


def test_every_registry_entry_is_complete():
    for name, entry in variables.registry().items():
        assert entry["long_name"], name
        assert set(entry) <= set(variables.FIELDS), name
    assert variables.attrs("frequency", "spectrum")["long_name"] == "frequency"
    assert variables.attrs("frequency")["long_name"] == "diaphragm frequency"
    assert variables.attrs("pga", "spectrum") == variables.attrs("pga")  # no scoped entry
    with pytest.raises(KeyError, match="not in urmx's variable registry"):
        variables.attrs("peak_drift")


def test_study_archive(records_dir, make_study, tmp_path):
    out = tmp_path / "walk.nc"
    run_study(make_study(STUDY), out=out, scheduler="serial", progress=False,
              records_dir=records_dir)
    with open_study(out) as ds:
        assert {"wall", "diaphragm", "record", "cor", "scale", "impact", "damping",
                "history", "time", "slenderness", "cell_frequency", "history_dt",
                "status", "theta_lower", "instability_ratio"} <= set(ds.variables)
        assert registry_problems(ds) == []
        assert ds["status"].attrs["flag_meanings"] == "ok collapsed event_limit not_run"


IDA_STUDY = """\
[study]
name = "registry-walk-ida"
walls = ["s16"]
diaphragms = ["D1", "D1/both"]
records = ["p695-01-mul009"]
cor = [0.8]

[study.ida]
im = "sa_wall"
"""


def test_ida_archive(records_dir, make_study, tmp_path):
    from .fixtures.records import records_file

    records_file("library/catalog.tsv")
    out = tmp_path / "ida.nc"
    run_study(make_study(IDA_STUDY, "ida.toml"), out=out, scheduler="serial", progress=False,
              records_dir=records_dir)
    with open_study(out) as ds:
        assert {"collapse_intensity", "censored", "intensity", "intensity_step", "supports",
                "median_collapse_intensity", "rocking_period",
                "predominant_frequency"} <= set(ds.variables)
        assert registry_problems(ds) == []
        assert ds["collapse_intensity"].attrs["units"] == "m s-2"
        assert "rocking period" in ds["collapse_intensity"].attrs["long_name"]
        # without the archive's measure the templated entries are not stamped at all
        bare = variables.stamp(xr.Dataset({"intensity": ("x", [1.0])}))
        assert "units" not in bare["intensity"].attrs
    with pytest.raises(KeyError, match="needs 'im_units'"):
        variables.attrs("collapse_intensity")
    with pytest.raises(KeyError, match="unknown intensity measure 'sa'"):
        variables.intensity_context("sa")


def test_simulate_archive(records_dir, make_wall, tmp_path):
    from urmx.records import load

    ds = urmx.simulate(make_wall(), load("elcentro", records_dir), scale=0.5, history=True)
    with xr.open_dataset(write_netcdf(ds, tmp_path / "run.nc")) as back:
        assert "time" in back.coords and "ground_acceleration" in back
        assert registry_problems(back) == []


def test_measures_and_spectra(records_dir):
    from urmx.records import fourier_spectrum, load, measures, response_spectrum

    tr = load("nahanni", records_dir)
    m = measures(tr)
    assert len(m.data_vars) == 12 and registry_problems(m) == []
    assert registry_problems(response_spectrum(tr, periods=[0.0, 0.1, 1.0]), "spectrum") == []
    fas = fourier_spectrum(tr)
    assert registry_problems(fas, "spectrum") == []
    assert fas.frequency.attrs["long_name"] == "frequency" and fas.attrs["smoothing"]


def test_the_walk_fails_on_a_variable_without_registry_attributes():
    ds = variables.stamp(xr.Dataset(
        {"peak_top_displacement": ("wall", [0.1, 0.2]), "peak_drift": ("wall", [1.0, 2.0]),
         "collapsed": ("wall", np.array([0, 1]))},
        coords={"wall": ["a", "b"], "height": ("wall", [2.0, 3.0])}))
    assert registry_problems(ds) == ["peak_drift: not in the registry"]
    ds["height"].attrs = {"long_name": "wall height"}  # units lost
    ds["collapsed"].attrs["long_name"] = "collapse"  # a long_name not the registry's
    assert sorted(registry_problems(ds)) == [
        "collapsed: long_name 'collapse', registry 'wall collapsed'",
        "height: units None, registry 'm'",
        "peak_drift: not in the registry"]
