"""The kernel's integration loop as native code: compiled once by numba, loaded in ms.

numba compiles the loop (:func:`urmx.kernel.loop._march`, 15 arguments, 51 arrays in all)
as usual. A small LLVM function, ``urmx_march_native(ret, exc, iv, fv)``, is added to its
module before numba optimises it: it reads the loop's arguments from two blocks (an int64
block with the address and shape of each array of ``urmx.kernel.loop.ARRAYS``, one slot of
``SLOT`` entries each, followed by the integer arguments; a float64 block with the real
ones), passes them as numba passes arguments (an array as meminfo, parent, size, item size,
data, shape and strides) and calls the loop. The object file numba's JIT makes of that
module (the loop and the shim, compiled once), which refers to no symbol outside itself, is
kept and written into urmx's cache folder (:mod:`urmx.jitcache`: keyed on the compiled
sources and the numba, llvmlite and Python versions; here also on the CPU, since the code
uses this CPU's instruction set). Every process, the compiling one included, loads that
object with llvmlite's MCJIT (a few ms) and calls the shim through ctypes: a warm process
never imports numba, whose import and cache loading cost about 0.8 s a process.

Each loop is named (:attr:`Loop.name`) and is its own object, compiled on its first call:
the kernel keeps two of the same arguments, ``march`` and ``march-capacity``
(:data:`urmx.kernel.loop.LOOPS`), and :meth:`Args.run` takes either.

Before an object is loaded its SHA-256 and the array layout it was compiled for are
checked against the JSON file that names it (written after the object, which is named by
its checksum, so a write cut short or a concurrent one leaves no mismatched pair); a
missing, corrupt or foreign object is compiled anew. The call holds the GIL, as numba's
dispatcher did (a wall's work arrays are shared).
"""

from __future__ import annotations

import ctypes
import hashlib
import json
import os
import sys
import threading
import time
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from . import jitcache

SLOT = 5  # int64 entries of an array in the block: its address and up to 4 dimensions


def _address(a: np.ndarray) -> int:
    return a.ctypes.data


class Loop(NamedTuple):
    """What the shim must know of the compiled loop: the function (numba's dispatcher or a
    :class:`urmx.jitcache.Lazy` of it) and its parameters in order, as names of the layout's
    arrays, of the integer arguments (``ints``, in the int64 block after the array slots;
    those in ``flags`` are booleans) and of the real ones (``reals``, the float64 block), or
    tuples of array names (passed as tuples)."""

    function: Any
    params: tuple
    ints: tuple
    reals: tuple
    flags: tuple = ()
    vectorize: tuple = ()
    name: str = "march"  # its native object's name in the cache folder


class Args:
    """The argument blocks of one wall's analyses at one record step.

    ``layout`` names each array of the loop with its dtype and number of dimensions, and
    ``arrays`` gives one for each name: the wall's tables, work and output arrays. They are
    checked against the layout and written once (:meth:`put` replaces one; they must stay
    alive and in place while they are in the block). ``loop`` describes the loop the blocks
    are for (compiled on the first run if no cached object serves). An analysis passes its
    own record (the ``record`` array) to :meth:`run`. Hold :attr:`lock` from a run until
    its outputs are read: a wall's blocks and arrays serve one analysis at a time."""

    def __init__(self, layout, arrays: dict, dt: float, loop: Loop, record: str = "ag"):
        self.layout = tuple(tuple(x) for x in layout)
        self.loop = loop
        self._index = {x[0]: i for i, x in enumerate(self.layout)}
        missing = [name for name in self._index if name not in arrays]
        if missing or len(arrays) != len(self.layout):
            raise ValueError(f"kernel arrays {sorted(arrays)} do not match the layout "
                             f"(missing: {missing})")
        n = len(self.layout)
        self.iv = np.zeros(n * SLOT + len(loop.ints), np.int64)
        self.fv = np.zeros(len(loop.reals))
        self.fv[0] = dt
        self._arrays: dict = {}
        for name, a in arrays.items():
            self.put(name, a)
        self._n = n * SLOT
        self._record_at = self._index[record] * SLOT
        if self.layout[self._index[record]][2] != 1:
            raise ValueError("the record must be a 1-D array")
        self.lock = threading.Lock()
        self._fns: dict = {}  # loop name: its native function
        self._ret = ctypes.c_int64(0)
        self._exc = ctypes.c_void_p(0)
        self._ptrs = (ctypes.addressof(self._ret), ctypes.addressof(self._exc),
                      _address(self.iv), _address(self.fv))

    def put(self, name: str, a: np.ndarray) -> None:
        """Write an array into its slot (checked against the layout)."""
        i = self._index[name]
        _, dtype, ndim = self.layout[i]
        if a.dtype.str != dtype or a.ndim != ndim or not (a.flags.c_contiguous
                                                          and a.flags.aligned):
            raise ValueError(f"kernel array {name}: {a.dtype.str} {a.ndim}-D "
                             f"(contiguous: {a.flags.c_contiguous}, aligned: "
                             f"{a.flags.aligned}), the loop reads an aligned, C-contiguous "
                             f"{dtype} {ndim}-D array")
        at = i * SLOT
        self.iv[at] = _address(a)
        self.iv[at + 1:at + 1 + ndim] = a.shape
        self._arrays[name] = a

    def __getitem__(self, name: str) -> np.ndarray:
        return self._arrays[name]

    def run(self, record: np.ndarray, ints, reals, loop: Loop | None = None) -> int:
        """Run the loop (:attr:`loop`, or another one of the same arguments) on the record
        (a C-contiguous float64 array, as :func:`urmx.kernel.run` makes it), the integer
        arguments and the real ones after dt; returns its status code."""
        loop = loop or self.loop
        fn = self._fns.get(loop.name)
        if fn is None:
            fn = self._fns[loop.name] = function(self.layout, loop)
        iv, at = self.iv, self._record_at
        iv[at] = _address(record)
        iv[at + 1] = record.shape[0]  # (the caller keeps the record alive during the run)
        n = self._n
        iv[n:n + len(ints)] = ints
        fv = self.fv
        for i, x in enumerate(reals, 1):
            fv[i] = x
        status = fn(*self._ptrs)
        if status < 0:  # numba's error status: the loop raises nothing
            raise RuntimeError("the native kernel reported an error status")
        return status


# ---- loading or compiling the native loop ----------------------------------------------

_FUNCTIONS: dict = {}  # loop name: (layout, the loaded function)
_KEEP: list = []  # the MCJIT engines behind the loaded functions
_LOCK = threading.Lock()
_PROTO = ctypes.PYFUNCTYPE(ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p,
                           ctypes.c_void_p, ctypes.c_void_p)


def function(layout, loop: Loop):
    """The native loop for an array layout: loaded from the cache, else compiled (each
    loop, by its name, once a process)."""
    known = _FUNCTIONS.get(loop.name)
    if known is None or known[0] != layout:
        with _LOCK:
            known = _FUNCTIONS.get(loop.name)
            if known is None or known[0] != layout:
                meta_path = description_path(loop.name)
                fn = _load(layout, meta_path) or _compile(layout, loop, meta_path)
                known = _FUNCTIONS[loop.name] = (layout, fn)
    return known[1]


def _llvm():
    import llvmlite.binding as ll

    ll.initialize_native_target()
    ll.initialize_native_asmprinter()
    return ll


def _cpu_key(ll) -> str:
    """This CPU as numba compiles for it (NUMBA_CPU_NAME/FEATURES override the host)."""
    h = hashlib.sha256()
    for part in (ll.get_process_triple(), ll.get_host_cpu_name(),
                 ll.get_host_cpu_features().flatten(), os.environ.get("NUMBA_CPU_NAME", ""),
                 os.environ.get("NUMBA_CPU_FEATURES", "")):
        h.update(part.encode() + b"\0")
    return h.hexdigest()[:12]


def description_path(name: str) -> Path | None:
    """The JSON description of the native loop `name` for this source and CPU, which names
    its object file (None: no writable cache folder)."""
    folder = jitcache.cache_dir()
    if folder is None:
        return None
    return folder / f"{name}-{_cpu_key(_llvm())}.json"


def _load(layout, meta_path: Path | None):
    if meta_path is None or not meta_path.is_file():
        return None
    obj = meta_path
    try:
        meta = json.loads(meta_path.read_text())
        if [tuple(x) for x in meta.get("layout", [])] != list(layout):
            return None  # compiled for other arrays: compile for these
        obj = meta_path.with_name(meta["object"])
        data = obj.read_bytes()
        if hashlib.sha256(data).hexdigest() != meta.get("sha256"):
            raise ValueError("its checksum does not match")
        return _engine(data, meta["symbol"])
    except Exception as exc:  # anything unusable is compiled anew
        sys.stderr.write(f"urmx: the cached kernel {obj} is unusable ({exc}); "
                         "compiling it again\n")
        return None


def _engine(data: bytes, symbol: str):
    """The function `symbol` of object code `data`, loaded by llvmlite's MCJIT."""
    ll = _llvm()
    engine = ll.create_mcjit_compiler(
        ll.parse_assembly(""), ll.Target.from_default_triple().create_target_machine())
    engine.add_object_file(ll.ObjectFileRef.from_data(data))
    engine.finalize_object()
    address = engine.get_function_address(symbol)
    if not address:
        raise ValueError(f"it has no symbol {symbol!r}")
    _KEEP.append(engine)
    return _PROTO(address)


SYMBOL = "urmx_march_native"
_DTYPES = {"<f8": ("float64", 8), "<i8": ("int64", 8), "|b1": ("boolean", 1)}


def _compile(layout, loop: Loop, meta_path: Path | None):
    where = meta_path.parent if meta_path else "nowhere: no writable cache folder"
    what = "the kernel" if loop.name == "march" else f"the kernel's {loop.name} loop"
    sys.stderr.write(f"urmx: compiling {what} (once per install; cached in {where}) ...\n")
    sys.stderr.flush()
    started = time.perf_counter()
    jitcache.materialize()
    from numba import types

    # a jitcache.Lazy (its dispatcher made by materialize), or numba's dispatcher
    dispatcher = getattr(loop.function, "dispatcher", None) or loop.function
    arrays = {x[0]: types.Array(getattr(types, _DTYPES[x[1]][0]), x[2], "C") for x in layout}
    scalar = {**{n: types.int64 for n in loop.ints}, **{n: types.float64 for n in loop.reals},
              **{n: types.boolean for n in loop.flags}}

    def numba_type(p):
        return types.Tuple([numba_type(q) for q in p]) if isinstance(p, tuple) else (
            arrays[p] if p in arrays else scalar[p])

    sig = tuple(numba_type(p) for p in loop.params)
    data = _compile_with_shim(dispatcher, sig, layout, loop)
    if data is None:  # compiled before in this process: emitted from its optimised module
        cres = dispatcher.overloads[sig]
        ll = _llvm()
        module = ll.parse_assembly(str(cres.library._final_module))
        if not any(f.name == SYMBOL and not f.is_declaration for f in module.functions):
            module.link_in(ll.parse_assembly(_shim(layout, loop, module.get_function(
                cres.fndesc.mangled_name))))
        data = cres.library._codegen._tm.emit_object(module)
    fn = _engine(data, SYMBOL)
    if meta_path is not None:
        try:
            _store(data, SYMBOL, layout, meta_path)
        except Exception as exc:  # the kernel runs; the next process compiles again
            sys.stderr.write(f"urmx: could not store the compiled kernel ({exc}); each "
                             "new process will compile it\n")
    sys.stderr.write(f"urmx: kernel compiled in {time.perf_counter() - started:.1f} s\n")
    return fn


def _compile_with_shim(dispatcher, sig, layout, loop: Loop) -> bytes | None:
    """numba compiles the loop for `sig` with the shim in its module, and the object code
    numba's JIT makes of that module is the native object (None if the loop had been
    compiled for `sig` before in this process).

    The shim is added to the loop's library when numba asks for the loop's machine code,
    so it is optimised and compiled with the loop, once: emitting the object again from
    the module numba had compiled (as before) cost a second code generation of the whole
    loop (about 1 s) and gave code of the same speed (paired 1.00)."""
    from numba.core import codegen, config, cpu
    from numba.core.compiler_lock import global_compiler_lock

    ll = _llvm()
    py_func = dispatcher.py_func
    own = "get_executable" in vars(cpu.CPUContext)
    executable = cpu.CPUContext.get_executable
    libraries = []

    def with_shim(self, library, fndesc, env):
        if (not libraries and not library._finalized and fndesc.qualname ==
                py_func.__qualname__ and fndesc.modname == py_func.__module__):
            compiled = library._final_module.get_function(fndesc.mangled_name)
            library.add_llvm_module(ll.parse_assembly(_shim(layout, loop, compiled)))
            library.enable_object_caching()  # numba's JIT hands over the object it makes
            libraries.append(library)
        return executable(self, library, fndesc, env)

    optimize = codegen.CPUCodeLibrary._optimize_final_module

    def vectorizing(self):
        # the functions named in loop.vectorize are optimised with LLVM's SLP vectorizer
        # (numba's default leaves it off: on the rest of the loop it cost 10-15 %)
        if self.name not in loop.vectorize:
            return optimize(self)
        slp = config.SLP_VECTORIZE
        config.SLP_VECTORIZE = 1
        try:
            return optimize(self)
        finally:
            config.SLP_VECTORIZE = slp

    with global_compiler_lock:  # (no other thread compiles while the hook is in place)
        cpu.CPUContext.get_executable = with_shim
        codegen.CPUCodeLibrary._optimize_final_module = vectorizing
        try:
            dispatcher.compile(sig)
        finally:
            codegen.CPUCodeLibrary._optimize_final_module = optimize
            if own:
                cpu.CPUContext.get_executable = executable
            else:  # (inherited in this numba version)
                del cpu.CPUContext.get_executable
    try:
        return libraries[0]._get_compiled_object() if libraries else None
    except (RuntimeError, ValueError):  # numba kept no object: emitted from the module
        return None


def _shim(layout, loop: Loop, compiled) -> str:
    """LLVM IR of ``urmx_march_native(iv, fv)``: the loop's arguments read from the blocks
    and passed as numba passes them (an array as meminfo, parent, size, item size, data,
    shape and strides), the loop called, its result returned (-1000 on an error status)."""
    ir = _ShimBody(layout, loop)
    for p in loop.params:
        ir.walk(p)
    expected = [str(a.type) for a in compiled.arguments][2:]
    got = [t for t, _ in ir.values]
    if got != expected:  # numba passes arguments otherwise than this shim assumes
        first = next((i for i, (a, b) in enumerate(zip(got, expected, strict=False))
                      if a != b), min(len(got), len(expected)))
        raise RuntimeError(f"the loop's native signature differs from the shim's at "
                           f"parameter {first} ({len(expected)} parameters, {len(got)} "
                           "made)")
    args = ", ".join(f"{t} {v}" for t, v in ir.values)
    return "\n".join([
        f"declare i32 @\"{compiled.name}\"(ptr, ptr, {', '.join(expected)})",
        f"define i64 @{SYMBOL}(ptr %ret, ptr %exc, ptr %iv, ptr %fv) {{",
        "entry:",
        *ir.body,
        f"  %status = call i32 @\"{compiled.name}\"(ptr %ret, ptr %exc, {args})",
        "  %value = load i64, ptr %ret",
        "  %ok = icmp eq i32 %status, 0",
        "  %out = select i1 %ok, i64 %value, i64 -1000",
        "  ret i64 %out",
        "}",
    ]) + "\n"


class _ShimBody:
    """The shim's body as it is written: its instructions (``body``) and the (type, value)
    of each argument of the loop's call (``values``), made parameter by parameter."""

    def __init__(self, layout, loop: Loop):
        self.layout, self.loop = layout, loop
        self.index = {x[0]: i for i, x in enumerate(layout)}
        self.body: list[str] = []
        self.values: list[tuple[str, str]] = []
        self.count = 0

    def tmp(self) -> str:
        self.count += 1
        return f"%t{self.count}"

    def load(self, block: str, kind: str, k) -> str:
        ptr, val = self.tmp(), self.tmp()
        self.body.append(f"  {ptr} = getelementptr {kind}, ptr %{block}, i64 {k}")
        self.body.append(f"  {val} = load {kind}, ptr {ptr}")
        return val

    def array(self, name: str) -> None:
        """An array argument: its address, shape and strides read from the int block."""
        _, dtype, ndim = self.layout[self.index[name]]
        at = self.index[name] * SLOT
        size = _DTYPES[dtype][1]
        address = self.load("iv", "i64", at)
        dims = [self.load("iv", "i64", at + 1 + j) for j in range(ndim)]
        nitems = dims[0]
        for d in dims[1:]:
            prod = self.tmp()
            self.body.append(f"  {prod} = mul i64 {nitems}, {d}")
            nitems = prod
        data = self.tmp()
        self.body.append(f"  {data} = inttoptr i64 {address} to ptr")
        strides = [str(size)]
        for j in range(ndim - 1, 0, -1):
            st = self.tmp()
            self.body.append(f"  {st} = mul i64 {strides[0]}, {dims[j]}")
            strides.insert(0, st)
        self.values.extend([("ptr", "null"), ("ptr", "null"), ("i64", nitems),
                            ("i64", str(size)), ("ptr", data)])
        self.values.extend(("i64", d) for d in dims)
        self.values.extend(("i64", st) for st in strides)

    def walk(self, p) -> None:
        """The argument(s) of loop parameter `p` (a tuple of them, an array, an int or a
        flag, a real)."""
        loop, layout = self.loop, self.layout
        if isinstance(p, tuple):
            for q in p:
                self.walk(q)
        elif p in self.index:
            self.array(p)
        elif p in loop.ints:
            v = self.load("iv", "i64", len(layout) * SLOT + loop.ints.index(p))
            if p in loop.flags:  # a boolean: numba passes it as a byte
                b, byte = self.tmp(), self.tmp()
                self.body.append(f"  {b} = icmp ne i64 {v}, 0")
                self.body.append(f"  {byte} = zext i1 {b} to i8")
                self.values.append(("i8", byte))
            else:
                self.values.append(("i64", v))
        else:
            self.values.append(("double", self.load("fv", "double", loop.reals.index(p))))


def _store(data: bytes, symbol: str, layout, meta: Path) -> None:
    """Write the object under a name of its checksum, then the description that names it
    (each by an atomic rename): a reader sees a whole pair or none."""
    digest = hashlib.sha256(data).hexdigest()
    obj = meta.with_name(f"{meta.stem}-{digest[:16]}.o")
    tag = f".tmp-{os.getpid()}-{threading.get_ident()}"
    description = {"object": obj.name, "symbol": symbol, "sha256": digest,
                   "layout": [list(x) for x in layout], "source": jitcache.SOURCE_HASH}
    for path, content in ((obj, data), (meta, json.dumps(description).encode())):
        tmp = path.with_name(path.name + tag)
        tmp.write_bytes(content)
        os.replace(tmp, path)
