"""``t_rest``, the rest time of held joints (``v_rest = g_open/t_rest``, MODEL.md section 4;
issue 32) as a setting: an argument of `urmx.kernel.run` and `urmx.simulate`, a study key,
recorded in archives and part of a cell's key; validated with a one-line error naming it."""

from __future__ import annotations

import math

import pytest

import urmx
import urmx.study as st
from urmx import kernel
from urmx.catalog import CatalogError
from urmx.errors import InputError
from urmx.study import kinds
from urmx.study.cells import Cells
from urmx.study.file import load_study
from urmx.study.kinds import grid as grid_kind

from .kernel_helpers import SUPPORTS, differences, elcentro
from .test_study import ACC, DT, SCALE

STUDY = """\
[study]
name = "rest"
walls = ["s08"]
diaphragms = ["D1"]
supports = "top"
records = ["quake"]
cor = [0.8]
"""


def _c9():
    """C9 on a rigid base under El Centro x 0.6, contact law (a chatter that ends in a
    hold): 132 crack impacts at t_rest = 0.01 s, 130 at 0.02 s (tests/test_holding.py)."""
    ag, dt = elcentro()
    return dict(wall=SUPPORTS["rigid/flex"], ground_acceleration=ag[:301], dt=dt, scale=0.6,
                impact="contact")


def test_the_default_is_a_hundredth_of_a_second_and_decides_holds():
    assert kernel.T_REST == urmx.model.T_REST == 0.01
    case = _c9()
    default = kernel.run(**case)
    assert max(differences(default, kernel.run(**case, t_rest=0.01)).values()) == 0.0
    other = kernel.run(**case, t_rest=0.02)
    assert (default["crack_impacts"], other["crack_impacts"]) == (132, 130)


@pytest.mark.parametrize("bad", [0.0, -0.01, math.nan, math.inf, "soon", None])
def test_a_bad_t_rest_is_refused_in_one_line_naming_it(bad):
    ag, dt = elcentro()
    for run in (kernel.run, urmx.simulate):
        with pytest.raises(InputError) as err:
            run(SUPPORTS["rigid/flex"], ag[:11], dt, t_rest=bad)
        assert str(err.value).startswith(f"t_rest={bad!r} must be") and "\n" not in str(err.value)


def test_simulate_passes_and_records_t_rest():
    case = _c9()
    ds = urmx.simulate(case.pop("wall"), case.pop("ground_acceleration"), case.pop("dt"),
                       t_rest=0.02, **case)
    assert ds.attrs["t_rest"] == 0.02 and "t_rest=0.02" in ds.attrs["history"]
    assert int(ds["crack_impacts"]) == 130


def test_a_study_key_recorded_in_the_archive_and_in_the_cells_keys(make_study, use_records):
    use_records(ACC, SCALE, DT)
    default = load_study(make_study(STUDY, "a.toml"))
    same = load_study(make_study(STUDY + "t_rest = 0.01\n", "b.toml"))
    other = load_study(make_study(STUDY + "t_rest = 0.02\n", "c.toml"))
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
    path = make_study(STUDY + f"t_rest = {bad}\n")
    with pytest.raises(CatalogError, match="study.t_rest"):
        load_study(path)
