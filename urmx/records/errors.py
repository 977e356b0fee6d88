"""Errors raised by the record readers and the manifest.

Every error is a :class:`urmx.UrmxError` and a :class:`ValueError` (a missing file raises
:class:`urmx.errors.MissingFileError`, a :class:`FileNotFoundError`), names the file and
says what is wrong, so the CLI can print it as one line.
"""

from __future__ import annotations

import os

from ..errors import UrmxError


class RecordError(UrmxError, ValueError):
    """A record file cannot be turned into a trustworthy acceleration history."""

    def __init__(self, path: str | os.PathLike | None, problem: str):
        self.path = None if path is None else str(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}" if self.path else problem)


class UnknownFormatError(RecordError):
    """The file's content matches no supported record format."""


class TruncatedRecordError(RecordError):
    """The file ends before all the samples its header announces."""


class PointCountError(RecordError):
    """The number of samples disagrees with the point count in the header."""


class NonFiniteError(RecordError):
    """The samples contain NaN or infinite values."""


class RecordUnitError(RecordError):
    """A unit is unknown, missing, contradicts the header, or gives implausible values."""


class MissingTimeStepError(RecordError):
    """The time step is missing (the file does not carry it and none was given), is not a
    positive number, or contradicts the file's own (header, comment or time column)."""


class UnusualRecordError(RecordUnitError):
    """A time step, peak or file size outside what strong-motion records have (most often a
    unit mistake: values in g under a cm/s2 header, milliseconds given as seconds); read it
    anyway with ``allow_unusual=True`` (``--allow-unusual``) when it is really meant."""


class ChannelError(RecordError):
    """A file holds several channels and none was chosen, or not the one asked for."""


class UnsupportedRecordError(RecordError):
    """A known file type that holds no usable acceleration (raw counts, spectra), or a
    file urmx refuses to read because reading it could run code (a Python pickle)."""


class ChecksumError(RecordError):
    """A record file's SHA-256 differs from the manifest."""


class ManifestError(RecordError):
    """The manifest is malformed or does not know a record id."""
