"""Settings: where the record files live, and where urmx's own data (the catalog and the
record manifest) and a source checkout are.

urmx's data (``catalog/`` and ``records/manifest.toml``) has one source, the top-level
folders of the source checkout; a built wheel carries a copy of them as package data
(``urmx/_data/``, copied there at build time by ``setup.py``), read with
`importlib.resources`. :func:`data_dir` gives the checkout's folder when urmx runs from a
checkout (an editable install), else the packaged copy. Outputs never go into the package:
reports and archives default to the current folder.

The records directory is, in order: the ``records_dir`` argument, the ``URMX_RECORDS``
environment variable, ``records_dir`` in ``urmx.toml`` in the current directory (a
``urmx.toml`` that is not valid TOML, or whose records_dir is not a path, is an
:class:`urmx.errors.InputError` naming it), or else the records urmx ships
(:func:`shipped_records`: the checkout's ``records/`` folder, or the copy a wheel carries).
A folder the user names wins over the shipped one for the manifest records it holds
(`urmx.records.manifest`); the others still come from the shipped folder.
"""

from __future__ import annotations

import os
import sys
from importlib import resources
from pathlib import Path

from .errors import InputError, MissingFileError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ENV = "URMX_RECORDS"


class UrmxWarning(UserWarning):
    """Warnings urmx itself raises (e.g. an unevenly sampled record was resampled)."""


#: where a wheel carries urmx's data (``setup.py`` copies ``catalog/`` and
#: ``records/manifest.toml`` there at build time)
PACKAGED = "_data"


def project_root() -> Path:
    """The folder above the package: the source checkout (holding catalog/, records/,
    reports/) when urmx runs from one, else the folder it is installed in
    (site-packages); see :func:`checkout`."""
    return Path(__file__).resolve().parent.parent


def checkout() -> Path | None:
    """The source checkout urmx runs from (an editable install or ``PYTHONPATH``), or None
    for an installed wheel: the folder above the package when it holds ``pyproject.toml``
    and ``catalog/``."""
    root = project_root()
    return root if (root / "pyproject.toml").is_file() and (root / "catalog").is_dir() else None


def need_checkout(what: str) -> Path:
    """The source checkout, or a one-line `MissingFileError` saying that `what` needs one."""
    root = checkout()
    if root is None:
        raise MissingFileError(f"{what} needs a source checkout of urmx (this urmx is "
                               f"installed in {project_root()}); run it from a clone of the "
                               "repository with `pip install -e .`")
    return root


def data_dir(name: str = "catalog") -> Path:
    """urmx's data folder `name`: ``"catalog"`` (the default: walls, diaphragms, building,
    examples, studies, hazard) or ``"records"`` (the record manifest), as
    ``data_dir("catalog")``; the checkout's top-level folder when urmx runs from a
    checkout, else the copy a wheel carries as package data (``urmx/_data/<name>``, found
    with `importlib.resources`)."""
    root = checkout()
    if root is not None:
        return root / name
    packaged = resources.files("urmx").joinpath(PACKAGED, name)
    # a wheel installs as files, so the resource is a path; a zipped urmx is not supported
    return packaged if isinstance(packaged, Path) else Path(str(packaged))


def shipped_records() -> Path:
    """The records urmx ships (``records/``: the files of the manifest's paper,
    verification and FEMA P695 records, with ``manifest.toml`` and ``PROVENANCE.md``), as an
    absolute path: the checkout's folder, or the copy a wheel carries."""
    return data_dir("records").absolute()


def _config_records_dir(cfg: Path) -> Path | None:
    """``records_dir`` of a ``urmx.toml`` (resolved against its folder), or None; a file
    that is not TOML, or a records_dir that is not a folder path, is an InputError naming
    the file."""
    try:
        data = tomllib.loads(cfg.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{cfg}: cannot be read as a TOML file "
                         f"({getattr(exc, 'strerror', None) or exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{cfg}: not valid TOML: {exc}") from None
    if "records_dir" not in data:
        close = [k for k in data if "record" in k.lower()]
        if close:
            raise InputError(f"{cfg} has no records_dir (it has {', '.join(map(repr, close))}: "
                             "a misspelling?)")
        return None

    value = data["records_dir"]
    if not isinstance(value, str) or not value.strip():
        raise InputError(f"{cfg}: records_dir = {value!r} must be a folder path in quotes, "
                         'e.g. records_dir = "my/records"')
    path = Path(value).expanduser()
    return path if path.is_absolute() else cfg.parent / path


def records_dir(records_dir: str | os.PathLike | None = None) -> Path:
    """The folder the record manifest is resolved against, as an absolute path: the one
    the user names (argument, ``$URMX_RECORDS``, ``urmx.toml``), else the shipped records
    (:func:`shipped_records`); a clear error if a named folder is missing (or if
    ``urmx.toml`` is not valid)."""
    source = "argument"
    value = records_dir
    if value is None and os.environ.get(ENV):
        value, source = os.environ[ENV], f"${ENV}"
    if value is None:
        cfg = Path.cwd() / "urmx.toml"
        if cfg.exists():
            value = _config_records_dir(cfg)
            source = str(cfg)
    if value is None:
        return shipped_records()
    path = Path(value).expanduser()
    if not path.is_dir():
        raise MissingFileError(f"records directory {str(path)!r} (from {source}) does not exist")
    # absolute: a relative $URMX_RECORDS means this process's working folder, also for a
    # worker or notebook kernel that runs elsewhere
    return path.absolute()
