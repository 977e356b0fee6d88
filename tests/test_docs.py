"""The documentation (issue 40): every public function has a numpydoc docstring whose
numeric parameters state their units, the API reference lists every public name, the
README fits on a screen and its example runs, every section of the former README has a
page, no file links outside the repository, the model page covers the model contract,
the cluster recipe runs on the client it makes, and a build outside git gets a version.

The docstring rule (:func:`docstring_problems`): the docstring parses as numpydoc and has
a summary; a function with parameters has a ``Parameters`` section naming each of them
(``a, b : float`` names two); a parameter whose type is numeric (``float``, an array, a
number, without ``bool``, ``int`` or ``str`` in its type) states its unit in square
brackets in its description or type, as the code writes units: ``[m]``, ``[s]``,
``[m s-2]``, ``[Hz]``, ``[1]`` (or ``[-]``) for a ratio, ``[units of the intensity]`` for a
quantity in the caller's units.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import os
import re
import subprocess
from pathlib import Path

import pytest

import urmx

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
PUBLIC = ("urmx", "urmx.records", "urmx.study", "urmx.fragility", "urmx.uncertainty",
          "urmx.assess")
#: a numeric parameter type (one that must state a unit) and what exempts one
NUMERIC = re.compile(r"\b(float|floats|array|arrays|ndarray|array_like|number|numbers)\b")
NOT_A_QUANTITY = re.compile(r"\b(bool|u?int\d*|str|Record|Trace)\b")
UNIT = re.compile(r"\[[^\]\s][^\]]*\]")

def docstring_problems(func) -> list[str]:
    """What keeps `func`'s docstring from the rule of the module docstring ([] if none)."""
    from numpydoc.docscrape import NumpyDocString

    doc = inspect.getdoc(func)
    if not doc:
        return ["no docstring"]
    try:
        parsed = NumpyDocString(doc)
    except Exception as exc:  # numpydoc raises ValueError and others on a bad section
        return [f"not numpydoc: {exc}"]
    problems = [] if parsed["Summary"] else ["no summary line"]
    params = [p.name for p in inspect.signature(func).parameters.values()
              if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD) and p.name not in ("self", "cls")]
    if params and not parsed["Parameters"]:
        return problems + ["no Parameters section"]
    documented = {}
    for p in parsed["Parameters"]:
        for name in p.name.split(","):
            documented[name.strip().lstrip("*")] = p
    problems += [f"parameter {n!r} is not in Parameters" for n in params if n not in documented]
    for name, p in documented.items():
        numeric = NUMERIC.search(p.type) and not NOT_A_QUANTITY.search(p.type)
        if numeric and not UNIT.search(p.type + " " + " ".join(p.desc)):
            problems.append(f"parameter {name!r} ({p.type}) states no unit in [brackets]")
    return problems


def public_functions():
    """Every public function (the functions of each module's ``__all__``) and the public
    methods of its public classes (those defined in urmx), by their public names."""
    for name in PUBLIC:
        module = importlib.import_module(name)
        for attr in module.__all__:
            obj = getattr(module, attr)
            if inspect.isfunction(obj):
                yield f"{name}.{attr}", obj
            elif inspect.isclass(obj) and obj.__module__.startswith("urmx"):
                for method, func in vars(obj).items():
                    if isinstance(func, (classmethod, staticmethod)):
                        func = func.__func__
                    if not method.startswith("_") and inspect.isfunction(func):
                        yield f"{name}.{attr}.{method}", func


def test_every_public_function_has_a_numpydoc_docstring_with_units():
    found = dict(public_functions())
    assert len(found) > 150
    assert {"urmx.simulate", "urmx.fragility.fit_lognormal", "urmx.Wall.in_building",
            "urmx.records.Record.from_file"} <= set(found)
    bad = {name: problems for name, func in found.items()
           if (problems := docstring_problems(func))}
    assert not bad, bad


def _good(thickness: float, label: str, *, flag: bool = False) -> None:
    """A planted good docstring.

    Parameters
    ----------
    thickness : float
        Wall thickness. [m]
    label : str
        A name.
    flag : bool
        A switch.
    """


def _no_unit(thickness: float, ratio: float) -> None:
    """A planted bad docstring: a length without its unit.

    Parameters
    ----------
    thickness : float
        Wall thickness in metres.
    ratio : float
        A ratio. [1]
    """


def _no_parameters(thickness: float) -> None:
    """A planted bad docstring: no Parameters section."""


def _one_missing(thickness: float, height: float) -> None:
    """A planted bad docstring: a parameter left out.

    Parameters
    ----------
    thickness : float
        Wall thickness. [m]
    """


def _bad_section(x: float) -> None:
    """A planted bad docstring: a section numpydoc does not know twice.

    Parameters
    ----------
    x : float
        A length. [m]

    Parameters
    ----------
    x : float
        Again. [m]
    """


def test_the_docstring_check_fails_on_planted_bad_docstrings():
    assert docstring_problems(_good) == []
    assert docstring_problems(_no_unit) == [
        "parameter 'thickness' (float) states no unit in [brackets]"]
    assert docstring_problems(_no_parameters) == ["no Parameters section"]
    assert docstring_problems(_one_missing) == ["parameter 'height' is not in Parameters"]
    assert docstring_problems(_bad_section)[0].startswith("not numpydoc")
    assert docstring_problems(lambda x: x) == ["no docstring"]


def test_the_api_reference_lists_every_public_name():
    pages = {"urmx": "urmx", "urmx.records": "records", "urmx.study": "study",
             "urmx.fragility": "fragility", "urmx.uncertainty": "uncertainty",
             "urmx.assess": "assess"}
    assert set(pages) == set(PUBLIC)
    for module, page in pages.items():
        text = (DOCS / "api" / f"{page}.rst").read_text(encoding="utf-8")
        assert f".. currentmodule:: {module}" in text
        listed = set(re.findall(r"^   (\w+)$", text, re.M))
        listed |= set(re.findall(r"^\.\. (?:autodata|data):: (\w+)", text, re.M))
        listed |= set(re.findall(r"``(\w+)``(?: and ``(\w+)``)? are re-exported", text)[0]
                      if "re-exported" in text else ())
        missing = set(importlib.import_module(module).__all__) - listed
        assert not missing, f"docs/api/{page}.rst lacks {sorted(missing)}"
    index = (DOCS / "api" / "index.md").read_text(encoding="utf-8")
    assert all(f"\n{page}\n" in index for page in pages.values())


# ---- the README ---------------------------------------------------------------------------

def readme() -> str:
    return (ROOT / "README.md").read_text(encoding="utf-8")


def readme_example() -> str:
    section = readme().split("\n## A ten-line example\n", 1)[1]
    return section.split("```python\n", 1)[1].split("```", 1)[0]


def layout_mismatch(text: str) -> set[str]:
    """Folders the README's Layout tree (one line a folder) names that do not exist, or
    packages of urmx/ it does not name, or folders it names twice."""
    layout = text.split("## Layout", 1)[1].split("\n## ", 1)[0]
    lines = re.findall(r"^    ([\w/]+/) ", layout, re.M)
    packages = {f"urmx/{p.name}/" for p in (ROOT / "urmx").iterdir()
                if (p / "__init__.py").is_file()}
    named = {x for x in lines if x.startswith("urmx/") and x != "urmx/"}
    twice = {x for x in lines if lines.count(x) > 1}
    return (named ^ packages) | {x for x in lines if not (ROOT / x).is_dir()} | twice


def test_the_layout_check_fails_on_a_stale_tree():
    good = readme()
    assert layout_mismatch(good.replace("    urmx/kernel/ ", "    urmx/kern/ ")) == {
        "urmx/kern/", "urmx/kernel/"}
    assert layout_mismatch(good.replace("    urmx/plot/ ", "    urmx/paper/ ")) == {
        "urmx/plot/", "urmx/paper/"}


def test_the_readme_fits_on_a_screen_and_has_its_parts():
    text = readme()
    assert len(text.splitlines()) <= 200
    headings = re.findall(r"^## (.+)$", text, re.M)
    assert headings == ["Quick start", "Install", "A ten-line example", "What is in the box",
                        "Layout", "Tests", "How to cite", "Licence"]
    assert layout_mismatch(text) == set()
    assert re.search(r'<img src="reports/[\w/]+\.png"', text)
    # every relative link of the README and of the docs pages leads to a file of the repository
    for path in [ROOT / "README.md", *DOCS.rglob("*.md")]:
        if "_build" in path.parts:
            continue
        for target in re.findall(r"\]\(([^)\s]+)\)|<img src=\"([^\"]+)\"", path.read_text(
                encoding="utf-8")):
            target = next(t for t in target if t).split("#", 1)[0]
            if not target or re.match(r"[a-z]+:", target):
                continue
            resolved = (path.parent / target).resolve()
            assert resolved.is_relative_to(ROOT) and resolved.exists(), (path, target)


def test_the_readme_example_runs_in_ten_lines(capsys, records_dir):
    code = readme_example()
    assert len([ln for ln in code.splitlines() if ln.strip()]) <= 10
    exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 3
    wall = urmx.Wall.in_building(thickness=0.23, height=4.14, crack_ratio=2 / 3,
                                 density=1800.0, wall_length=12.51, diaphragm_weight=0.455,
                                 plan_area=17.4 * 29.9, diaphragm_frequency=3.0, damping=0.12)
    record = urmx.records.load("elcentro")
    for line, cor in zip(lines, (0.7, 0.8, 0.9), strict=True):
        ds = urmx.simulate(wall, record, scale=1.5, cor=cor)
        ratio, top = ds.instability_ratio.item(), ds.peak_top_displacement.item()
        assert line == (f"COR {cor}: instability ratio {ratio:.3f}, top {1e3 * top:.1f} mm, "
                        f"collapsed {ds.collapsed.item():g}")
        assert 0 < ratio <= 1 and (ratio == 1) == bool(ds.collapsed.item())


def former_readme_headings() -> list[str] | None:
    """The ``##``/``###`` headings of the README before issue 40 (commit faaadda), or None
    when the history is not there (a copy without git)."""
    done = subprocess.run(["git", "-C", str(ROOT), "show", "faaadda:README.md"],
                          capture_output=True, text=True, check=False)
    if done.returncode != 0:
        return None
    return re.findall(r"^#{2,3} (.+)$", done.stdout, re.M)


def test_every_section_of_the_former_readme_has_a_page():
    rows = re.findall(r"^\| (.+?) \| `([^`]+)` \| (.+?) \| .*\|$",
                      (DOCS / "readme-sections.md").read_text(encoding="utf-8"), re.M)
    rows = [r for r in rows if r[0] != "former README heading"]
    assert len(rows) >= 22
    for old, page, heading in rows:
        text = (ROOT / page).read_text(encoding="utf-8")
        assert re.search(rf"^#+ {re.escape(heading)}$", text, re.M), (old, page, heading)
    former = former_readme_headings()
    if former is not None:  # the checklist covers the former README, heading by heading
        assert len(former) == 21
        assert set(former) == {r[0] for r in rows}
    # the texts tests and code point at moved with their sections
    errors = (DOCS / "guide" / "errors.md").read_text(encoding="utf-8")
    assert all(f"**Rule {n}:" in errors for n in range(1, 8))
    start = (DOCS / "getting-started.md").read_text(encoding="utf-8")
    assert "1,171 tests in 613 s" in " ".join(start.split())


# ---- no link out of the repository --------------------------------------------------------

OUTSIDE = re.compile(r"\.\./shared|shared/(?:design|paper|records)\b|/work/")


def outside_links(root: Path) -> list[str]:
    """Files of the repository (Markdown, reST, TOML, CFF, and the docstrings of the package,
    the benchmarks and the docs' Python) that name a path outside the repository."""
    found = []
    skip = {".git", "_build", "results", "build", "dist", "generated", "__pycache__"}
    for path in sorted(root.rglob("*")):
        rel = path.relative_to(root)
        if set(rel.parts) & skip or rel.parts[0].startswith(".venv") or not path.is_file():
            continue
        if path.suffix in (".md", ".rst", ".toml", ".cff", ".ipynb") or path.name == "run":
            text = path.read_text(encoding="utf-8", errors="replace")
        elif path.suffix == ".py" and rel.parts[0] in ("urmx", "benchmarks", "docs"):
            tree = ast.parse(path.read_text(encoding="utf-8"))
            text = "\n".join(ast.get_docstring(node) or "" for node in ast.walk(tree)
                             if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef,
                                                  ast.AsyncFunctionDef)))
        else:
            continue
        found += [f"{rel}: {m.group(0)}" for m in OUTSIDE.finditer(text)]
    return found


def test_no_file_links_outside_the_repository(tmp_path):
    assert outside_links(ROOT) == []
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "page.md").write_text("See ../shared/design/MODEL.md.\n")
    (tmp_path / "urmx").mkdir()
    (tmp_path / "urmx" / "m.py").write_text('def f():\n    """As /work/shared/paper says."""\n')
    assert outside_links(tmp_path) == ["docs/page.md: ../shared", "urmx/m.py: /work/",
                                       "urmx/m.py: shared/paper"]


def test_the_model_page_covers_the_contract_with_the_papers_numbers():
    text = (DOCS / "model" / "index.md").read_text(encoding="utf-8")
    for heading in ("The wall", "Four rocking patterns", "The trilinear curves",
                    "The equations of motion", "Impacts and the two impact laws",
                    "Held joints", "Events", "What is exact and what is a choice"):
        assert f"\n## {heading}\n" in text, heading
    for ref in ("Eq. 7", "Eq. 1", "Eq. 2", "Eq. 3", "Eq. 4", "Eq. 5", "Table I", "Table III",
                "Table VI", "Fig. 1", "Fig. 2", "Fig. 4"):
        assert f"**{ref}**" in text, ref
    assert "`scale`" in text and "`contact`" in text and "t_\\mathrm{rest}" in text
    assert "](../MODEL.md)" in text  # the full contract, in the repository


# ---- running on a cluster: the dask-jobqueue recipe ----------------------------------------

TINY = """[study]
name = "my-study"
walls = ["s12"]
diaphragms = ["D1"]
records = ["elcentro"]
cor = [0.7, 0.8]
"""


def jobqueue_recipe() -> str:
    page = (DOCS / "guide" / "cluster.md").read_text(encoding="utf-8")
    section = page.split("\n## A batch system: dask-jobqueue\n", 1)[1]
    return section.split("```python\n", 1)[1].split("```", 1)[0]


def test_the_jobqueue_recipe_runs_on_the_client_it_makes(tmp_path, monkeypatch, records_dir):
    """The page's script as written, with a local cluster of threads in place of SLURM
    (one worker per job): the study runs on the Client the script makes (the engine is
    handed that Client, not a cluster of its own) and its archive equals a serial run's;
    and dask-jobqueue's real SLURMCluster, called as the page calls it, writes a job script
    with the page's resources and prologue (nothing is submitted)."""
    dask_jobqueue = pytest.importorskip("dask_jobqueue")
    import xarray as xr
    from distributed import Client, LocalCluster

    from urmx.study import engine

    code = jobqueue_recipe()
    made, handed, slurm = [], [], dask_jobqueue.SLURMCluster

    class LocalSLURM(LocalCluster):
        def __init__(self, **job):
            super().__init__(n_workers=0, processes=False, threads_per_worker=1,
                             dashboard_address=":0")
            made.append((self, job))

        def scale(self, n=None, jobs=0, **kw):
            return super().scale(jobs)

    real_get_client = engine.get_client

    def spy(scheduler, *rest, **kw):
        handed.append(scheduler)
        return real_get_client(scheduler, *rest, **kw)

    monkeypatch.setattr(dask_jobqueue, "SLURMCluster", LocalSLURM)
    monkeypatch.setattr(engine, "get_client", spy)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "my-study.toml").write_text(TINY, encoding="utf-8")
    exec(compile(code, "cluster.md", "exec"), {"__name__": "__main__"})
    (cluster, job), = made
    assert job["cores"] == 8 and job["processes"] == 8 and job["walltime"] == "02:00:00"
    assert len(handed) == 1 and isinstance(handed[0], Client)
    assert handed[0].cluster is cluster
    urmx.run_study(tmp_path / "my-study.toml", out=tmp_path / "serial.nc", scheduler="serial",
                   progress=False)
    with xr.open_dataset(tmp_path / "my-study.nc") as a, \
            xr.open_dataset(tmp_path / "serial.nc") as b:
        assert a.sizes["cor"] == 2
        xr.testing.assert_equal(a.instability_ratio, b.instability_ratio)

    call = re.search(r"SLURMCluster\((.*?)\)\n", code, re.S).group(1)
    real = eval(f"SLURMCluster({call}, scheduler_options={{'dashboard_address': ':0'}})",
                {"SLURMCluster": slurm})
    try:
        script = real.job_script()
    finally:
        real.close()
    assert "#SBATCH -t 02:00:00" in script and "#SBATCH --mem=15G" in script
    assert "source ~/urmx/.venv/bin/activate" in script and "--nworkers 8" in script


# ---- versions from git tags ---------------------------------------------------------------

def _git(cwd: Path, *args: str) -> str:
    env = dict(os.environ, GIT_AUTHOR_NAME="t", GIT_AUTHOR_EMAIL="t@t", GIT_COMMITTER_NAME="t",
               GIT_COMMITTER_EMAIL="t@t")
    return subprocess.run(["git", "-C", str(cwd), *args], capture_output=True, text=True,
                          check=True, env=env).stdout.strip()


def test_a_checkouts_release_is_its_nearest_tag(tmp_path, monkeypatch):
    """`git_release` names a checkout's version from its tags as setuptools-scm's
    post-release scheme does, and `code_version` adds the commit: no tag, at the tag, three
    commits after it, a newer tag."""
    from urmx import provenance

    repo = tmp_path / "repo"
    (repo / "urmx").mkdir(parents=True)
    (repo / "urmx" / "provenance.py").write_text("")
    _git(repo, "init", "-q")
    _git(repo, "add", "-A")
    _git(repo, "commit", "-qm", "one")
    monkeypatch.setattr(provenance, "ROOT", repo)

    def release():
        provenance.git_commit.cache_clear()
        provenance.git_release.cache_clear()
        return provenance.git_release(), provenance.code_version()

    try:
        assert release()[0] is None
        _git(repo, "tag", "-a", "v0.2.0", "-m", "0.2.0")
        head = _git(repo, "rev-parse", "HEAD")[:7]
        assert release() == ("0.2.0", f"0.2.0+g{head}")
        for n in range(3):
            _git(repo, "commit", "-q", "--allow-empty", "-m", f"after {n}")
        head = _git(repo, "rev-parse", "HEAD")[:7]
        assert release() == ("0.2.0.post3", f"0.2.0.post3+g{head}")
        (repo / "urmx" / "provenance.py").write_text("# changed\n")
        assert release()[1] == f"0.2.0.post3+g{head}.dirty"
        _git(repo, "tag", "-a", "v0.10.1", "-m", "0.10.1")
        assert release()[0] == "0.10.1"
    finally:
        provenance.git_commit.cache_clear()
        provenance.git_release.cache_clear()


