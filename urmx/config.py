"""Settings: where the record files live.

The records directory is, in order: the ``records_dir`` argument, the ``URMX_RECORDS``
environment variable, or ``records_dir`` in ``urmx.toml`` in the current directory.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from .errors import MissingFileError

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


def records_dir(records_dir: str | os.PathLike | None = None) -> Path:
    """The folder the record manifest is resolved against, as an absolute path; a clear
    error if unset or missing."""
    source = "argument"
    value = records_dir
    if value is None and os.environ.get(ENV):
        value, source = os.environ[ENV], f"${ENV}"
    if value is None:
        cfg = Path.cwd() / "urmx.toml"
        if cfg.is_file():
            data = tomllib.loads(cfg.read_text(encoding="utf-8"))
            if "records_dir" in data:
                value, source = data["records_dir"], str(cfg)
                if not Path(value).is_absolute():
                    value = cfg.parent / value
    if value is None:
        raise MissingFileError(
            f"no records directory set: set {ENV}=/path/to/records (for example the "
            "shared/records folder beside this checkout) or pass --records DIR")
    path = Path(value).expanduser()
    if not path.is_dir():
        raise MissingFileError(f"records directory {str(path)!r} (from {source}) does not exist")
    # absolute: a relative $URMX_RECORDS means this process's working folder, also for a
    # worker or notebook kernel that runs elsewhere
    return path.absolute()
