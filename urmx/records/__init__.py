"""Ground-motion records: readers, processing, measures and the record manifest.

Public API::

    from urmx.records import read, load, manifest, measures
    st = read("RSN6953_DARFIELD_PRPCW.AT2")         # obspy.Stream in m/s2
    tr = load("nahanni")                            # manifest record, sha256-checked
    rf = describe("RSN763_LOMAP_GIL067.AT2")        # one channel + sha256, format, unit, dt
    ds = measures(tr)                               # pga, pgv, pgd, arias_intensity, ...
    rs = response_spectrum(tr)                      # psa(period), 5 % damping
    rec = as_record("nahanni")                      # Record: samples, dt, scale factor
"""

from .errors import (
    ChannelError,
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
    UnusualRecordError,
)
from .manifest import index, load, load_samples, manifest, write_manifest
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
from .readers import (
    DT_RANGE,
    FORMATS,
    MAX_RECORD_BYTES,
    PGA_RANGE_G,
    STANDARD_GRAVITY,
    UNIT_FACTORS,
    RecordFile,
    check_finite,
    describe,
    describe_all,
    detect_format,
    read,
    read_channel,
)
from .record import Record, as_record

__all__ = [
    "read", "read_channel", "detect_format", "describe", "describe_all", "RecordFile",
    "check_finite",
    "load", "load_samples", "manifest", "index", "write_manifest", "measures",
    "Record", "as_record",
    "response_spectrum",
    "fourier_spectrum", "significant_frequency_range", "significant_duration",
    "predominant_frequency", "arias_history", "sdof_displacement",
    "baseline", "taper", "bandpass", "resample", "scale", "process",
    "FORMATS", "UNIT_FACTORS", "STANDARD_GRAVITY", "DT_RANGE", "PGA_RANGE_G",
    "MAX_RECORD_BYTES",
    "RecordError", "UnknownFormatError", "TruncatedRecordError", "PointCountError",
    "NonFiniteError", "RecordUnitError", "MissingTimeStepError", "UnsupportedRecordError",
    "ChecksumError", "ManifestError", "UnusualRecordError", "ChannelError",
]
