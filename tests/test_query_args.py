"""The in-kernel pose check of the collision queries against the Python validator."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference import examples, random_pose

import thesis_rbd as rbd
from thesis_rbd._validate import as_rigid_transform
from thesis_rbd.collision.queries._query_args import pose_ok

# Faults far from the tolerance (1e-6) on either side, so rounding cannot decide the answer.
FAULTS = [0.0, 1e-9, -1e-9, 1e-3, -0.5, 2.0, np.nan, np.inf, -np.inf]


def _accepted(T) -> bool:
    try:
        as_rigid_transform(T, "T")
    except ValueError:
        return False
    return True


@settings(max_examples=examples(300))
@given(
    seed=st.integers(0, 2**31),
    row=st.integers(0, 3),
    column=st.integers(0, 3),
    fault=st.sampled_from(FAULTS),
    mirrored=st.booleans(),
)
def test_pose_ok_accepts_exactly_what_the_validator_accepts(seed, row, column, fault, mirrored):
    """One entry of a random rigid transform disturbed (or a column flipped, a reflection):
    the kernel's branch-free check says what as_rigid_transform says."""
    T = random_pose(seed, 5.0)
    if mirrored:
        T[:3, 0] = -T[:3, 0]
    T[row, column] += fault
    assert pose_ok(T) == _accepted(T)


@settings(max_examples=examples(100))
@given(
    seed=st.integers(0, 2**31),
    columns=st.permutations([0, 1, 2]),
    lean=st.sampled_from([1e-9, 1e-3, 0.3]),
)
def test_pose_ok_checks_every_pair_of_rotation_columns(seed, columns, lean):
    """A column leant towards another and renormalised: unit columns that are not
    orthogonal, which only that pair's dot product shows."""
    T = random_pose(seed, 5.0)
    i, j = columns[0], columns[1]
    leant = T[:3, j] + lean * T[:3, i]
    T[:3, j] = leant / np.linalg.norm(leant)
    assert pose_ok(T) == _accepted(T)


def test_pose_ok_refuses_wrong_shapes():
    assert not pose_ok(np.eye(3))
    assert not pose_ok(np.eye(5))
    assert pose_ok(np.eye(4))


def test_tolerances_that_are_not_numbers_are_named():
    tree = rbd.OBBTree(rbd.shapes.box())
    identity = np.eye(4)
    with pytest.raises(ValueError, match="merge_tolerance must be a number, got 'x'"):
        rbd.collide(tree, identity, tree, identity, mode="contacts", merge_tolerance="x")
    with pytest.raises(ValueError, match="tolerance must be a number, got 'x'"):
        rbd.continuous_collide(tree, identity, identity, tree, identity, identity, tolerance="x")
