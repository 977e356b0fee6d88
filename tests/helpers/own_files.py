"""A study on record files of one's own, beside the study file (`tests/test_study_file.py`,
`tests/test_cells.py`): three record files of the folder of the format samples (`AT2`, `V2A`,
`PLAIN`, paths inside it) and `OWN_FILES`, a study file that reads them from ``data/``."""

AT2 = "formats/peer/RSN763_LOMAP_GIL067.AT2"
V2A = "formats/geonet/20161113_110259_WTMC_20.V2A"
PLAIN = "elcentro1940/elcentro_S00E_1940.dat"  # plain numbers: dt 0.02 s, cm/s2

OWN_FILES = """\
[study]
name = "own-files"
walls = ["mine"]
diaphragms = ["specimen"]
supports = "specimen"
records = ["gilroy", "wtmc", "mine"]
cor = [0.75, 0.85]

[walls.mine]
thickness = 0.23
height = 3.2
crack_ratio = 0.6
mass = 6000.0
top_stiffness = 1.2e6
top_mass = 5000.0
top_damping = 0.12

[records.gilroy]
file = "data/RSN763_LOMAP_GIL067.AT2"

[records.wtmc]
file = "data/20161113_110259_WTMC_20.V2A"
channel = "S62W"

[records.mine]
file = "data/my-record.txt"
dt = 0.02
unit = "cm/s2"
scale = 2.0
"""
