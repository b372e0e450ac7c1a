"""Shared test configuration.

Hypothesis deadlines are off: the first call of a numba kernel compiles it (or loads it from
the cache), which would otherwise count as a slow example. Example counts stay moderate so the
default run fits in ~10 minutes on two cores; set HYPOTHESIS_PROFILE=thorough for a long soak.
"""

import os
import tempfile

from hypothesis import HealthCheck, settings

# numba's on-disk cache is not safe for two processes writing the same kernel at once (numba
# issues 4807 and 10128: a process can load an entry another is writing, and crash), which is
# what two xdist workers compiling from an empty cache do: each worker gets its own cache,
# below NUMBA_CACHE_DIR if one is set. This runs before any test module imports numba.
_worker = os.environ.get("PYTEST_XDIST_WORKER")
if _worker:
    _base = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(
        tempfile.gettempdir(), "thesis_rbd-numba-cache"
    )
    os.environ["NUMBA_CACHE_DIR"] = os.path.join(_base, _worker)

settings.register_profile(
    "default", deadline=None, max_examples=60, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile(
    "thorough", deadline=None, max_examples=2000, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))
