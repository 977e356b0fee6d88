"""urmx: out-of-plane rocking of cracked URM walls between flexible timber diaphragms.

Public API (heavy modules are imported on first use)::

    from urmx import Wall, simulate, run_study, open_study

Every error urmx raises for bad input or a run it cannot accept is a `urmx.UrmxError`
(module `urmx.errors`), with a one-line message naming the bad value.
"""

import importlib
import importlib.abc
import importlib.util
import sys
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


_SUBMODULES = ("analysis", "catalog", "errors", "fragility", "guard",
               "kernel", "markdown", "model", "netcdf", "paper", "plot", "records",
               "reference", "reports", "simulation", "study", "variables")

#: old module -> the module that replaced it: ``import urmx.fragility_report`` (and ``python
#: -m`` of an old name) gives the new module, for one release (docs/layout.md)
MOVED = {
    "urmx.report": "urmx.reports.paper",
    "urmx.reporting": "urmx.reports.common",
    "urmx.generic_report": "urmx.reports.grid",
    "urmx.fragility_report": "urmx.reports.ida",
    "urmx.risk_report": "urmx.reports.ida_risk",
    "urmx.uncertainty_report": "urmx.reports.sampling",
    "urmx.assessment_report": "urmx.reports.assessment",
    "urmx.predictors_report": "urmx.reports.predictors",
    "urmx.records.report": "urmx.reports.records",
    "urmx.fragility_analysis": "urmx.analysis.ida",
    "urmx.uncertainty_analysis": "urmx.analysis.sampling",
    "urmx.predictors_analysis": "urmx.analysis.predictors",
    "urmx.recompute": "urmx.analysis.recompute",
}


class _Moved(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds the old names of :data:`MOVED`: the module object is the new module's own (one
    module, whichever name imported it), its ``__spec__`` left the new one's."""

    def find_spec(self, name, path=None, target=None):
        return importlib.util.spec_from_loader(name, self) if name in MOVED else None

    def create_module(self, spec):
        module = importlib.import_module(MOVED[spec.name])
        spec.loader_state = module.__spec__  # the import machinery sets ours on it
        return module

    def exec_module(self, module):
        module.__spec__ = module.__spec__.loader_state

    def get_code(self, name):  # ``python -m urmx.<old name>`` runs the new module
        return compile(f"import runpy\nrunpy.run_module({MOVED[name]!r}, run_name='__main__',"
                       " alter_sys=True)\n", f"<{name}: moved to {MOVED[name]}>", "exec")


if not any(isinstance(f, _Moved) for f in sys.meta_path):
    sys.meta_path.insert(0, _Moved())

#: names that left a module for another, kept there for one release: ``from urmx.catalog
#: import load_study`` (the study file's parser, now `urmx.study.file`)
MOVED_NAMES = {
    "urmx.catalog": ("urmx.study.file", ("load_study", "load_study_text", "Study", "study_path",
                                         "file_keys", "STUDY_FILE_KEYS", "STUDY_KEYS",
                                         "History", "OwnRecord")),
}


def _names_moved(module: str) -> None:
    """Give `module` a module ``__getattr__`` that serves its :data:`MOVED_NAMES` from
    where they went (loaded on first use)."""
    where, names = MOVED_NAMES[module]

    def __getattr__(name):
        if name in names:
            return getattr(importlib.import_module(where), name)
        raise AttributeError(f"module {module!r} has no attribute {name!r}")

    sys.modules[module].__getattr__ = __getattr__


from . import catalog  # noqa: E402, F401 - light (config, errors, model); its moved names

_names_moved("urmx.catalog")


def __getattr__(name):
    if name in _LAZY:
        module, attr = _LAZY[name]
        return getattr(importlib.import_module(module), attr)
    if name in _SUBMODULES or f"urmx.{name}" in MOVED:
        return importlib.import_module(f"urmx.{name}")
    raise AttributeError(f"module 'urmx' has no attribute {name!r}")
