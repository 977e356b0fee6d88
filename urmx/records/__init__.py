"""Ground-motion records: readers, processing, measures and the record manifest.

Public API::

    from urmx.records import read, load, manifest, measures
    st = read("RSN6953_DARFIELD_PRPCW.AT2")         # obspy.Stream in m/s2
    tr = load("nahanni")                            # manifest record, sha256-checked
    ds = measures(tr)                               # pga, pgv, pgd, arias_intensity, ...
    rs = response_spectrum(tr)                      # psa(period), 5 % damping
    rec = as_record("nahanni")                      # Record: samples, dt, scale factor
"""

from .errors import (
    ChecksumError,
    ManifestError,
    MissingTimeStepError,
    NonFiniteError,
    PointCountError,
    RecordError,
    RecordUnitError,
    TruncatedRecordError,
    UnknownFormatError,
    UnsupportedRecordError,
)
from .manifest import load, load_samples, manifest
from .measures import (
    arias_history,
    fourier_spectrum,
    measures,
    predominant_frequency,
    response_spectrum,
    sdof_displacement,
    significant_duration,
    significant_frequency_range,
)
from .processing import bandpass, baseline, process, resample, scale, taper
from .readers import FORMATS, STANDARD_GRAVITY, UNIT_FACTORS, detect_format, read
from .record import Record, as_record

__all__ = [
    "read", "detect_format", "load", "load_samples", "manifest", "measures", "Record",
    "as_record",
    "response_spectrum",
    "fourier_spectrum", "significant_frequency_range", "significant_duration",
    "predominant_frequency", "arias_history", "sdof_displacement",
    "baseline", "taper", "bandpass", "resample", "scale", "process",
    "FORMATS", "UNIT_FACTORS", "STANDARD_GRAVITY",
    "RecordError", "UnknownFormatError", "TruncatedRecordError", "PointCountError",
    "NonFiniteError", "RecordUnitError", "MissingTimeStepError", "UnsupportedRecordError",
    "ChecksumError", "ManifestError",
]
