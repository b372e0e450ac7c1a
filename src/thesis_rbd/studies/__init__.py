"""Studies: what accuracy costs in time on a scene, over a grid of world settings.

>>> import thesis_rbd as rbd
>>> table = rbd.study("bouncing_ball", vary={"dt": [1/60, 1/240]}, seconds=1.0)  # doctest: +SKIP
>>> table.recommend({"position": 1e-3}).sentence  # doctest: +SKIP

:func:`study` runs every combination of the settings it is given, on local worker processes
or a Dask cluster, measures each run against a reference run (:mod:`.measures`), and returns
the table (:class:`StudyTable`); ``thesis-rbd study`` is the same on the command line, and
writes the table, its page and the records that let an interrupted study resume (:mod:`.folder`).
"""

from thesis_rbd.studies.grid import VARIABLE_SETTINGS, StudyError
from thesis_rbd.studies.measures import MEASURES, UNITS
from thesis_rbd.studies.run import study
from thesis_rbd.studies.table import TIMING_COLUMNS, Recommendation, StudyTable

__all__ = [
    "MEASURES",
    "TIMING_COLUMNS",
    "UNITS",
    "VARIABLE_SETTINGS",
    "Recommendation",
    "StudyError",
    "StudyTable",
    "study",
]
