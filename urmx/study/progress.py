"""Progress of a study run: a bar with rate and ETA on a terminal, plain lines in a log
file (both on stderr), and `tqdm.auto`'s bar (a widget where ipywidgets is installed) in a
Jupyter notebook."""

from __future__ import annotations

import sys
import time as _time
import warnings
from typing import Any


def in_notebook() -> bool:
    """Whether this process is a Jupyter kernel (an IPython ZMQ shell)."""
    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None and hasattr(ipython,
                                                                      "get_ipython") else None
    return type(shell).__name__ == "ZMQInteractiveShell"


class Progress:
    """Progress of a study in its kind's unit (analyses, cells, ...): in a Jupyter notebook
    (and no `stream` given), `tqdm.auto`'s bar; else on stderr, a tqdm bar (rate, ETA) on a
    terminal, and on a file or pipe, plain lines (no carriage returns) at every tenth of the
    work and at least once a minute."""

    def __init__(self, total: int, done: int, enabled: bool, label: str = "urmx",
                 stream: Any = None, unit: str = "analyses"):
        self.stream = stream or sys.stderr
        self.total, self.done, self.label, self.unit = total, done, label, f" {unit}"
        self.enabled = enabled and total > 0
        self.bar = None
        self.start = _time.monotonic()
        self.initial = done
        self.last_line = (-1, self.start)
        if not self.enabled:
            return
        isatty = getattr(self.stream, "isatty", None)
        if stream is None and in_notebook():
            with warnings.catch_warnings():  # no ipywidgets: tqdm's text bar, unwarned
                warnings.simplefilter("ignore")
                from tqdm.auto import tqdm as auto
            self.bar = auto(total=total, initial=done, unit=self.unit, desc=label,
                            smoothing=0.05, leave=True)
        elif isatty is not None and isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=total, initial=done, unit=self.unit, desc=label,
                            file=self.stream, dynamic_ncols=True, smoothing=0.05, leave=True)
        else:
            self._line()

    def note(self, message: str) -> None:
        """A line of text above the bar (nothing when progress is off).

        Parameters
        ----------
        message : str
            The line.
        """
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.write(message, file=self.stream)
        else:
            self.stream.write(message + "\n")
            self.stream.flush()

    def _line(self) -> None:
        from tqdm import tqdm

        now = _time.monotonic()
        meter = tqdm.format_meter(self.done, self.total, now - self.start, ncols=0,
                                  prefix=self.label, unit=self.unit, initial=self.initial)
        self.stream.write(meter + "\n")
        self.stream.flush()
        self.last_line = (10 * self.done // self.total, now)

    def update(self, n: int) -> None:
        """Count `n` more units of work done (the bar, or a plain line every tenth of the work).

        Parameters
        ----------
        n : int
            Units done since the last update.
        """
        self.done += n
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.update(n)
            return
        tenth, when = self.last_line
        if (10 * self.done // self.total > tenth or self.done == self.total
                or _time.monotonic() - when > 60.0):
            self._line()

    def close(self) -> None:
        """End the bar (nothing to end for plain lines or when progress is off)."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None
