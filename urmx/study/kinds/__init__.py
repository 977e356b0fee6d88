"""Study kinds: what a study computes, as plug-ins of the kind-blind engine; this module is
the one place kinds are registered (:data:`BUILT_IN` and :func:`register`).

The kind protocol
-----------------
A kind is a `Kind` (`urmx.study.kinds.kind`): a frozen record of a few names and
functions. The engine (`urmx.study.engine`) runs any registered kind the same way and never
asks which one it is: it parses nothing, cuts nothing and assembles nothing itself.

``name`` : str
    Registry name (``"grid"``, ``"ida"``), stored as ``Study.kind``; part of every cell's
    identity and of its batches' keys (``<name>-<hash>``).
``table`` : str or None
    The ``[study.<table>]`` table that makes a study this kind (None: the default kind, a
    study without any kind table). The catalog keeps every registered kind's table as data
    (``Study.tables``) and refuses any other ``[study.<name>]`` with file, key and line.
``keys`` : tuple of str
    The keys its ``[study.<table>]`` accepts (its ``parse`` refuses any other);
    `urmx.study.file.file_keys` lists them with every other study-file key, and
    ``docs/study-files.md`` must describe them (``tests/test_study_file.py``).
``combines`` : tuple of str
    Other kinds' tables this kind reads as well (a study with several kind tables is the
    kind that combines all the others; :func:`select`).
``unit`` : str
    What progress counts: one cell of the kind (``"analyses"``, ``"cells"``).
``outputs`` : tuple of str
    The per-cell arrays every batch result holds (a saved part lacking one is computed
    again). Each has the shape of the batch's block (``batch.shape``: one axis per cell
    dimension, in order), then any per-cell axes of its own (an IDA curve's points; shorter
    ones are padded with the fill).
``parse(study) -> settings``
    Validates the kind's table(s) and the study's grid for this kind (raising
    ``study.error(key, message, *needles)``, a `urmx.catalog.CatalogError` naming file,
    key and line) and returns its settings, stored as ``Study.settings``. Called by
    `urmx.study.file.load_study`, so a bad table fails before any work. The settings are part
    of every cell's identity (a dataclass by its fields).
``dims(study) -> dict``
    The kind's cell dimensions and their values, in archive order (default
    ``study.dims``: wall, diaphragm, record, cor and the study's added dimensions); they
    must include ``wall`` and ``record``. A cell is one point of this grid. The engine cuts
    the cells over every dimension into blocks of about ``batch_size`` cells, one record
    each (`urmx.study.batches.Cut`), keys each cell (`urmx.study.cells`) and finds finished
    cells by key; a kind cuts and keys nothing itself.
``task(study, records, batch, kernel) -> dict``
    The task of one block (``batch.block``: the indices of each dimension it covers): plain
    values, picklable, no xarray.
``run(task, acceleration) -> dict of ndarray``
    Runs one block on a worker: numpy only (it must import neither xarray nor dask nor
    ObsPy: a test runs each kind's batch in a fresh process and looks). `acceleration`
    is the record's samples, unscaled; the task carries its scale factor. Returns every
    name of ``outputs`` (block-shaped, above) and, for the cells ``extras`` names, extra
    arrays ``extra.<i>.<name>`` (``i`` the cell's flat C-order index in the block).
``assemble(study, records, cells, extras, attrs) -> xarray.Dataset``
    Builds the Dataset from ``cells`` (each output over the whole grid, then its per-cell
    axes; the fill of ``fills`` where no cell ran: numpy arrays, or dask arrays gathered
    from the parts when the run writes an archive, so keep to numpy functions that dask
    follows, or call ``np.asarray`` when the kind's cells are few) and ``extras`` (the extra
    arrays by the label ``extras`` gave); ``attrs`` are the engine's global attributes.
    `urmx.study.dataset` gives the shared coordinates. The engine adds ``cell_key`` to an
    archive.
``reopen(ds) -> Dataset or None``
    For `urmx.open_study`: masks an archive of an older urmx of this kind (None when the
    archive is not this kind's or needs nothing); optional.
``counts(ds) -> dict or None``
    For `urmx.study.info` (``urmx info``): how many cells of an archive end in each way
    (``{"ok": 40, "collapsed": 23, ...}``, the cells partitioned, missing ones included),
    or None when `ds` is not this kind's archive; optional.

Optional, with defaults:

``identity(study, records) -> {dim: [value, ...]}``
    What each value of a dimension means for a result, where its value alone does not say
    (plain JSON values, one per index), for the kind's own dimensions (default: the value;
    wall, diaphragm and record have the engine's, `urmx.study.cells.dimension_identity`).
``extras(study) -> {cell index: label}``
    Cells whose run also returns extra arrays (a grid's kept time histories); they are
    keyed apart and never taken from an archive, only from parts.
``fills`` : dict
    Output -> (value, dtype) where no cell ran (default NaN, float64).
``archived`` : dict
    Output -> the archive variable holding it, for cells taken over from an earlier
    archive (default: the same name); variables over fewer dimensions are broadcast.
``cell_bytes(study) -> float``
    Bytes of one cell's outputs in the archive, for the size check before a run (default
    8 per output).
``prepare(study, records) -> object``
    What ``assemble`` needs of the study and its records alone (not of the cells): computed
    in a thread of this process while the cells run, and passed to ``assemble`` as
    ``prepared=`` (the IDA kind's record measures: about a second of spectra that the end
    of a run no longer waits for). Default: none.
``chain``, ``chain_tag``, ``chained``
    A dimension along which each cell starts from the result of the cell before it (the
    IDA kinds' ``wall``: warm-started searches), what that means (folded into the cells'
    keys, `urmx.study.cells`) and the outputs the next cell needs; the cut never splits a
    chain and a block's finished predecessors travel with it as ``Batch.before``
    (`urmx.study.batches`). Default: none, independent cells.

A new kind is one module holding its `Kind`, added to :data:`BUILT_IN` here, or registered
from outside with ``urmx.study.kinds.register(kind)`` (a test's toy kind does so).
"""

from __future__ import annotations

from typing import Any

from .kind import Kind

_KINDS: dict[str, Kind] = {}


def register(kind: Kind) -> Kind:
    """Add a kind to the registry (replacing one of the same name); returns it."""
    if not isinstance(kind, Kind):
        raise TypeError(f"a study kind must be a urmx.study.kinds.Kind, not "
                        f"{type(kind).__name__}")
    _KINDS[kind.name] = kind
    return kind


def unregister(name: str) -> Kind:
    """Take kind `name` out of the registry (a test's kind, after the test); returns it."""
    return _KINDS.pop(name)


def get(name: str) -> Kind:
    """The registered kind `name`."""
    try:
        return _KINDS[name]
    except KeyError:
        raise KeyError(f"no study kind {name!r} (registered: {', '.join(_KINDS)})") from None


def registered() -> tuple[Kind, ...]:
    """Every registered kind, the built-in ones first."""
    return tuple(_KINDS.values())


def tables() -> tuple[str, ...]:
    """The ``[study.<name>]`` tables of the registered kinds."""
    return tuple(k.table for k in _KINDS.values() if k.table)


def fitting(present: set[str]) -> list[Kind]:
    """The kinds of a study with the kind tables `present`: those whose table it has and
    that combine every other table it has; of several, those that read exactly these
    tables (``[study.sampling]`` alone makes the kind ``sampling``, with ``[study.ida]``
    beside it ``sampling-ida``)."""
    found = [k for k in _KINDS.values()
             if k.table in present and present <= {k.table, *k.combines}]
    return [k for k in found if present == {k.table, *k.combines}] or found


def select(study: Any) -> Kind:
    """The kind of a study: the default kind (no table) when the study has no kind table,
    else the one kind of :func:`fitting`.

    Raises
    ------
    urmx.catalog.CatalogError
        Tables no one kind combines (via ``study.error``).
    """
    present = set(study.tables)
    if not present:
        return next(k for k in _KINDS.values() if k.table is None)
    found = fitting(present)
    if len(found) != 1:
        names = sorted(present)
        raise study.error(f"study.{names[-1]}", f"the tables {', '.join(names)} make no one "
                          "study kind (each kind reads its own table)", names[-1])
    return found[0]


def prepare(study: Any) -> tuple[str, Any]:
    """(kind name, parsed settings) of a study (`select`, then the kind's ``parse``)."""
    kind = select(study)
    return kind.name, kind.parse(study) if kind.parse is not None else None


from . import grid, ida, sampling  # noqa: E402 - the built-in kinds, registered below

#: the kinds urmx comes with; the first needs no table (a study without one is this kind)
BUILT_IN = (grid.KIND, ida.KIND, sampling.KIND, sampling.KIND_IDA)
for _kind in BUILT_IN:
    register(_kind)
