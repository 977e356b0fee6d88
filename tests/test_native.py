"""The kernel's loop as a native object (urmx.native): compiled once, then loaded by later
processes without numba, with the same results; a damaged object is never run."""

from __future__ import annotations

import json
import threading
from pathlib import Path

import numpy as np
import pytest

import urmx
from urmx import kernel, native

from .fixtures import compiled


def _same(a: dict, b: dict) -> bool:
    """Equal bit for bit as printed (NaN equals NaN: no collapse time)."""
    return json.dumps(a, sort_keys=True, default=float) == json.dumps(b, sort_keys=True,
                                                                       default=float)


def _object(cache: Path) -> Path:
    (meta,) = cache.glob("urmx-numba-*/march-????????????.json")  # (not march-capacity)
    return meta.with_name(json.loads(meta.read_text())["object"])


@pytest.mark.slow
def test_compiled_once_then_loaded_without_numba_with_equal_results(cold_kernel, tmp_path):
    first, err = cold_kernel.out, cold_kernel.err  # (the suite's one cold compile)
    assert "compiling the kernel" in err and "kernel compiled in" in err
    # a full-tracking analysis compiles its own loop, not the capacity searches' one
    assert "march-capacity" not in err and err.count("kernel compiled in") == 1
    assert not list(cold_kernel.cache.glob("urmx-numba-*/march-capacity-*"))
    assert "numba" in first["imported"]  # the cold process compiled it
    cache = compiled.copy_cache(cold_kernel, tmp_path / "cache")
    obj = _object(cache)
    assert obj.stat().st_size > 10_000
    again, err = compiled.run(cache)
    assert err == ""  # nothing compiled, nothing said
    assert again["imported"] == []  # the warm process never imports numba
    assert _same(again["result"], first["result"])  # bit for bit, event log included
    assert first["result"]["events"] > 10 and first["result"]["base_impacts"] > 0
    # a damaged object is detected by its checksum, compiled anew, and never run
    data = bytearray(obj.read_bytes())
    data[len(data) // 2] ^= 0xFF
    obj.write_bytes(bytes(data))
    damaged, err = compiled.run(cache)
    assert "is unusable (its checksum does not match); compiling it again" in err
    assert _same(damaged["result"], first["result"])
    healed, err = compiled.run(cache)
    assert err == "" and _same(healed["result"], first["result"])


def test_a_wrong_array_is_refused_before_the_loop_sees_it():
    wall = urmx.Wall(thickness=0.23, height=4.14, crack_ratio=2 / 3, mass=30000.0)
    tab = kernel.tables(wall, 0.01)
    with pytest.raises(ValueError, match=r"kernel array hist: <f8 1-D .* 2-D"):
        tab.args.put("hist", np.zeros(5))
    with pytest.raises(ValueError, match=r"kernel array ag: <i8"):
        tab.args.put("ag", np.zeros(5, np.int64))
    with pytest.raises(ValueError, match="contiguous: False, aligned: True"):
        tab.args.put("ag", np.zeros(10)[::2])
    names = [x[0] for x in kernel.loop.ARRAYS]
    arrays = {name: tab.args[name] for name in names}
    del arrays["KP"]
    with pytest.raises(ValueError, match=r"missing: \['KP'\]"):
        native.Args(kernel.loop.ARRAYS, arrays, 0.01, kernel.loop.LOOP)
    # the refused arrays left the block as it was: an analysis still runs correctly
    ag = np.sin(np.arange(200) * 0.1)
    assert _same(kernel.run(wall, ag, 0.01), kernel.run(wall, ag.copy(), 0.01))


def test_threads_sharing_a_wall_get_the_serial_results():
    """The call holds the GIL and a wall's blocks are locked from a run until its outputs
    are read: threads running the same wall (as a threaded dask worker may) get exactly
    what one thread gets."""
    wall = urmx.Wall(thickness=0.23, height=4.14, crack_ratio=2 / 3, mass=30000.0,
                     top_stiffness=815e3, top_mass=20000.0, top_damping=0.12)
    t = np.arange(801) * 0.01
    records = [(1.0 + 0.3 * k) * np.sin(2 * np.pi * 1.5 * t) for k in range(6)]
    serial = [kernel.run(wall, ag, 0.01) for ag in records]
    out: dict = {}

    def work(k):
        for _ in range(5):
            out[k] = kernel.run(wall, records[k], 0.01)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(6)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert all(_same(out[k], serial[k]) for k in range(6))
    assert len({r["peak_top_displacement"] for r in serial}) == 6


def test_a_wall_with_unaligned_parameters_runs_as_its_aligned_twin():
    """A wall received by a dask worker can hold its parameters in an unaligned view of
    the message buffer: the kernel copies them (the run used to stop on this)."""
    wall = urmx.Wall(thickness=0.23, height=4.14, crack_ratio=2 / 3, mass=30000.0,
                     top_stiffness=815e3, top_mass=20000.0, top_damping=0.12, pmr=60.0)
    P = wall.params
    raw = np.zeros(P.nbytes + 1, np.uint8)[1:]
    odd = raw.view(np.float64)
    odd[:] = P
    assert not odd.flags.aligned
    twin = urmx.Wall(thickness=0.23, height=4.14, crack_ratio=2 / 3, mass=30000.0,
                     top_stiffness=815e3, top_mass=20000.0, top_damping=0.12, pmr=60.0)
    object.__setattr__(twin, "_params", odd)
    kernel.clear_cache()
    ag = 2.5 * np.sin(np.arange(600) * 0.06)
    res = kernel.run(twin, ag, 0.01)
    assert res["events"] > 5
    assert _same(res, kernel.run(wall, ag, 0.01))


class _Arg:
    def __init__(self, type_):
        self.type = type_


class _Compiled:
    """Stands for numba's compiled loop in LLVM: its name and parameter types (retptr,
    excinfo, then the arguments as numba passes them)."""

    name = "loop"

    def __init__(self, types_):
        self.arguments = [_Arg(t) for t in ("ptr", "ptr", *types_)]


def test_the_shim_refuses_a_loop_numba_passes_otherwise():
    """The shim builds the loop's native arguments from the kernel's description; if numba
    passed them otherwise (another numba, a changed signature) it stops instead of calling
    the loop with misplaced arguments."""
    layout = (("a", "<f8", 2),)
    # numba's convention: an array is meminfo, parent, size, item size, data, shape,
    # strides; an int64, a boolean (as a byte), a float64
    compiled = _Compiled(["ptr", "ptr", "i64", "i64", "ptr", "i64", "i64", "i64", "i64",
                          "i64", "i8", "double"])
    good = native.Loop(None, ("a", "n", "flag", "x"), ("n", "flag"), ("x",), flags=("flag",))
    ir = native._shim(layout, good, compiled)
    assert 'call i32 @"loop"(ptr %ret, ptr %exc, ptr null, ptr null' in ir
    assert "zext i1" in ir and "load double" in ir
    wrong_flag = good._replace(flags=())  # the boolean passed as a 64-bit integer
    with pytest.raises(RuntimeError, match=r"differs from the shim's at parameter 10 "
                                           r"\(12 parameters, 12 made\)"):
        native._shim(layout, wrong_flag, compiled)
    missing = good._replace(params=("a", "n", "flag"))
    with pytest.raises(RuntimeError, match=r"at parameter 11 \(12 parameters, 11 made\)"):
        native._shim(layout, missing, compiled)


@pytest.mark.slow
def test_the_object_numba_makes_with_the_shim_gives_the_results_of_one_emitted_again(
        cold_kernel):
    """The native object is what numba's JIT makes of the loop's module with the shim
    added before optimisation (one code generation); for a loop numba had compiled before
    in the process, the object is emitted again from its optimised module (a second code
    generation, as every compile did before). Both give the same results bit for bit,
    event log included (`tests.fixtures.compiled`: the suite's one cold process)."""
    out = cold_kernel.out
    assert out["made"] == ["bytes", "NoneType"]  # the first compile took numba's object
    assert out["size"] > 10_000 and out["result"]["events"] > 10
    assert out["same"] and out["called"]


def test_a_capacity_search_runs_the_loop_with_the_runs_of_plain_steps_and_others_not():
    """Two native objects of one loop: ``march-capacity`` (``_march`` with its runs of
    plain steps, SLP-vectorised) for ``track="capacity"``, and ``march`` (the same code with
    the runs replaced by a function that takes none) for everything else."""
    from urmx.kernel import loop

    full, capacity = loop.LOOPS
    assert (full.name, capacity.name) == ("march", "march-capacity")
    assert capacity.vectorize == loop.PLAIN_RUNS and full.vectorize == ()
    assert capacity.function.py_func is loop._march.py_func
    code = full.function.dispatcher.py_func
    assert code.__code__ is loop._march.py_func.__code__ and code.__name__ == "_march_full"
    assert code.__globals__["_plain_2"] is code.__globals__["_plain_3"] is loop._no_plain
    assert loop._march.py_func.__globals__["_plain_2"] is loop._plain_2
