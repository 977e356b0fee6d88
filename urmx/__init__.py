"""urmx: out-of-plane rocking of cracked URM walls between flexible timber diaphragms.

Public API (heavy modules are imported on first use)::

    from urmx import Wall, simulate, run_study, open_study

Every error urmx raises for bad input or a run it cannot accept is a `urmx.UrmxError`
(module `urmx.errors`), with a one-line message naming the bad value.
"""

from importlib.metadata import PackageNotFoundError, version

from .config import UrmxWarning
from .errors import UrmxError
from .model import Wall

try:
    __version__ = version("urmx")
except PackageNotFoundError:  # pragma: no cover - running from a bare source tree
    __version__ = "0.0.0+unknown"

__all__ = ["Wall", "simulate", "run_study", "open_study", "UrmxWarning", "UrmxError",
           "__version__"]

_LAZY = {
    "simulate": ("urmx.simulation", "simulate"),
    "run_study": ("urmx.study", "run_study"),
    "open_study": ("urmx.study", "open_study"),
}


_SUBMODULES = ("analysis", "catalog", "errors", "fragility", "fragility_analysis",
               "fragility_report", "generic_report", "guard", "kernel", "markdown", "model",
               "netcdf", "paper", "plot", "records", "reference", "report", "reporting",
               "simulation", "study", "variables")


def __getattr__(name):
    import importlib

    if name in _LAZY:
        module, attr = _LAZY[name]
        return getattr(importlib.import_module(module), attr)
    if name in _SUBMODULES:
        return importlib.import_module(f"urmx.{name}")
    raise AttributeError(f"module 'urmx' has no attribute {name!r}")
