"""Build hook: a built urmx carries its data as package data.

The catalog (every file of ``catalog/``: walls, diaphragms, building, studies,
paper.toml, examples) and the records (every file of ``records/``: the manifest, the record
files it names, PROVENANCE.md) have one source, the top-level folders of the checkout. Building a wheel (``pip install .``, ``pip wheel .``, ``python -m
build``) copies them into the build tree as ``urmx/_data/catalog/`` and
``urmx/_data/records/``, where `urmx.config.data_dir` finds them with
`importlib.resources`; nothing is copied in git. An editable install (``pip install -e .``)
copies nothing: urmx then reads the checkout's folders themselves. The project's metadata
is in pyproject.toml.
"""

from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent
#: folder -> the files of it a wheel carries, under urmx/_data/<folder>/
DATA = {"catalog": "**/*", "records": "**/*"}


def data_files() -> list[Path]:
    """The data files of the checkout (or sdist) a wheel carries; an error when one of the
    folders has none (a wheel without its catalog must not be built)."""
    files = []
    for folder, pattern in DATA.items():
        found = sorted(p for p in (ROOT / folder).glob(pattern) if p.is_file()
                       and not any(part.startswith((".", "__")) for part in
                                   p.relative_to(ROOT).parts))
        if not found:
            raise SystemExit(f"setup.py: no {folder}/{pattern} beside {ROOT}: the wheel "
                             "would lack urmx's data")
        files += found
    return files


class BuildPyWithData(build_py):
    """`build_py` that also copies the checkout's data into ``urmx/_data/``."""

    def run(self):
        super().run()
        if getattr(self, "editable_mode", False):
            return  # an editable urmx reads the checkout's own folders
        for src in data_files():
            dest = Path(self.build_lib, "urmx", "_data", src.relative_to(ROOT))
            self.mkpath(str(dest.parent))
            self.copy_file(str(src), str(dest))

    def get_outputs(self, include_bytecode=True):
        if getattr(self, "editable_mode", False):
            return super().get_outputs(include_bytecode)
        return super().get_outputs(include_bytecode) + [
            str(Path(self.build_lib, "urmx", "_data", p.relative_to(ROOT)))
            for p in data_files()]


setup(cmdclass={"build_py": BuildPyWithData})
