"""Compiled code of urmx: made lazily, cached on disk keyed on the source it compiles.

* **Lazy.** :func:`jit` marks a function for numba without importing numba: numba is
  imported, and every marked function becomes a numba dispatcher, only when a compiled
  function is first needed (:func:`materialize`). A process that loads the kernel from its
  native object (:mod:`urmx.native`) never imports numba at all (about 0.35 s of imports
  and 0.4 s of numba's own set-up when it loads a cached function).
* **Never stale.** numba keys a cached function on its own file only: a compiled function
  of ``kernel/loop.py`` that calls a compiled function of ``model.py`` keeps running the old code
  from disk after ``model.py`` changes. Here every compiled urmx function (numba's cache
  and the kernel's native object) is cached in a folder named by a hash of the contents of
  *all* urmx modules with compiled code (and the numba, llvmlite and Python versions), and
  that hash is also the source stamp numba checks: a change in any of them means a new
  folder and a fresh compile, never a stale load. In the package's own ``__pycache__`` the
  folders of earlier sources are removed when a new one is made.
* **One version per argument types.** A helper (a function without a Python wrapper,
  which only compiled code calls) is compiled once per types of its arguments, not once
  per literal constant a caller passes (:func:`_helper_class`): the kernel's first compile
  makes 58 numba compiles instead of 93, with the same results bit for bit.

The folder is ``urmx/__pycache__/numba-<hash>`` when the package folder is writable, else
``<user cache>/urmx/numba-<hash>``; with ``NUMBA_CACHE_DIR`` set it is
``$NUMBA_CACHE_DIR/urmx-numba-<hash>``.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import shutil
import sys
import threading
import types
from pathlib import Path

HERE = Path(__file__).resolve().parent
# every urmx module that defines compiled (numba) functions, and the kernel's other modules
# (its tables and checks shape every result the compiled loop gives)
COMPILED_MODULES = ("jitcache.py", "model.py", "kernel/__init__.py", "kernel/checks.py",
                    "kernel/loop.py", "kernel/pieces.py", "native.py")


def _version_stamp(package: str) -> bytes:
    """The version of an installed package without importing it (importing numba costs
    0.35 s): its ``_version.py``, else its ``__version__``."""
    spec = importlib.util.find_spec(package)
    if spec is not None and spec.origin:
        path = Path(spec.origin).parent / "_version.py"
        if path.is_file():
            return path.read_bytes()
    return str(getattr(__import__(package), "__version__", "")).encode()


def source_hash() -> str:
    """Hash of the compiled modules' sources and the numba, llvmlite and Python versions."""
    h = hashlib.sha256()
    for name in COMPILED_MODULES:
        h.update(name.encode())
        h.update((HERE / name).read_bytes())
    for package in ("numba", "llvmlite"):
        h.update(_version_stamp(package))
    h.update(sys.version.encode())
    return h.hexdigest()[:16]


SOURCE_HASH = source_hash()
PREFIX = "numba-"


def _candidates() -> list[Path]:
    numba_dir = os.environ.get("NUMBA_CACHE_DIR", "")  # as numba.core.config reads it
    if numba_dir:
        return [Path(numba_dir) / f"urmx-{PREFIX}{SOURCE_HASH}"]
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


def _locator_class():
    """numba's cache locator for urmx's own compiled functions (numba imported here)."""
    from numba.core import caching

    class UrmxCacheLocator(caching._CacheLocator):
        """numba cache locator for urmx's compiled functions (see the module docstring)."""

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
        impl = caching.CacheImpl
    except AttributeError:  # numba before 0.62
        impl = caching._CacheImpl
    return UrmxCacheLocator, impl


# ---- lazy compilation -------------------------------------------------------------------

class Lazy:
    """A function marked for numba: its dispatcher (and numba) is made on first use.

    ``py_func`` is the Python function; calling, or asking for any numba attribute, makes
    every marked function of urmx a dispatcher (:func:`materialize`)."""

    def __init__(self, py_func, options: dict):
        self.py_func = py_func
        self.options = options
        self.dispatcher = None
        self.__name__ = py_func.__name__
        self.__qualname__ = py_func.__qualname__
        self.__doc__ = py_func.__doc__
        self.__module__ = py_func.__module__
        self.__wrapped__ = py_func

    def __call__(self, *args, **kwargs):
        materialize()
        return self.dispatcher(*args, **kwargs)

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        materialize()
        return getattr(self.dispatcher, name)

    def __repr__(self) -> str:
        return f"<urmx.jitcache.Lazy {self.__qualname__} (numba {self.options})>"


_LAZY: list[Lazy] = []
_LOCK = threading.RLock()
_MATERIALIZED = False


def _helper_class():
    """numba's dispatcher for a helper (a function without a CPython wrapper: only
    compiled code calls it) that compiles one version per type of its arguments, not one
    per literal value.

    Called from compiled code with a constant (``_put(..., 0)``, ``_newton(..., 1)``),
    numba's dispatcher types that argument as a literal (``Literal[int](0)``) and compiles
    the helper once for each value: 93 compiles of 53 functions in the kernel. The helpers
    are inlined into their callers (``forceinline``) or small, so LLVM propagates the
    constant after inlining as it did in the literal version; the values are the same
    (the same operations in the same order). Here the arguments' types lose their literal
    value before numba looks for a version to compile."""
    global _HELPER
    if _HELPER is not None:
        return _HELPER
    from numba.core import registry, types

    class UrmxHelper(registry.CPUDispatcher):
        """A CPU dispatcher whose calls from compiled code drop literal argument types."""

        def get_call_template(self, args, kws):
            return super().get_call_template(
                tuple(types.unliteral(a) for a in args),
                {k: types.unliteral(v) for k, v in kws.items()})

    # importable as urmx.jitcache.UrmxHelper (module __getattr__), so that a helper's
    # dispatcher pickles as numba's do
    UrmxHelper.__module__, UrmxHelper.__qualname__ = __name__, "UrmxHelper"
    _HELPER = UrmxHelper
    return _HELPER


_HELPER = None


def __getattr__(name: str):
    if name == "UrmxHelper":  # (numba imported here)
        return _helper_class()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _dispatcher(py_func, options: dict):
    """numba's dispatcher of a function (numba imported); a helper's of
    :func:`_helper_class`."""
    import numba

    dispatcher = numba.njit(**options)(py_func)
    if options.get("no_cpython_wrapper"):
        dispatcher.__class__ = _helper_class()
    return dispatcher


def jit(**options):
    """``numba.njit(**options)`` without importing numba until a compiled function is used."""
    def decorate(py_func):
        if _MATERIALIZED:
            return _dispatcher(py_func, options)
        lazy = Lazy(py_func, options)
        _LAZY.append(lazy)
        return lazy
    return decorate


class Variant:
    """A marked function compiled with some of the compiled functions it calls replaced:
    its code with other module globals, for a second, specialised native object (the
    kernel's loop without the plain-step runs that only a capacity search uses).

    ``lazy`` is a :class:`Lazy` (or numba's dispatcher); ``replace`` maps global names of
    its module to marked functions. The dispatcher (:attr:`dispatcher`, named ``name``) is
    made on first use, from the module's globals as :func:`materialize` left them."""

    def __init__(self, lazy, name: str, **replace):
        self.lazy, self.name, self.replace = lazy, name, replace
        self._dispatcher = None

    @property
    def dispatcher(self):
        if self._dispatcher is None:
            materialize()
            with _LOCK:
                if self._dispatcher is None:
                    py = self.lazy.py_func
                    space = dict(vars(sys.modules[py.__module__]))
                    space.update({k: getattr(f, "dispatcher", None) or f
                                  for k, f in self.replace.items()})
                    func = types.FunctionType(py.__code__, space, self.name, py.__defaults__,
                                              py.__closure__)
                    func.__qualname__ = self.name
                    func.__doc__ = py.__doc__
                    self._dispatcher = _dispatcher(func, self.lazy.options if isinstance(
                        self.lazy, Lazy) else self.lazy.targetoptions)
        return self._dispatcher

    def __repr__(self) -> str:
        return f"<urmx.jitcache.Variant {self.name} of {self.lazy.__qualname__}>"


def materialize() -> None:
    """Import numba, install urmx's cache locator and make every marked function a numba
    dispatcher, in the module globals of urmx too (numba resolves the functions a compiled
    function calls through its globals when it compiles it)."""
    global _MATERIALIZED
    if _MATERIALIZED:
        return
    with _LOCK:
        if _MATERIALIZED:
            return
        locator, impl = _locator_class()
        if not any(c.__name__ == locator.__name__ for c in impl._locator_classes):
            impl._locator_classes.insert(0, locator)
        for lazy in _LAZY:
            lazy.dispatcher = _dispatcher(lazy.py_func, lazy.options)
        for name, module in list(sys.modules.items()):
            if module is not None and (name == "urmx" or name.startswith("urmx.")):
                space = vars(module)
                for key, value in list(space.items()):
                    if isinstance(value, Lazy):
                        space[key] = value.dispatcher
        _MATERIALIZED = True


