"""The package's kernel sorts against numpy's: the same order, equal keys included."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from reference import examples

from thesis_rbd._sorting import sort_with_order, sorted_copy, stable_argsort, unique_sorted

# Few distinct values, so that most draws hold runs of equal keys (where stability shows),
# and lengths past the insertion-sorted runs (16) and several merge passes.
INTS = arrays(np.int64, st.integers(0, 200), elements=st.integers(-3, 3))
WIDE_INTS = arrays(np.int64, st.integers(0, 200), elements=st.integers(-(2**62), 2**62))
FLOATS = arrays(
    np.float64,
    st.integers(0, 200),
    elements=st.sampled_from([-np.inf, -1.5, -0.0, 0.0, 2.0, np.inf, np.nan]),
)


@settings(max_examples=examples(200))
@given(keys=st.one_of(INTS, WIDE_INTS, FLOATS))
def test_stable_argsort_is_numpys_stable_argsort(keys):
    order = np.argsort(keys, kind="stable")
    np.testing.assert_array_equal(stable_argsort(keys), order)
    ordered, with_order = sort_with_order(keys)
    np.testing.assert_array_equal(with_order, order)
    np.testing.assert_array_equal(ordered, keys[order])


@settings(max_examples=examples(100))
@given(keys=st.one_of(INTS, WIDE_INTS, FLOATS))
def test_sorted_copy_is_numpys_sort(keys):
    before = keys.copy()
    np.testing.assert_array_equal(sorted_copy(keys), np.sort(keys))
    np.testing.assert_array_equal(keys, before)  # the keys are left as they were


@settings(max_examples=examples(100))
@given(keys=st.one_of(INTS, WIDE_INTS))
def test_unique_sorted_is_numpys_unique(keys):
    np.testing.assert_array_equal(unique_sorted(keys), np.unique(keys))


def test_large_random_keys_match_numpy():
    keys = np.random.default_rng(0).integers(0, 1000, size=100_000)
    np.testing.assert_array_equal(stable_argsort(keys), np.argsort(keys, kind="stable"))
