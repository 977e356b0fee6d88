"""Settings: where the record files live.

The records directory is, in order: the ``records_dir`` argument, the ``URMX_RECORDS``
environment variable, or ``records_dir`` in ``urmx.toml`` in the current directory (a
``urmx.toml`` that is not valid TOML, or whose records_dir is not a path, is an
:class:`urmx.errors.InputError` naming it).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from .errors import InputError, MissingFileError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

ENV = "URMX_RECORDS"


class UrmxWarning(UserWarning):
    """Warnings urmx itself raises (e.g. an unevenly sampled record was resampled)."""


def project_root() -> Path:
    """The source checkout (the folder holding catalog/, records/, reports/)."""
    return Path(__file__).resolve().parent.parent


def _config_records_dir(cfg: Path) -> tuple[Path | None, str]:
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
        hint = f" (it has {', '.join(map(repr, close))}: a misspelling?)" if close else ""
        return None, f"; {cfg} has no records_dir{hint}"
    value = data["records_dir"]
    if not isinstance(value, str) or not value.strip():
        raise InputError(f"{cfg}: records_dir = {value!r} must be a folder path in quotes, "
                         'e.g. records_dir = "../shared/records"')
    path = Path(value).expanduser()
    return (path if path.is_absolute() else cfg.parent / path), ""


def records_dir(records_dir: str | os.PathLike | None = None) -> Path:
    """The folder the record manifest is resolved against, as an absolute path; a clear
    error if unset or missing (or if ``urmx.toml`` is not valid)."""
    source = "argument"
    value = records_dir
    note = ""
    if value is None and os.environ.get(ENV):
        value, source = os.environ[ENV], f"${ENV}"
    if value is None:
        cfg = Path.cwd() / "urmx.toml"
        if cfg.exists():
            value, note = _config_records_dir(cfg)
            source = str(cfg)
    if value is None:
        raise MissingFileError(
            f"no records directory set: set {ENV}=/path/to/records (for example the "
            f"shared/records folder beside this checkout) or pass --records DIR{note}")
    path = Path(value).expanduser()
    if not path.is_dir():
        raise MissingFileError(f"records directory {str(path)!r} (from {source}) does not exist")
    # absolute: a relative $URMX_RECORDS means this process's working folder, also for a
    # worker or notebook kernel that runs elsewhere
    return path.absolute()
