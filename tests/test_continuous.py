"""continuous_collide() against densely sampled poses and a brute-force distance."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from reference import MESH_KINDS, examples, random_mesh, random_pose
from reference_queries import brute_force_distance, interpolated_pose

import thesis_rbd as rbd

SAMPLES = 161


def _first_sampled_contact(tree_a, motion_a, tree_b, motion_b):
    """Time of the first contact (``collide``) among evenly sampled poses, refined by
    bisection to 1e-6; None if no sample touches."""

    def touching(t):
        return rbd.collide(
            tree_a, interpolated_pose(*motion_a, t), tree_b, interpolated_pose(*motion_b, t)
        ).colliding

    times = np.linspace(0.0, 1.0, SAMPLES)
    for k, t in enumerate(times):
        if touching(t):
            if k == 0:
                return 0.0
            lo, hi = times[k - 1], t
            while hi - lo > 1e-6:
                mid = 0.5 * (lo + hi)
                lo, hi = (lo, mid) if touching(mid) else (mid, hi)
            return hi
    return None


def _crossing_motion(seed, size):
    """A motion of B through A's neighbourhood: from one side to the other, turning."""
    rng = np.random.default_rng(seed)
    side = rng.normal(size=3)
    side /= np.linalg.norm(side)
    start = random_pose(seed, 0.0)
    end = random_pose(seed + 1, 0.0)
    start[:3, 3] = 1.6 * size * side + rng.normal(size=3) * 0.3 * size
    end[:3, 3] = -1.6 * size * side + rng.normal(size=3) * 0.3 * size
    return start, end


@settings(max_examples=examples(20))
@given(
    kind_a=st.sampled_from(MESH_KINDS),
    kind_b=st.sampled_from(MESH_KINDS),
    seed=st.integers(0, 2**31),
    a_moves=st.booleans(),
)
def test_first_contact_is_never_later_than_the_sampled_one(kind_a, kind_b, seed, a_moves):
    mesh_a = random_mesh(kind_a, seed)
    mesh_b = random_mesh(kind_b, seed + 1)
    size = max(mesh_a.scale, mesh_b.scale)
    tree_a = rbd.OBBTree(mesh_a)
    tree_b = rbd.OBBTree(mesh_b)
    motion_a = (random_pose(seed + 2, 0.1 * size), random_pose(seed + 3, 0.1 * size))
    if not a_moves:
        motion_a = (motion_a[0], motion_a[0])
    motion_b = _crossing_motion(seed + 4, size)
    res = rbd.continuous_collide(tree_a, *motion_a, tree_b, *motion_b)
    sampled = _first_sampled_contact(tree_a, motion_a, tree_b, motion_b)
    if sampled is not None:
        assert res.colliding
        assert res.time <= sampled + 1e-6
    if not res.colliding:
        assert res.time == 1.0
        return
    pose_a = interpolated_pose(*motion_a, res.time)
    pose_b = interpolated_pose(*motion_b, res.time)
    np.testing.assert_allclose(res.poses[0], pose_a, atol=1e-9 * size)
    np.testing.assert_allclose(res.poses[1], pose_b, atol=1e-9 * size)
    assert brute_force_distance(mesh_a, pose_a, mesh_b, pose_b) <= 1e-9 * size


def test_translating_boxes_meet_at_the_analytic_time():
    tree = rbd.OBBTree(rbd.shapes.box((1.0, 1.0, 1.0)))
    start = np.eye(4)
    start[0, 3] = 3.0
    end = np.eye(4)
    end[0, 3] = -3.0
    res = rbd.continuous_collide(tree, np.eye(4), np.eye(4), tree, start, end)
    # Faces meet when B's centre reaches x = 1: t = 2 / 6.
    assert res.colliding
    assert 1 / 3 - 1e-9 <= res.time <= 1 / 3
    assert res.distance <= 1e-9 * tree.scale
    assert res.poses[1][0, 3] == pytest.approx(1.0, abs=1e-8)


def test_turning_bar_hits_a_post_at_the_analytic_angle():
    # A bar of half-length 1 (thin) turns about z; a post at (0, 0.5) in its way is first
    # touched when the bar's upper face reaches the post's corner.
    bar = rbd.OBBTree(rbd.shapes.box((2.0, 0.02, 0.1)))
    post = rbd.OBBTree(rbd.shapes.box((0.1, 0.1, 1.0)))
    T_post = np.eye(4)
    T_post[:3, 3] = (0.0, 0.5, 0.0)
    turned = np.eye(4)
    c, s = np.cos(np.pi / 2), np.sin(np.pi / 2)
    turned[:2, :2] = [[c, -s], [s, c]]
    res = rbd.continuous_collide(bar, np.eye(4), turned, post, T_post, T_post)
    assert res.colliding
    # The bar's leading face y' = 0.01 (its frame) first touches the post's corner
    # (0.05, 0.45), whose y' is 0.45 cos(a) - 0.05 sin(a) = r cos(a + phi).
    r = np.hypot(0.45, 0.05)
    angle = np.arccos(0.01 / r) - np.arctan2(0.05, 0.45)
    assert res.time * np.pi / 2 == pytest.approx(angle, abs=1e-7)
    assert res.time * np.pi / 2 <= angle + 1e-12


def test_missing_motion_reports_no_contact_and_the_end_poses():
    tree = rbd.OBBTree(rbd.shapes.icosphere(0.5, 2))
    start = np.eye(4)
    start[:3, 3] = (3.0, 2.0, 0.0)
    end = np.eye(4)
    end[:3, 3] = (-3.0, 2.0, 0.0)
    res = rbd.continuous_collide(tree, np.eye(4), np.eye(4), tree, start, end)
    assert not res.colliding and res.time == 1.0
    np.testing.assert_allclose(res.poses[1], end, atol=1e-12)
    assert res.distance == pytest.approx(np.sqrt(13.0) - 1.0, abs=0.02)  # at the end pose


def test_contact_at_the_start_is_time_zero():
    tree = rbd.OBBTree(rbd.shapes.icosphere(0.5, 1))
    res = rbd.continuous_collide(tree, np.eye(4), np.eye(4), tree, np.eye(4), random_pose(1, 4))
    assert res.colliding and res.time == 0.0 and res.steps == 1


def test_stacks_equal_single_motions():
    mesh = random_mesh("torus", 2)
    tree = rbd.OBBTree(mesh)
    starts, ends = zip(*(_crossing_motion(40 + 3 * k, mesh.scale) for k in range(5)), strict=True)
    starts = np.stack(starts)
    ends = np.stack(ends)
    res = rbd.continuous_collide(tree, np.eye(4), np.eye(4), tree, starts, ends)
    assert res.time.shape == (5,) and res.poses.shape == (5, 2, 4, 4)
    for k in range(5):
        one = rbd.continuous_collide(tree, np.eye(4), np.eye(4), tree, starts[k], ends[k])
        assert one.colliding == res.colliding[k] and one.time == res.time[k]
        np.testing.assert_array_equal(one.poses, res.poses[k])


def test_bad_arguments_raise_naming_them():
    tree = rbd.OBBTree(rbd.shapes.box())
    I = np.eye(4)
    with pytest.raises(ValueError, match="T_a1"):
        rbd.continuous_collide(tree, I, np.diag([1.0, 2.0, 1.0, 1.0]), tree, I, I)
    with pytest.raises(ValueError, match="T_b0"):
        rbd.continuous_collide(tree, I, I, tree, np.full((4, 4), np.nan), I)
    with pytest.raises(ValueError, match="tolerance"):
        rbd.continuous_collide(tree, I, I, tree, I, I, tolerance=-1.0)
    with pytest.raises(ValueError, match="length"):
        rbd.continuous_collide(tree, np.stack([I] * 2), I, tree, np.stack([I] * 3), I)
    with pytest.raises(ValueError, match="OBBTree"):
        rbd.continuous_collide(tree.mesh, I, I, tree, I, I)
