"""Which code made a result: the urmx version and git commit, the kernel source hash and the
versions of the libraries a study's numbers rest on, for archives and for checking that
every worker of a cluster runs the same code.

:func:`code_version` is the version an archive records (``urmx_version``): the package
version, with a local label naming the git commit (``0.1.0+g7ab99c0``, ``.dirty`` when
the package's files differ from it) when urmx runs from a git checkout. :func:`attrs` are
an archive's provenance attributes (:data:`ATTRS` names them). :func:`identity` is what a
worker reports of itself, and :func:`differs` says whether a worker's results can be mixed
with this process's (same urmx version, same sources of the whole package, :func:`source_hash`,
so an older urmx of the same version is caught too, same kernel sources, same numpy).

Only the standard library is imported here (versions are read from the installed
packages' metadata), so a worker that runs a batch can report its identity cheaply.
"""

from __future__ import annotations

import functools
import hashlib
import subprocess
import sys
from importlib import metadata
from pathlib import Path
from typing import Any

from . import jitcache

#: libraries whose versions an archive records, as their distributions are named
PACKAGES = ("numba", "numpy", "scipy", "xarray", "dask", "distributed", "netCDF4", "obspy")
#: the entries of :func:`identity` that must be equal for results to be mixed
COMPARED = ("urmx", "sources", "kernel_source", "numpy")
#: the global attributes :func:`attrs` gives an archive
ATTRS = ("urmx_version", "urmx_git_commit", "urmx_git_dirty", "kernel_source_hash",
         "python_version", *(f"{p.lower()}_version" for p in PACKAGES))

ROOT = Path(__file__).resolve().parent.parent  # the checkout, when urmx runs from one


def package_version(name: str) -> str:
    """The installed version of distribution `name` ("not installed" when absent)."""
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return "not installed"


def _git(*args: str) -> str | None:
    try:
        done = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True,
                              text=True, timeout=10, check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


@functools.lru_cache(maxsize=1)
def git_commit() -> tuple[str, bool] | None:
    """(commit, dirty) of the git checkout urmx is imported from, or None when it is not
    (an installed wheel, no git). ``dirty``: the package's files (``urmx/``,
    ``pyproject.toml``) differ from the commit, or it has files the commit lacks."""
    if not (ROOT / ".git").exists() or not (ROOT / "urmx" / "provenance.py").is_file():
        return None
    top = _git("rev-parse", "--show-toplevel")
    if top is None or Path(top).resolve() != ROOT:
        return None
    commit = _git("rev-parse", "HEAD")
    if not commit:
        return None
    status = _git("status", "--porcelain", "--untracked-files=normal", "--", "urmx",
                  "pyproject.toml")
    return commit, bool(status)


def code_version() -> str:
    """The urmx version with the git commit as a local label when run from a checkout
    (``0.1.0+g7ab99c0``, ``0.1.0+g7ab99c0.dirty``), else the package version."""
    from . import __version__

    git = git_commit()
    if git is None:
        return __version__
    commit, dirty = git
    sep = "." if "+" in __version__ else "+"
    return f"{__version__}{sep}g{commit[:7]}" + (".dirty" if dirty else "")


@functools.lru_cache(maxsize=1)
def source_hash() -> str:
    """16 hex digits of the SHA-256 of urmx's own files (each ``.py`` and ``.toml`` of the
    package, with its path in it): two processes with the same hash run the same code,
    whatever their version says (an older checkout of the same version has another)."""
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for path in sorted(root.rglob("*")):
        if path.suffix in (".py", ".toml") and "__pycache__" not in path.parts:
            h.update(path.relative_to(root).as_posix().encode() + b"\0")
            h.update(path.read_bytes() + b"\0")
    return h.hexdigest()[:16]


@functools.lru_cache(maxsize=1)
def identity() -> dict[str, str]:
    """What this process runs: the urmx version, :func:`source_hash`,
    `urmx.jitcache.SOURCE_HASH`, and the numba, numpy and Python versions (a worker reports
    it with every batch)."""
    from . import __version__, jitcache

    return {"urmx": __version__, "sources": source_hash(),
            "kernel_source": jitcache.SOURCE_HASH,
            "numpy": package_version("numpy"), "numba": package_version("numba"),
            "python": sys.version.split()[0]}


def differs(theirs: dict[str, Any], ours: dict[str, Any] | None = None) -> bool:
    """Whether results computed under identity `theirs` must not be mixed with ours."""
    ours = identity() if ours is None else ours
    return any(str(theirs.get(k)) != str(ours.get(k)) for k in COMPARED)


def describe(ident: dict[str, Any]) -> str:
    """An identity in a few words: ``urmx 0.1.0 (sources 0a1b2c3d4e5f6a7b), kernel
    1a2b3c4d5e6f7a8b, numpy 2.4.6``; an urmx that reports no source hash is older."""
    sources = ident.get("sources")
    said = f"sources {sources}" if sources else "an older urmx: no source hash"
    return (f"urmx {ident.get('urmx', '?')} ({said}), kernel "
            f"{ident.get('kernel_source', '?')}, numpy {ident.get('numpy', '?')}")


def attrs() -> dict[str, Any]:
    """An archive's provenance attributes (:data:`ATTRS`): the code version, the git
    commit and whether the package's files differed from it (1/0; ``"none"`` and -1 when
    not run from a git checkout), the kernel source hash, the Python and library
    versions."""
    git = git_commit()
    out: dict[str, Any] = {
        "urmx_version": code_version(),
        "urmx_git_commit": git[0] if git else "none",
        "urmx_git_dirty": int(git[1]) if git else -1,
        "kernel_source_hash": jitcache.SOURCE_HASH,
        "python_version": sys.version.split()[0],
    }
    for name in PACKAGES:
        out[f"{name.lower()}_version"] = package_version(name)
    return out
