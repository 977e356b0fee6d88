"""The sections of ``reports/performance.md``, in report order.

A section is a module here with

- ``run(quick: bool) -> dict``: measure; the dict (plain JSON values) is saved as
  ``reports/performance/<name>.json``. ``run`` may also take the keyword arguments
  ``figures`` (the folder for its PNG files), ``echo`` (a print function for progress)
  and ``window`` (seconds of each record, ``--window``); the runner passes those it names.
- ``render(data: dict) -> list[str]``: its Markdown lines, from the saved dict alone
  (``figures_dir``, the figure folder as the report links it, if it takes it).
- optionally ``targets(data) -> list[list[str]]``: its rows (target, measured, verdict)
  of the report's targets table, and ``IN_ALL = False`` to leave it out of ``all``.

To add a section, write its module and add it to `SECTIONS`; the name on the command line
and of the JSON file is the module's name.
"""

from . import (
    cost_growth,
    fragility,
    grid_scaling,
    guard,
    hard_cases,
    kernel,
    opensees,
    paper,
    scale,
    startup,
    statuses,
    uncertainty,
    wall_population,
    work_precision,
)

SECTIONS = [kernel, work_precision, cost_growth, grid_scaling, paper, hard_cases, guard,
            fragility, statuses, startup, opensees, uncertainty, scale, wall_population]

#: names on the command line that run several sections
GROUPS = {
    "records": ["work_precision", "cost_growth"],
    "study": ["grid_scaling"],
    "hard": ["hard_cases"],
}
