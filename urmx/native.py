"""The kernel's integration loop as native code: compiled once by numba, loaded in ms.

The loop (:func:`urmx.kernel._march`) takes two pointer arguments: an int64 block with the
address and shape of each of its arrays (``urmx.kernel.ARRAYS``, one slot of ``SLOT``
entries each) followed by its integer arguments, and a float64 block with its real ones.
A cold start compiles it with numba and writes its machine code (the loop and every helper
it calls; it refers to no symbol outside itself) as an object file into urmx's cache folder
(:mod:`urmx.jitcache`: keyed on the compiled sources and the numba, llvmlite and Python
versions; here also on the CPU, since the code uses this CPU's instruction set). Every
later process loads that object with llvmlite's MCJIT (a few ms) and calls it through
ctypes: it never imports numba, whose import and cache loading cost about 0.8 s a process.

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

import numpy as np

from . import jitcache

SLOT = 5  # int64 entries of an array in the block: its address and up to 4 dimensions


def _address(a: np.ndarray) -> int:
    return a.__array_interface__["data"][0]


class Args:
    """The argument blocks of one wall's analyses at one record step.

    ``layout`` names each array of the loop with its dtype and number of dimensions, and
    ``arrays`` gives one for each name: the wall's tables, work and output arrays. They are
    checked against the layout and written once (:meth:`put` replaces one; they must stay
    alive and in place while they are in the block). An analysis passes its own record
    (the ``record`` array) to :meth:`run`. Hold :attr:`lock` from a run until its outputs
    are read: a wall's blocks and arrays serve one analysis at a time."""

    def __init__(self, layout, arrays: dict, dt: float, record: str = "ag"):
        self.layout = tuple(tuple(x) for x in layout)
        self._index = {x[0]: i for i, x in enumerate(self.layout)}
        missing = [name for name in self._index if name not in arrays]
        if missing or len(arrays) != len(self.layout):
            raise ValueError(f"kernel arrays {sorted(arrays)} do not match the layout "
                             f"(missing: {missing})")
        n = len(self.layout)
        self.iv = np.zeros(n * SLOT + 3, np.int64)
        self.fv = np.zeros(3)
        self.fv[0] = dt
        self._arrays: dict = {}
        for name, a in arrays.items():
            self.put(name, a)
        self._n = n * SLOT
        self._record_at = self._index[record] * SLOT
        if self.layout[self._index[record]][2] != 1:
            raise ValueError("the record must be a 1-D array")
        self.lock = threading.Lock()
        self._fn = None
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

    def run(self, loop, record: np.ndarray, ints, reals) -> int:
        """Run the loop (``loop``: the compiled function, used if it must be compiled) on
        the record (a C-contiguous float64 array, as :func:`urmx.kernel.run` makes it), the
        integer arguments and the real ones after dt; returns its status code."""
        fn = self._fn
        if fn is None:
            fn = self._fn = function(self.layout, loop)
        iv, at = self.iv, self._record_at
        iv[at] = record.ctypes.data
        iv[at + 1] = record.shape[0]  # (the caller keeps the record alive during the run)
        n = self._n
        iv[n], iv[n + 1], iv[n + 2] = ints
        self.fv[1], self.fv[2] = reals
        if fn(*self._ptrs) != 0:  # numba's status word: the loop raises nothing
            raise RuntimeError("the native kernel reported an error status")
        return self._ret.value


def view_intrinsic(layout):
    """A numba intrinsic ``view(iv, k)``: the k-th array of ``layout`` as a C-contiguous
    array over the memory its slot of the block names (k a constant). It owns nothing:
    the loop is compiled without reference counting, and ``numba.carray`` needs it."""
    from numba import types
    from numba.core.extending import intrinsic
    from numba.np.arrayobj import make_array, populate_array

    dtypes = {"<f8": types.float64, "<i8": types.int64, "|b1": types.boolean}

    @intrinsic(prefer_literal=True)
    def view(typingctx, iv, k):
        if not isinstance(k, types.IntegerLiteral):
            return None
        index = k.literal_value
        _, dtype, ndim = layout[index]
        item = dtypes[dtype]
        aryty = types.Array(item, ndim, "C")

        def codegen(context, builder, signature, args):
            block = args[0]
            at = index * SLOT

            def entry(j):
                return builder.load(builder.gep(block, [context.get_constant(types.intp,
                                                                              at + j)]))

            ary = make_array(aryty)(context, builder)
            dims = [entry(1 + j) for j in range(ndim)]
            size = context.get_abi_sizeof(context.get_data_type(item))
            strides = [context.get_constant(types.intp, size)]
            for j in range(ndim - 1, 0, -1):
                strides.insert(0, builder.mul(strides[0], dims[j]))
            data = builder.inttoptr(entry(0), context.get_data_type(item).as_pointer())
            populate_array(ary, data=data, shape=dims, strides=strides,
                           itemsize=context.get_constant(types.intp, size), meminfo=None)
            return ary._getvalue()

        return aryty(iv, k), codegen

    return view


# ---- loading or compiling the native loop ----------------------------------------------

_FUNCTION = None
_FUNCTION_LAYOUT = None
_KEEP: list = []  # the MCJIT engine or numba library behind _FUNCTION
_LOCK = threading.Lock()
_PROTO = ctypes.PYFUNCTYPE(ctypes.c_int32, ctypes.c_void_p, ctypes.c_void_p,
                           ctypes.c_void_p, ctypes.c_void_p)


def function(layout, loop):
    """The native loop for an array layout: loaded from the cache, else compiled."""
    global _FUNCTION, _FUNCTION_LAYOUT
    if _FUNCTION is None or _FUNCTION_LAYOUT != layout:
        with _LOCK:
            if _FUNCTION is None or _FUNCTION_LAYOUT != layout:
                _FUNCTION = _load(layout) or _compile(layout, loop)
                _FUNCTION_LAYOUT = layout
    return _FUNCTION


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


def description_path() -> Path | None:
    """The JSON description of the native loop for this source and CPU, which names its
    object file (None: no writable cache folder)."""
    folder = jitcache.cache_dir()
    if folder is None:
        return None
    return folder / f"march-{_cpu_key(_llvm())}.json"


def is_compiled() -> bool:
    """Whether the native loop of this source and CPU is in the cache."""
    path = description_path()
    return path is not None and path.is_file()


def _load(layout):
    meta_path = description_path()
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
        ll = _llvm()
        engine = ll.create_mcjit_compiler(
            ll.parse_assembly(""), ll.Target.from_default_triple().create_target_machine())
        engine.add_object_file(ll.ObjectFileRef.from_data(data))
        engine.finalize_object()
        address = engine.get_function_address(meta["symbol"])
        if not address:
            raise ValueError(f"it has no symbol {meta['symbol']!r}")
    except Exception as exc:  # anything unusable is compiled anew
        sys.stderr.write(f"urmx: the cached kernel {obj} is unusable ({exc}); "
                         "compiling it again\n")
        return None
    _KEEP.append(engine)
    return _PROTO(address)


def _compile(layout, loop):
    meta_path = description_path()
    where = meta_path.parent if meta_path else "nowhere: no writable cache folder"
    sys.stderr.write(f"urmx: compiling the kernel (once per install; cached in {where}) "
                     "...\n")
    sys.stderr.flush()
    started = time.perf_counter()
    jitcache.materialize()
    from numba import types

    dispatcher = getattr(loop, "dispatcher", None) or loop  # a jitcache.Lazy, or numba's
    sig = (types.CPointer(types.int64), types.CPointer(types.float64))
    dispatcher.compile(sig)
    cres = dispatcher.overloads[sig]
    symbol = cres.fndesc.mangled_name
    address = cres.library.get_pointer_to_function(symbol)
    _KEEP.append(cres.library)
    if meta_path is not None:
        try:
            _store(cres.library, symbol, layout, meta_path)
        except Exception as exc:  # the kernel runs; the next process compiles again
            sys.stderr.write(f"urmx: could not store the compiled kernel ({exc}); each "
                             "new process will compile it\n")
    sys.stderr.write(f"urmx: kernel compiled in {time.perf_counter() - started:.1f} s\n")
    return _PROTO(address)


def _object_code(library) -> bytes:
    """The machine code MCJIT made of a finalized numba library (numba keeps it for its own
    cache); emitted again if this numba does not keep it."""
    try:
        return library._get_compiled_object()
    except Exception:
        return library._codegen._tm.emit_object(library._final_module)


def _store(library, symbol: str, layout, meta: Path) -> None:
    """Write the object under a name of its checksum, then the description that names it
    (each by an atomic rename): a reader sees a whole pair or none."""
    data = _object_code(library)
    digest = hashlib.sha256(data).hexdigest()
    obj = meta.with_name(f"{meta.stem}-{digest[:16]}.o")
    tag = f".tmp-{os.getpid()}-{threading.get_ident()}"
    description = {"object": obj.name, "symbol": symbol, "sha256": digest,
                   "layout": [list(x) for x in layout], "source": jitcache.SOURCE_HASH}
    for path, content in ((obj, data), (meta, json.dumps(description).encode())):
        tmp = path.with_name(path.name + tag)
        tmp.write_bytes(content)
        os.replace(tmp, path)
