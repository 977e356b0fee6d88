"""The compiled kernel's on-disk cache cannot go stale (urmx.jitcache).

numba keys a cached function on its own source file only, so a compiled function of
kernel.py that calls one of model.py used to keep running the old model.py from disk after
an edit. Here a copy of the package is edited as a developer (or an upgrade) would, and a
new process must use the new physics without anyone clearing a cache.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import urmx

SCRIPT = r"""
import json, sys
import numpy as np
import urmx
from urmx import kernel, reference
wall = urmx.Wall(thickness=0.23, height=4.14, crack_ratio=2 / 3, mass=30000.0,
                 top_stiffness=815e3, top_mass=20000.0, top_damping=0.12)
t = np.arange(301) * 0.01
ag = 4.0 * np.sin(2 * np.pi * 1.5 * t) * np.exp(-t / 2.0)
out = {"kernel": kernel.run(wall, ag, 0.01), "file": urmx.__file__}
if "reference" in sys.argv:
    ref = reference.run(wall, ag, 0.01, rtol=1e-11)
    out["reference"] = {k: v for k, v in ref.items() if k != "event_log"}
print(json.dumps(out, default=float))
"""
PEAKS = ("peak_crack_displacement", "peak_top_displacement", "peak_top_acceleration",
         "instability_ratio_lower", "instability_ratio_upper", "unfavourable_fraction")


def _run(src: Path, *args: str) -> tuple[dict, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_CACHE")}
    env["PYTHONPATH"] = str(src)
    proc = subprocess.run([sys.executable, "-c", SCRIPT, *args], capture_output=True,
                          text=True, env=env, cwd=src, timeout=900)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1]), proc.stderr


@pytest.mark.slow
def test_changed_model_is_picked_up_without_clearing_any_cache(cold_kernel, tmp_path):
    """A copy of the package elsewhere, its cache in its own ``__pycache__`` (where a
    checkout keeps it), loads the kernel another process compiled from the same sources
    (the cache is keyed on their contents; `tests.fixtures.compiled`: the suite's one cold
    compile, copied there), and after an edit of model.py compiles anew, runs the new
    physics, and removes the earlier source's folder."""
    src = tmp_path / "src"
    shutil.copytree(Path(urmx.__file__).parent, src / "urmx",
                    ignore=shutil.ignore_patterns("__pycache__"))
    (compiled_folder,) = cold_kernel.cache.glob("urmx-numba-*")
    own = src / "urmx" / "__pycache__"
    shutil.copytree(compiled_folder, own / compiled_folder.name.removeprefix("urmx-"))
    first, err = _run(src)
    assert first["file"].startswith(str(src))
    assert "compiling the kernel" not in err  # the same sources: loaded, not compiled
    # a change of physics in a compiled function of model.py, which the kernel's compiled
    # code calls: family 1 now takes the lower segment's Case 2 curve too
    model = src / "urmx" / "model.py"
    text = model.read_text()
    old = '    return 3 if family == 1 else 2\n'
    assert text.count(old) == 1
    model.write_text(text.replace(old, '    return 2\n'))
    edited, err = _run(src, "reference")
    assert "compiling the kernel" in err  # nothing cleared: a new source, a new compile
    before, after = first["kernel"], edited["kernel"]
    assert any(before[k] != after[k] for k in PEAKS)
    # the new physics throughout: the reference solver (fresh compiled event functions of
    # the edited model.py) agrees with the kernel
    ref = edited["reference"]
    for k in PEAKS[:-1]:
        assert after[k] == pytest.approx(ref[k], rel=1e-8), k
    again, err = _run(src)
    assert "compiling the kernel" not in err and again["kernel"] == after  # cached too
    # the earlier source's folder is gone (a checkout's earlier sources are dead)
    folders = [f.name for f in own.glob("numba-*")]
    assert len(folders) == 1 and folders[0] != compiled_folder.name.removeprefix("urmx-")


HELPERS = '''
def scale(x, k):
    if k == 0:
        return x
    if k == 1:
        return 2.0 * x
    return x * k


def total(x, n):
    return scale(x, 0) + scale(x, 1) + scale(x, 2) + scale(x, n)
'''


def test_a_helper_compiles_one_version_per_argument_type_not_per_constant():
    """A helper (no Python wrapper: only compiled code calls it) that compiled code calls
    with the constants 0, 1 and 2 and a variable is compiled once, for (float64, int64),
    and gives the values of the Python function; numba's own dispatcher compiles it four
    times (one per literal value and one for the variable), as the kernel's helpers were
    (93 compiles of 53 functions on a first analysis, 58 since)."""
    import numba
    from numba.core import types

    from urmx import jitcache

    jitcache.materialize()  # (then jit gives numba's dispatchers themselves)
    ns: dict = {}
    exec(HELPERS, ns)  # (fresh functions: numba keeps the versions on each dispatcher)
    ns["scale"] = jitcache.jit(cache=False, no_cpython_wrapper=True,
                               no_cfunc_wrapper=True)(ns["scale"])
    total = jitcache.jit(cache=False)(ns["total"])
    assert total(1.5, 3) == 1.5 + 3.0 + 3.0 + 4.5
    assert total(1.5, 0) == 1.5 + 3.0 + 3.0 + 1.5
    assert list(ns["scale"].overloads) == [(types.float64, types.int64)]

    plain: dict = {}
    exec(HELPERS, plain)
    plain["scale"] = numba.njit(no_cpython_wrapper=True, no_cfunc_wrapper=True)(plain["scale"])
    assert numba.njit(plain["total"])(1.5, 3) == 12.0
    assert len(plain["scale"].overloads) == 4
    assert sum(isinstance(a[1], types.IntegerLiteral) for a in plain["scale"].overloads) == 3
