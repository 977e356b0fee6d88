"""numba's on-disk cache for urmx, keyed on the source it compiles, so it cannot go stale.

numba keys a cached function on its own file only: a compiled function of ``kernel.py``
that calls a compiled function of ``model.py`` keeps running the old code from disk after
``model.py`` changes. Here every compiled urmx function is cached in a folder named by a
hash of the contents of *all* urmx modules with compiled code (and the numba version), and
that hash is also the source stamp numba checks: a change in any of them means a new
folder and a fresh compile, never a stale load. In the package's own ``__pycache__`` the
folders of earlier sources are removed when a new one is made.

The folder is ``urmx/__pycache__/numba-<hash>`` when the package folder is writable, else
``<user cache>/urmx/numba-<hash>``; with ``NUMBA_CACHE_DIR`` set it is
``$NUMBA_CACHE_DIR/urmx-numba-<hash>``. This module must be imported before any
``@njit(cache=True)`` decorator of the package runs (``model`` and ``kernel`` import it first).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import sys
from pathlib import Path

import numba
from numba.core import caching, config

HERE = Path(__file__).resolve().parent
# every urmx module that defines compiled (numba) functions
COMPILED_MODULES = ("jitcache.py", "model.py", "kernel.py")


def source_hash() -> str:
    """Hash of the compiled modules' sources, the numba version and the Python version."""
    h = hashlib.sha256()
    for name in COMPILED_MODULES:
        h.update(name.encode())
        h.update((HERE / name).read_bytes())
    h.update(numba.__version__.encode())
    h.update(sys.version.encode())
    return h.hexdigest()[:16]


SOURCE_HASH = source_hash()
PREFIX = "numba-"


def _candidates() -> list[Path]:
    if config.CACHE_DIR:
        return [Path(config.CACHE_DIR) / f"urmx-{PREFIX}{SOURCE_HASH}"]
    user = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "urmx"
    return [HERE / "__pycache__" / f"{PREFIX}{SOURCE_HASH}", user / f"{PREFIX}{SOURCE_HASH}"]


def _writable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / f".probe-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
        return True
    except OSError:
        return False


def _prune(path: Path) -> None:
    """Remove the cache folders of earlier sources beside `path` (best effort)."""
    for old in path.parent.glob(f"*{PREFIX}*"):
        if old != path and old.is_dir() and old.name.endswith(tuple("0123456789abcdef")):
            shutil.rmtree(old, ignore_errors=True)


_CACHE_DIR: Path | None = None


def cache_dir() -> Path | None:
    """The folder of this source's compiled functions (None: no writable place)."""
    global _CACHE_DIR
    if _CACHE_DIR is None:
        for path in _candidates():
            fresh = not path.exists()
            if _writable(path):
                if fresh and path.parent == HERE / "__pycache__":
                    _prune(path)  # this source tree's own folder: earlier sources are dead
                _CACHE_DIR = path
                break
    return _CACHE_DIR


def is_compiled(function_name: str) -> bool:
    """Whether a compiled function of urmx has an entry in the cache (a first call will
    load it rather than compile it)."""
    path = cache_dir()
    return path is not None and any(path.glob(f"*.{function_name}-*.nbi"))


class UrmxCacheLocator(caching._CacheLocator):
    """numba cache locator for urmx's own compiled functions (see the module docstring)."""

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno

    def ensure_cache_path(self):
        if cache_dir() is None:
            raise OSError("no writable cache folder for urmx's compiled kernel")

    def get_cache_path(self):
        return str(cache_dir())

    def get_source_stamp(self):
        return SOURCE_HASH

    def get_disambiguator(self):
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        try:
            if Path(py_file).resolve().parent != HERE:
                return None
        except OSError:
            return None
        self = cls(py_func, py_file)
        try:
            self.ensure_cache_path()
        except OSError:
            return None
        return self


try:
    _impl = caching.CacheImpl
except AttributeError:  # numba before 0.62
    _impl = caching._CacheImpl
if UrmxCacheLocator not in _impl._locator_classes:
    _impl._locator_classes.insert(0, UrmxCacheLocator)
