"""The package's architecture, measured on its source: no import cycle (function-level
imports included), a kind-blind engine and catalog, a fragility package free of studies,
dask and xarray, a variable registry that imports nothing of urmx, and no long function in
the modules of the study engine, the fragility and the reports."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import urmx

PACKAGE = Path(urmx.__file__).parent


def _modules(package: Path) -> dict[str, Path]:
    """Dotted module name -> file, for every module of `package`."""
    root = package.parent
    out = {}
    for path in package.rglob("*.py"):
        parts = list(path.relative_to(root).with_suffix("").parts)
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def _type_checking(node: ast.AST) -> bool:
    return isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)


def imports(path: Path, name: str) -> set[str]:
    """Every module `path` (module `name`) imports, at any level (functions included; not
    under ``if TYPE_CHECKING:``, which never runs): absolute dotted names, a ``from x import
    y`` giving ``x.y`` when that is a module of the package, else ``x``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    skip = {id(n) for node in ast.walk(tree) if _type_checking(node)
            for n in ast.walk(node)}
    found = set()
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module
            found.add(source)
            found |= {f"{source}.{a.name}" for a in node.names}
    return found


def import_graph(package: Path) -> dict[str, set[str]]:
    """Module -> the package's modules it imports. Importing ``a.b.c`` runs the packages
    ``a`` and ``a.b`` first, so those are edges too, except packages that hold the importer
    itself (already running when it runs). Attribute loading by name (``importlib``, the
    lazy public names of ``urmx`` and ``urmx.study``) is not an import: it runs only when
    the name is first used, never while the modules load."""
    modules = _modules(package)
    graph = {}
    for name, path in modules.items():
        own = {".".join(name.split(".")[:i]) for i in range(1, name.count(".") + 1)}
        edges = set()
        for target in imports(path, name) & set(modules):
            parts = target.split(".")
            edges |= {".".join(parts[:i]) for i in range(1, len(parts) + 1)} - own - {name}
        graph[name] = edges
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import cycles of `graph` (strongly connected components of more than one
    module, or a module importing itself), each as a sorted list."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    out = []

    def visit(v: str) -> None:  # Tarjan's algorithm
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                component.append(w)
                if w == v:
                    break
            if len(component) > 1 or v in graph.get(v, ()):
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_package_has_no_import_cycle():
    graph = import_graph(PACKAGE)
    assert len(graph) > 50 and "urmx.study.kinds.ida" in graph["urmx.study.kinds"]
    assert "urmx.fragility" in graph["urmx.study.kinds.ida"]  # the kind imports fragility
    assert cycles(graph) == []


def test_the_cycle_check_fails_on_a_cycle(tmp_path):
    """A cycle through a function-level import, and one through a parent package that
    imports the module importing its sibling, are both found."""
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from . import b\n")
    (pkg / "b.py").write_text("def f():\n    from .a import g\n")
    (pkg / "sub" / "__init__.py").write_text("from . import engine\n")
    (pkg / "sub" / "engine.py").write_text("import pkg.c\n")
    (pkg / "sub" / "kinds.py").write_text("")
    (pkg / "c.py").write_text("def f():\n    from .sub import kinds\n")
    (pkg / "d.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                              "    from . import e\n")
    (pkg / "e.py").write_text("from . import d\n")
    assert cycles(import_graph(pkg)) == [["pkg.a", "pkg.b"],
                                         ["pkg.c", "pkg.sub", "pkg.sub.engine"]]


WORDS = re.compile(r"\b(ida|fragility|capacity|capacities)\b", re.I)


def test_the_engine_and_the_catalog_know_no_study_kind_by_name():
    files = [p for p in (PACKAGE / "study").rglob("*.py") if "kinds" not in p.parts]
    files.append(PACKAGE / "catalog.py")
    assert len(files) > 8
    found = [f"{p.relative_to(PACKAGE)}:{i}: {line.strip()}" for p in files
             for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
             if WORDS.search(line)]
    assert found == []
    assert WORDS.search("an [study.ida] table") and not WORDS.search("validated")


def _external(prefixes: tuple[str, ...], path: Path, name: str) -> set[str]:
    return {m for m in imports(path, name) if m.split(".")[0] in prefixes
            or any(m.startswith(p + ".") or m == p for p in prefixes if "." in p)}


def test_fragility_imports_no_study_dask_or_xarray():
    modules = {n: p for n, p in _modules(PACKAGE).items()
               if n == "urmx.fragility" or n.startswith("urmx.fragility.")}
    assert len(modules) >= 5
    banned = ("urmx.study", "dask", "distributed", "xarray")
    found = {n: _external(banned, p, n) for n, p in modules.items()}
    assert {n: m for n, m in found.items() if m} == {}
    # the check sees function-level imports (the study's engine imports dask inside one)
    engine = PACKAGE / "study" / "engine.py"
    assert _external(banned, engine, "urmx.study.engine") >= {"distributed"}


def test_the_variable_registry_imports_no_urmx_module():
    found = imports(PACKAGE / "variables.py", "urmx.variables")
    assert {m for m in found if m.split(".")[0] == "urmx"} == set()
    assert "tomllib" in found or "tomli" in found


# The measured modules: the study engine and its kinds, the fragility, the catalog, the
# paper's layer and both reports. The compiled kernel (urmx.kernel) is not among them:
# kernel._march (the event loop) and kernel.Tables (its arrays) are exempt, since numba
# compiles _march as one native function whose hot paths are inlined by hand and split
# into calls would cost a call per event, and Tables declares the arrays that native call
# is compiled for, one line each.
MEASURED = ("study", "fragility", "catalog.py", "paper", "reports")
LONGEST = 80


def long_functions(paths: list[Path], limit: int = LONGEST) -> list[str]:
    """``file:function (lines)`` of every function or method longer than `limit` lines."""
    out = []
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > limit:
                    out.append(f"{path.name}:{node.name} ({n})")
    return out


def test_no_function_longer_than_80_lines():
    paths = []
    for item in MEASURED:
        target = PACKAGE / item
        paths += sorted(target.rglob("*.py")) if target.is_dir() else [target]
    assert len(paths) >= 20
    assert long_functions(paths) == []


def test_the_length_check_fails_on_a_long_function(tmp_path):
    path = tmp_path / "long.py"
    path.write_text("def short():\n    pass\n\n\ndef long():\n" + "    x = 1\n" * 80)
    assert long_functions([path]) == ["long.py:long (81)"]


def test_every_module_says_its_job_first():
    """Each module's docstring opens with a sentence (its job)."""
    missing = []
    for name, path in _modules(PACKAGE).items():
        doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")))
        if not doc or not re.match(r"^[`A-Z\w(].*", doc) or "." not in doc:
            missing.append(name)
    assert missing == []


def test_the_engine_imports_no_kernel_and_the_kernel_keeps_the_status_codes():
    """The study's modules outside its kinds never import the kernel (a kind brings its
    warm-up and its integrator's record time-step floor); the status vocabulary is the
    study's (`urmx.study.dataset.STATUS`) and the kernel's codes are its first three."""
    from urmx import kernel
    from urmx.study import dataset, kinds

    graph = import_graph(PACKAGE)
    engine = [n for n in graph if n.startswith("urmx.study") and ".kinds" not in n]
    assert len(engine) > 10 and "urmx.study.engine" in engine
    assert {n: sorted(graph[n] & {"urmx.kernel"}) for n in engine
            if "urmx.kernel" in graph[n]} == {}
    assert "urmx.kernel" in graph["urmx.study.kinds.grid"]  # the check sees the kinds' import
    codes = {"ok": kernel.ST_OK, "collapsed": kernel.ST_COLLAPSED,
             "event-limit": kernel.ST_EVENT_LIMIT}
    assert {name: dataset.STATUS.index(name) for name in codes} == codes
    assert kernel.STATUS == dataset.STATUS[:3] and dataset.STATUS[dataset.NOT_RUN] == "not-run"
    assert kernel.ST_NEED_PIECE not in codes.values() and kernel.ST_NEED_PIECE == 3  # internal
    for kind in kinds.BUILT_IN:
        assert kind.warm_up is kernel.warm_up and kind.dt_above == kernel.WINDOW
