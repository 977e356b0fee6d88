"""The shape of the package: no module reaches into another's private names, library code
leaves the plotting backend alone, and docs/layout.md names every module (those of the
subpackages too) and the one place study kinds are registered."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import urmx
from urmx.config import project_root

PACKAGE = Path(urmx.__file__).parent
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
