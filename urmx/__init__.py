"""urmx: out-of-plane rocking of cracked URM walls between flexible timber diaphragms.

Public API (heavy modules are imported on first use)::

    from urmx import Wall, simulate, run_study, open_study

Every error urmx raises for bad input or a run it cannot accept is a `urmx.UrmxError`
(module `urmx.errors`), with a one-line message naming the bad value.
"""

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys

from .config import UrmxWarning
from .errors import UrmxError
from .model import Wall
from .provenance import VERSION as __version__

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


#: names that left a module for another, kept there for one release: ``from urmx.catalog
#: import load_study`` (the study file's parser, now `urmx.study.file`), ``from urmx.assess
#: import compare`` (a comparison over an IDA archive, now `urmx.analysis.assessment`)
MOVED_NAMES = {
    "urmx.catalog": ("urmx.study.file", ("load_study", "load_study_text", "Study", "study_path",
                                         "file_keys", "STUDY_FILE_KEYS", "STUDY_KEYS",
                                         "History", "OwnRecord")),
    "urmx.assess": ("urmx.analysis.assessment", ("compare",)),
}


def _serve_moved_names(module) -> None:
    """Give `module` a module ``__getattr__`` serving its :data:`MOVED_NAMES` from where
    they went (loaded on first use)."""
    where, names = MOVED_NAMES[module.__name__]

    def __getattr__(name):
        if name in names:
            return getattr(importlib.import_module(where), name)
        raise AttributeError(f"module {module.__name__!r} has no attribute {name!r}")

    module.__getattr__ = __getattr__


class _Moved(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds the old names of :data:`MOVED`: the module object is the new module's own (one
    module, whichever name imported it), its ``__spec__`` left the new one's; and loads the
    modules of :data:`MOVED_NAMES` as usual, then serves their moved names."""

    def find_spec(self, name, path=None, target=None):
        if name in MOVED_NAMES:
            spec = importlib.machinery.PathFinder.find_spec(name, path)
            if spec is not None:
                spec.loader = _ServingMovedNames(spec.loader)
            return spec
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


class _ServingMovedNames(importlib.abc.Loader):
    """A module's own loader, which then gives it its moved names (`_serve_moved_names`)."""

    def __init__(self, loader):
        self.loader = loader

    def __getattr__(self, attr):  # get_source, get_filename ... as the module's own loader
        return getattr(self.loader, attr)

    def create_module(self, spec):
        return self.loader.create_module(spec)

    def exec_module(self, module):
        self.loader.exec_module(module)
        _serve_moved_names(module)


if not any(isinstance(f, _Moved) for f in sys.meta_path):
    sys.meta_path.insert(0, _Moved())
for _name in MOVED_NAMES:
    if _name in sys.modules:  # loaded before the finder was in place
        _serve_moved_names(sys.modules[_name])


def __getattr__(name):
    if name in _LAZY:
        module, attr = _LAZY[name]
        return getattr(importlib.import_module(module), attr)
    if name in _SUBMODULES or f"urmx.{name}" in MOVED:
        return importlib.import_module(f"urmx.{name}")
    raise AttributeError(f"module 'urmx' has no attribute {name!r}")
