"""Shared test configuration.

Hypothesis deadlines are off: the first call of a numba kernel compiles it (or loads it from
the cache), which would otherwise count as a slow example. Example counts stay moderate so the
default run fits in ~10 minutes on two cores; set HYPOTHESIS_PROFILE=thorough for a long soak.
"""

import os

from hypothesis import HealthCheck, settings

settings.register_profile(
    "default", deadline=None, max_examples=60, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile(
    "thorough", deadline=None, max_examples=2000, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))
