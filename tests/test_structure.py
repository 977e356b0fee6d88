"""The package's architecture, measured on its source (one test module for the whole of
`urmx/`): layers in a declared order with no import from a lower layer up to a higher one
and no import cycle, counting function-level imports and lazy loads (``importlib`` and a
module ``__getattr__``); function-level imports of urmx modules only in the command line and
a short named list; no function over 80 lines but the compiled loop; at most 15 modules
directly under ``urmx/``; a kind-blind engine and catalog, a fragility package free of
studies, dask and xarray, a variable registry that imports nothing of urmx; no module
reaching into another's private names; library code leaving the plotting backend alone;
``docs/layout.md`` naming every module and folder. Each check is shown to fail on a small
bad package built in ``tmp_path``."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import urmx
from urmx.config import project_root

PACKAGE = Path(urmx.__file__).parent

#: the layers, highest first; a module belongs to the first layer one of whose names is it
#: or a package holding it (the root package, the public face, is its own top layer). A
#: module may import its own layer and any lower one, never a higher one.
LAYERS = (
    ("face", ("urmx",)),
    ("command line", ("urmx.cli", "urmx.commands")),
    ("reports", ("urmx.reports",)),
    ("figures and the paper", ("urmx.plot", "urmx.paper")),
    ("analysis", ("urmx.analysis",)),
    ("study", ("urmx.study",)),
    ("libraries", ("urmx.fragility", "urmx.uncertainty", "urmx.assess", "urmx.guard")),
    ("kernel, records, catalog, model", ("urmx.kernel", "urmx.native", "urmx.reference",
                                         "urmx.simulation", "urmx.records", "urmx.catalog",
                                         "urmx.model")),
    ("base", ("urmx.errors", "urmx.config", "urmx.variables", "urmx.netcdf", "urmx.markdown",
              "urmx.jitcache", "urmx.provenance")),
)


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


def _parse(path: Path) -> ast.Module:
    return ast.parse(path.read_text(encoding="utf-8"), str(path))


def _import_nodes(tree: ast.Module):
    """Every import statement that runs (not under ``if TYPE_CHECKING:``), with whether it
    sits in a function."""
    skip = {id(n) for node in ast.walk(tree) if _type_checking(node) for n in ast.walk(node)}
    late = {id(n) for f in ast.walk(tree)
            if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef)) for n in ast.walk(f)}
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)) and id(node) not in skip:
            yield node, id(node) in late


def _sources(node: ast.AST, name: str, is_package: bool) -> set[str]:
    """The absolute dotted names one import statement of module `name` loads."""
    if isinstance(node, ast.Import):
        return {a.name for a in node.names}
    package = name if is_package else name.rpartition(".")[0]
    if node.level:
        base = package.split(".")[:len(package.split(".")) - node.level + 1]
        source = ".".join(base + ([node.module] if node.module else []))
    else:
        source = node.module
    return {source} | {f"{source}.{a.name}" for a in node.names}


def loads_by_name(tree: ast.Module, modules: set[str]) -> set[str]:
    """The modules a module loads by name: where it calls ``import_module`` (``importlib``'s,
    by any spelling) or defines a module ``__getattr__``, every string in it naming a module
    of the package counts, and an f-string starting ``pkg.sub.`` counts every module under
    ``pkg.sub``."""
    calls = any(isinstance(n, ast.Call) and ast.unparse(n.func).endswith("import_module")
                for n in ast.walk(tree))
    getattr_ = any(isinstance(n, ast.FunctionDef) and n.name == "__getattr__" for n in tree.body)
    if not (calls or getattr_):
        return set()
    found = set()
    for n in ast.walk(tree):
        if isinstance(n, ast.Constant) and isinstance(n.value, str) and n.value in modules:
            found.add(n.value)
        elif isinstance(n, ast.JoinedStr) and n.values and isinstance(n.values[0], ast.Constant):
            prefix = str(n.values[0].value)
            if prefix.endswith(".") and prefix[:-1] in modules:
                found |= {m for m in modules if m.startswith(prefix)}
    return found


def imports(path: Path, name: str, modules: set[str] | None = None,
            by_name: bool = True) -> set[str]:
    """Every module `path` (module `name`) imports, at any level (functions included; not
    under ``if TYPE_CHECKING:``, which never runs), and the package's modules it loads by
    name (:func:`loads_by_name`): absolute dotted names, a ``from x import y`` giving
    ``x.y`` when that is a module of the package, else ``x``."""
    tree = _parse(path)
    found = set()
    for node, _ in _import_nodes(tree):
        sources = _sources(node, name, path.name == "__init__.py")
        if isinstance(node, ast.ImportFrom) and modules:
            # ``from pkg import a, b`` of modules a and b only: pkg runs on the way (an edge
            # unless it holds the importer, see import_graph); a name it defines is taken
            # from pkg itself
            package = min(sources, key=len)
            if all(f"{package}.{a.name}" in modules for a in node.names):
                sources = sources - {package}
        found |= sources
    return found | (loads_by_name(tree, modules or set()) if by_name else set())


def late_imports(path: Path, name: str, root: str, modules: set[str] | None = None) -> list[str]:
    """``module:line -> source`` of every import of a `root` module inside a function: each
    module of `modules` one statement loads (``from . import a, b`` gives two), else the
    package it imports from."""
    out = []
    for node, late in _import_nodes(_parse(path)):
        sources = sorted(_sources(node, name, path.name == "__init__.py"))
        if not (late and sources[0].split(".")[0] == root):
            continue
        named = [s for s in sources[1:] if s in (modules or set())] or sources[:1]
        out += [f"{name}:{node.lineno} -> {s}" for s in named]
    return out


def import_graph(package: Path) -> dict[str, set[str]]:
    """Module -> the package's modules it imports or loads by name. Importing ``a.b.c`` runs
    the packages ``a`` and ``a.b`` first, so those are edges too, except packages that hold
    the importer itself (already running when it runs). A name taken from the root package
    (``from .. import __version__``), the face and its own top layer, is an edge all the
    same: the root runs its submodules before it defines its names, so a lower module that
    takes one depends on the face above it."""
    modules = _modules(package)
    root = package.name
    graph = {}
    for name, path in modules.items():
        own = {".".join(name.split(".")[:i]) for i in range(1, name.count(".") + 1)}
        explicit = imports(path, name, set(modules), by_name=False)
        edges = {root} if root in explicit and name != root else set()
        for target in imports(path, name, set(modules)) & set(modules):
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


def layer_of(module: str, layers=LAYERS) -> int:
    """The index of `module`'s layer in `layers` (0 the highest): the first layer naming it
    or a package holding it, the root package only by its own name."""
    for i, (_, names) in enumerate(layers):
        for n in names:
            if module == n or (module.startswith(n + ".") and "." in n):
                return i
    raise KeyError(f"{module} is in no layer: add it to LAYERS")


def upward(graph: dict[str, set[str]], layers=LAYERS) -> list[str]:
    """``importer -> imported`` of every edge from a lower layer up to a higher one."""
    return sorted(f"{a} -> {b}" for a, edges in graph.items() for b in edges
                  if layer_of(b, layers) < layer_of(a, layers))


def test_layers_no_upward_import_and_no_cycle():
    graph = import_graph(PACKAGE)
    edges = sum(len(e) for e in graph.values())
    print(f"{len(graph)} modules, {edges} import edges, {len(cycles(graph))} cycles, "
          f"{len(upward(graph))} upward imports")
    assert len(graph) > 100 and "urmx.study.kinds.ida" in graph["urmx.study.kinds"]
    assert "urmx.fragility" in graph["urmx.study.kinds.ida"]  # the kind imports fragility
    assert "urmx.study.engine" in graph["urmx.study"]  # a lazy __getattr__ load is counted
    assert {"urmx.commands.report", "urmx.commands.aliases"} <= graph["urmx.cli"]  # importlib
    assert cycles(graph) == []
    assert upward(graph) == []


def _bad_package(tmp_path: Path) -> Path:
    """A small package whose layers are pkg (face) > pkg.top > pkg.low, with one cycle
    through a function-level import, one through a parent package, and three upward loads
    from pkg.low: a function-level import, an ``importlib`` load and a module
    ``__getattr__``."""
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "low").mkdir()
    files = {
        "__init__.py": "", "a.py": "from . import b\n",
        "b.py": "def f():\n    from .a import g\n",
        "sub/__init__.py": "from . import engine\n", "sub/engine.py": "import pkg.c\n",
        "sub/kinds.py": "", "c.py": "def f():\n    from .sub import kinds\n",
        "d.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from . import e\n",
        "e.py": "from . import d\n", "top.py": "from .low import fine\n",
        "low/__init__.py": "", "low/fine.py": "VALUE = 1\n",
        "low/late.py": "def f():\n    from .. import top\n",
        "low/version.py": "from .. import VERSION\n", "low/sibling.py": "from . import fine\n",
        "low/two.py": "def f():\n    from . import fine, late\n",
        "low/lazy.py": "import importlib\n\ndef f():\n"
                       "    return importlib.import_module('pkg.top')\n",
        "low/attr.py": "def __getattr__(name):\n    import importlib\n"
                       "    return importlib.import_module(f'pkg.{name}')\n",
    }
    for name, text in files.items():
        (pkg / name).write_text(text)
    return pkg


BAD_LAYERS = (("face", ("pkg",)), ("top", ("pkg.top", "pkg.a", "pkg.b", "pkg.c", "pkg.d",
                                            "pkg.e", "pkg.sub")), ("low", ("pkg.low",)))


def test_the_layer_and_cycle_checks_fail_on_a_bad_package(tmp_path):
    """The cycles and the upward imports of :func:`_bad_package` are all found, the lazy
    ones too (and a ``TYPE_CHECKING`` import is none)."""
    graph = import_graph(_bad_package(tmp_path))
    assert cycles(graph) == [["pkg.a", "pkg.b"], ["pkg.c", "pkg.sub", "pkg.sub.engine"]]
    found = upward(graph, BAD_LAYERS)
    assert found[:3] == ["pkg.low.attr -> pkg.a", "pkg.low.attr -> pkg.b",
                         "pkg.low.attr -> pkg.c"]
    assert {"pkg.low.late -> pkg.top", "pkg.low.lazy -> pkg.top",
            "pkg.low.attr -> pkg.top"} <= set(found)
    assert not [f for f in found if f.startswith(("pkg.top", "pkg.low.fine"))]
    assert "pkg.low.version -> pkg" in found  # a name taken from the root package
    assert not [f for f in found if f.startswith("pkg.low.sibling")]  # a module of its own
    assert upward(import_graph(PACKAGE)) == []  # while the real package has none


#: imports of urmx modules inside a function outside the command line, each with its reason
#: (``module:imported``); any other belongs at the top of its module
LATE = {
    # `urmx bench guard` times a fresh process that imports urmx.guard (for the benchmark
    # wall): the reference (scipy.integrate, 0.5 s) and the records (scipy.sparse, obspy)
    # load only when the guard's measurement needs them, as when its baseline was stored
    "urmx.guard:urmx.reference": "the guard's start-up process stays light",
    "urmx.guard:urmx.records.record": "the guard's start-up process stays light",
    "urmx.study.clients:urmx.jitcache": "a worker's identity probe imports urmx where it runs",
    "urmx.study.clients:urmx.provenance": "a worker's identity probe imports urmx where it runs",
}


def _late_outside_the_command_line(package: Path, root: str) -> list[str]:
    found = []
    modules = _modules(package)
    for name, path in modules.items():
        if name == f"{root}.cli" or name.startswith(f"{root}.commands"):
            continue
        found += late_imports(path, name, root, set(modules))
    return found


def test_function_level_imports_only_in_the_command_line_and_a_named_list():
    found = _late_outside_the_command_line(PACKAGE, "urmx")
    in_commands = sum(len(late_imports(p, n, "urmx")) for n, p in _modules(PACKAGE).items()
                      if n == "urmx.cli" or n.startswith("urmx.commands"))
    print(f"function-level urmx imports: {in_commands} in the command line, {len(found)} "
          f"elsewhere ({len(LATE)} named)")
    keys = {f"{f.split(':')[0]}:{f.split(' -> ')[1]}" for f in found}
    assert keys - set(LATE) == set(), "import these at the top of the module, or name them"
    assert set(LATE) <= keys, f"no longer late, drop from LATE: {sorted(set(LATE) - keys)}"


def test_the_late_import_check_fails_on_a_late_import(tmp_path):
    found = _late_outside_the_command_line(_bad_package(tmp_path), "pkg")
    # every module one statement loads (pkg.low.two imports two), a name from a package the
    # package (pkg.low.late: `from .. import top`, top a module, is pkg.top)
    assert sorted(found) == ["pkg.b:2 -> pkg.a", "pkg.c:2 -> pkg.sub.kinds",
                             "pkg.low.late:2 -> pkg.top", "pkg.low.two:2 -> pkg.low.fine",
                             "pkg.low.two:2 -> pkg.low.late"]


#: the functions allowed over 80 lines: numba compiles the event loop (kernel.loop._march) and
#: the event handler it inlines (kernel.loop.handle_event) as one native function whose hot paths
#: are inlined by hand; split into calls they would cost a call per event
EXEMPT = {"kernel/loop.py:_march", "kernel/loop.py:handle_event"}
LONGEST = 80


def _relative(path: Path) -> str:
    """A module's path inside the package (``kernel/loop.py``), or its name outside it."""
    try:
        return path.resolve().relative_to(PACKAGE.resolve()).as_posix()
    except ValueError:
        return path.name


def long_functions(paths: list[Path], limit: int = LONGEST) -> list[str]:
    """``file:function (lines)`` of every function or method longer than `limit` lines."""
    out = []
    for path in paths:
        for node in ast.walk(_parse(path)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                where = f"{_relative(path)}:{node.name}"
                if n > limit and where not in EXEMPT:
                    out.append(f"{where} ({n})")
    return out


#: long functions not yet split, each to leave this list when it is (the test fails on a new
#: one, and on one listed here that is no longer long); none
NOT_YET: set[str] = set()


def test_no_function_longer_than_80_lines_anywhere():
    paths = sorted(PACKAGE.rglob("*.py"))
    assert len(paths) > 100
    found = long_functions(paths)
    print(f"functions over {LONGEST} lines: {', '.join(found) or 'none'} (exempt: "
          f"{', '.join(sorted(EXEMPT))})")
    assert {f.split(" (")[0] for f in found} == NOT_YET


def test_the_length_check_fails_on_a_long_function(tmp_path):
    path = tmp_path / "long.py"
    path.write_text("def short():\n    pass\n\n\ndef long():\n" + "    x = 1\n" * 80)
    assert long_functions([path]) == ["long.py:long (81)"]


def top_modules(package: Path) -> list[str]:
    """The modules directly under `package` (its ``__init__`` not counted)."""
    return sorted(p.stem for p in package.glob("*.py") if p.name != "__init__.py")


def test_at_most_15_modules_directly_under_urmx(tmp_path):
    found = top_modules(PACKAGE)
    print(f"{len(found)} modules directly under urmx/: {', '.join(found)}")
    assert len(found) <= 15
    (tmp_path / "many").mkdir()
    for i in range(16):
        (tmp_path / "many" / f"m{i}.py").write_text("")
    assert len(top_modules(tmp_path / "many")) == 16  # the count sees a crowded folder


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
    for kind in kinds.BUILT_IN:  # a kind of capacity searches warms the capacity loop
        warm = kernel.warm_up_capacity if "capacity" in kind.outputs else kernel.warm_up
        assert kind.warm_up is warm and kind.dt_above == kernel.WINDOW
    assert {k.name for k in kinds.BUILT_IN if k.warm_up is kernel.warm_up_capacity} >= {"ida"}


KNOWN: set[str] = set()


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def private_uses(package: Path) -> set[str]:
    """``"file -> module.name"`` for every private name of one module of `package` that
    another module imports (``from .x import _name``) or reads (``x._name``,
    ``pkg.x._name``)."""
    root = package.parent
    modules = {}
    for path in package.rglob("*.py"):
        parts = list(path.relative_to(root).with_suffix("").parts)
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    found = set()
    for name, path in modules.items():
        here = path.relative_to(root).as_posix()
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        package_of = name if path.name == "__init__.py" else name.rpartition(".")[0]
        aliases = {}  # local name -> module it is bound to
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name in modules:
                        aliases[a.asname or a.name.split(".")[0]] = (
                            a.name if a.asname else a.name.split(".")[0])
            elif isinstance(node, ast.ImportFrom):
                base = package_of.split(".")[:len(package_of.split(".")) - node.level + 1]
                source = (".".join(base + [node.module] if node.module else base)
                          if node.level else node.module or "")
                if source not in modules:
                    continue
                for a in node.names:
                    if f"{source}.{a.name}" in modules:
                        aliases[a.asname or a.name] = f"{source}.{a.name}"
                    if _private(a.name) and source != name:
                        found.add(f"{here} -> {source}.{a.name}")
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and _private(node.attr):
                chain, value = [], node.value
                while isinstance(value, ast.Attribute):
                    chain.append(value.attr)
                    value = value.value
                if isinstance(value, ast.Name) and value.id in aliases:
                    target = ".".join([aliases[value.id], *reversed(chain)])
                    if target in modules and target != name:
                        found.add(f"{here} -> {target}.{node.attr}")
    return found


def test_no_module_imports_a_private_name_of_another():
    found = private_uses(PACKAGE)
    assert found - KNOWN == set(), "private names used across modules"
    assert KNOWN <= found, f"no longer used, drop from KNOWN: {sorted(KNOWN - found)}"


def test_the_private_name_check_fails_on_a_bad_package(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "core.py").write_text("_cache = {}\ndef _helper(): pass\ndef public(): pass\n")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "use.py").write_text(
        "from .. import core as C\nfrom ..core import _helper, public\nimport pkg.core\n"
        "x = C._cache, pkg.core._helper, C.public, C.__name__\n")
    (pkg / "ok.py").write_text("from .core import public\n_mine = 1\nprint(_mine)\n")
    assert private_uses(pkg) == {"pkg/sub/use.py -> pkg.core._helper",
                                 "pkg/sub/use.py -> pkg.core._cache"}


def shadowed(package: Path) -> set[str]:
    """``pkg.sub`` of every submodule whose package face binds its name to something else
    (``from .pieces import tables`` beside ``tables.py``): ``import pkg.sub as m`` then
    gives that thing, not the module."""
    root = package.parent
    found = set()
    for init in package.rglob("__init__.py"):
        folder = init.parent
        subs = {p.stem for p in folder.glob("*.py") if p.stem != "__init__"}
        subs |= {p.name for p in folder.iterdir() if (p / "__init__.py").is_file()}
        dotted = ".".join(folder.relative_to(root).parts)
        for node in _parse(init).body:
            if isinstance(node, ast.ImportFrom) and not (node.level == 1 and not node.module):
                bound = {a.asname or a.name for a in node.names}
            elif isinstance(node, (ast.FunctionDef, ast.ClassDef)):
                bound = {node.name}
            elif isinstance(node, ast.Assign):
                bound = {t.id for t in node.targets if isinstance(t, ast.Name)}
            else:
                continue
            found |= {f"{dotted}.{n}" for n in bound & subs}
    return found


#: submodules their face shadows on purpose: each assessment procedure is called by the
#: name of its module (``urmx.assess.nzsee_c8(...)``), and ``urmx.records.manifest()`` and
#: ``measures()`` are the records' public functions (issues before 35)
SHADOWED = {"urmx.assess.asce41_ht", "urmx.assess.doherty", "urmx.assess.ntc_kinematic",
            "urmx.assess.nzsee_c8", "urmx.assess.urmx_rule", "urmx.records.manifest",
            "urmx.records.measures"}


def test_no_package_face_shadows_a_new_submodule(tmp_path):
    assert shadowed(PACKAGE) == SHADOWED
    pkg = tmp_path / "pkg"
    (pkg / "kernel").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "kernel" / "__init__.py").write_text(
        "from . import loop\nfrom .pieces import Tables, tables\ndef checks(): pass\n")
    for name in ("loop", "pieces", "tables", "checks"):
        (pkg / "kernel" / f"{name}.py").write_text("")
    assert shadowed(pkg) == {"pkg.kernel.tables", "pkg.kernel.checks"}


def test_library_code_leaves_the_plotting_backend_alone():
    for path in PACKAGE.rglob("*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                names = [a.name for a in node.names] + [getattr(node, "module", None) or ""]
                assert not any("pyplot" in n for n in names), f"{path}: imports pyplot"
            if isinstance(node, ast.Attribute) and node.attr == "use":
                assert ast.unparse(node.value) != "matplotlib", f"{path}: matplotlib.use"


def test_the_layout_page_names_every_module_and_folder():
    layout = (project_root() / "docs" / "layout.md").read_text(encoding="utf-8")
    names = {p.stem for p in PACKAGE.rglob("*.py") if p.stem != "__init__"}
    names |= {p.name for p in PACKAGE.rglob("*") if (p / "__init__.py").is_file()}
    missing = {n for n in names if not re.search(rf"\b{n}\b", layout)}
    assert not missing, f"docs/layout.md lacks {sorted(missing)}"
    assert "kinds/__init__.py is the one place kinds are registered" in " ".join(
        layout.split())
    folders = {p.name for p in project_root().iterdir()
               if p.is_dir() and not p.name.startswith(".") and p.name not in
               ("results", "build", "dist", "scratch") and not p.name.endswith(".egg-info")}
    assert not {f for f in folders if f"{f}/" not in layout}, "docs/layout.md lacks a folder"


# ---- the tests themselves: no test module imports another ---------------------------------

TESTS = Path(__file__).resolve().parent


def _test_modules_imported(source: str, package: str = "tests") -> list[str]:
    """The test modules (``tests.test_*``) that Python `source`, a module of `package`,
    imports: ``import tests.test_x``, ``from tests.test_x import ...``, ``from tests import
    test_x``, the relative forms (``from .test_x``, ``from . import test_x``, ``from
    ..test_x`` in a subpackage) and ``importlib.import_module("tests.test_x")``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            parts = package.split(".")
            base = ".".join(parts[:len(parts) - node.level + 1] if node.level else [])
            module = ".".join(p for p in (base, node.module or "") if p)
            names = [module, *(f"{module}.{a.name}" for a in node.names)]
        elif isinstance(node, ast.Call) and ast.unparse(node.func).endswith("import_module") \
                and node.args and isinstance(node.args[0], ast.Constant):
            names = [str(node.args[0].value)]
        found += [n for n in names if re.fullmatch(r"tests\.test_\w+", n)]
    return sorted(set(found))


def test_no_test_module_imports_another():
    """Issue 35: test modules share data, stand-ins and fixtures through ``tests/helpers/``,
    ``tests/fixtures/`` and ``conftest.py`` only; no test module imports a test module (not
    even itself), and neither do the helpers and fixtures. The check is shown to find each
    form of such an import planted in a source string, and to pass the shared places."""
    bad = {}
    for path in sorted(TESTS.rglob("*.py")):
        package = ".".join(path.relative_to(TESTS.parent).parent.parts)
        found = _test_modules_imported(path.read_text(encoding="utf-8"), package)
        if found:
            bad[str(path.relative_to(TESTS.parent))] = found
    assert bad == {}
    planted = {
        "from .test_study import ACC\n": "tests.test_study",
        "import tests.test_kinds as T\n": "tests.test_kinds",
        "from tests.test_docs import fallback_version\n": "tests.test_docs",
        "from . import test_cells\n": "tests.test_cells",
        "from tests import test_risk\n": "tests.test_risk",
        "def f():\n    from .test_fragility import ACC\n": "tests.test_fragility",
        "import importlib\nT = importlib.import_module('tests.test_cells')\n":
            "tests.test_cells",
    }
    for source, module in planted.items():
        assert _test_modules_imported(source) == [module], source
    assert _test_modules_imported("from ..test_study import ACC\n", "tests.helpers") == \
        ["tests.test_study"]
    for fine in ("from .helpers.grid_study import ACC\n", "from .fixtures import pinned\n",
                 "import tests.helpers.kernel\n", "from ..fixtures.records import record_file\n",
                 "from .conftest import x\n", "RUN = 'import tests.test_cells as T'\n"):
        assert _test_modules_imported(fine) == [], fine
