"""Which code made a result: the urmx version and git commit, the kernel source hash and the
versions of the libraries a study's numbers rest on, for archives and for checking that
every worker of a cluster runs the same code.

:func:`code_version` is the version an archive records (``urmx_version``) and ``urmx
--version`` prints: in a git checkout, the release of the nearest tag ``vX.Y.Z``
(:func:`git_release`, read from git when asked, so an editable install does not keep the
version it was installed with) with a local label naming the commit (``0.2.0+g7ab99c0``,
``0.2.0.post3+g7ab99c0``, ``.dirty`` when the package's files differ from it); elsewhere
the installed version, which setuptools-scm took from the tag when the package was built
(its ``fallback_version`` when built outside git). :func:`attrs` are
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
import re
import subprocess
import sys
from importlib import metadata
from pathlib import Path
from typing import Any

from . import jitcache

try:
    #: the installed version of urmx (``importlib.metadata``; ``0.0.0+unknown`` when urmx
    #: runs from a source tree that was never installed): the root's ``urmx.__version__``
    VERSION = metadata.version("urmx")
except metadata.PackageNotFoundError:  # pragma: no cover - running from a bare source tree
    VERSION = "0.0.0+unknown"

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


#: a release tag and what ``git describe --long`` says of it: v0.2.0-3-g1a2b3c4
_DESCRIBE = re.compile(r"v(\d+(?:\.\d+)*)-(\d+)-g[0-9a-f]+")


@functools.lru_cache(maxsize=1)
def git_release() -> str | None:
    """The release of the checkout's nearest tag ``vX.Y.Z`` at or before HEAD, named as
    setuptools-scm's ``post-release`` scheme names it (``pyproject.toml``): ``0.2.0`` at
    the tagged commit, ``0.2.0.post3`` three commits after it; None outside a checkout or
    without such a tag."""
    if git_commit() is None:
        return None
    found = _DESCRIBE.fullmatch(_git("describe", "--tags", "--long", "--match", "v[0-9]*")
                                or "")
    if found is None:
        return None
    release, distance = found.group(1), int(found.group(2))
    return release if distance == 0 else f"{release}.post{distance}"


def release(version: str | None = None) -> str:
    """The release part of a version (``0.2.0`` of ``0.2.0.post3+g7ab99c0``; default the
    installed :data:`VERSION`): what a study's cell keys hold, so cells computed at
    one commit are reused at the next one of the same release (the kernel's own source
    hash is in the keys besides, so a changed kernel never reuses them)."""
    if version is None:
        version = VERSION
    found = re.match(r"\d+(\.\d+)*", version)
    return found.group(0) if found else version


def code_version() -> str:
    """The code that runs: in a git checkout, the release of the nearest tag
    (:func:`git_release`; without a tag, the installed version's public part) with the
    commit as a local label (``0.2.0+g7ab99c0``, ``0.2.0.post3+g7ab99c0.dirty``); else the
    installed version (:data:`VERSION`)."""
    git = git_commit()
    if git is None:
        return VERSION
    commit, dirty = git
    release = git_release() or VERSION.split("+")[0]
    return f"{release}+g{commit[:7]}" + (".dirty" if dirty else "")


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
    return {"urmx": VERSION, "sources": source_hash(),
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
