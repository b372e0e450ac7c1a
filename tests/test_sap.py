"""Sweep-and-prune broad phase against the brute-force oracle of reference_broad_phase.py."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from reference_broad_phase import BroadPhaseOracle, brute_force_pairs

import thesis_rbd as rbd
from thesis_rbd._pair_keys import keys_to_pairs, unordered_pair_key
from thesis_rbd.collision.broad_phase import pair_table
from thesis_rbd.collision.broad_phase._sap_grid import choose_grid, compute_cells
from thesis_rbd.collision.broad_phase.sap import SweepAndPrune

# ---------------------------------------------------------------- helpers


def _configured(variant: str) -> SweepAndPrune:
    """A broad phase forced down one code path; all must give identical results."""
    if variant == "tiny_budget":
        # Falls back to a full re-sort in the middle of nearly every frame.
        sap = SweepAndPrune()
        sap._swap_budget = lambda: 3
        sap._prediction_margin = np.inf  # never skip the insertion sort up front
        return sap
    if variant == "fine_grid":
        # Cells as small as a box edge and one box per column: boxes span several columns,
        # share several with their partners and move between them every frame.
        sap = SweepAndPrune()
        sap._grid_options = {"cell_edges": 0.5, "boxes_per_column": 0.01}
        return sap
    if variant == "tiny_log":
        # Parks and resumes the insertion sort after every logged transition.
        sap = SweepAndPrune("incremental")
        sap._log_capacity = 1
        return sap
    return SweepAndPrune(variant)


VARIANTS = ["auto", "incremental", "full", "tiny_budget", "tiny_log", "fine_grid"]


def _assert_same(got, want, what):
    assert got.dtype == np.int64 and got.ndim == 2 and got.shape[1] == 2, what
    np.testing.assert_array_equal(got, want, err_msg=what)


def _check_frame(sap, oracle, before, added, removed, want_added, want_removed):
    _assert_same(added, want_added, "added")
    _assert_same(removed, want_removed, "removed")
    _assert_same(sap.pairs, oracle.sorted(), "pairs")
    # The event identity itself: pairs(t) = pairs(t-1) + added - removed.
    rows = {tuple(p) for p in before.tolist()}
    assert rows.issuperset(tuple(p) for p in removed.tolist())
    assert rows.isdisjoint(tuple(p) for p in added.tolist())
    rows = (rows - {tuple(p) for p in removed.tolist()}) | {tuple(p) for p in added.tolist()}
    assert rows == {tuple(p) for p in sap.pairs.tolist()}
    sap._check_invariants()


# ---------------------------------------------------------------- scenes for hypothesis

# Coordinates on a coarse lattice make exact ties (touching faces, equal endpoints, identical
# boxes, zero extents) the common case rather than a measure-zero accident.
LATTICE = 0.5


@st.composite
def scenes(draw):
    """(variant, offset, ulp_mode, initial boxes, list of operations)."""
    variant = draw(st.sampled_from(VARIANTS))
    # Near 1e6 a lattice step of 0.5 is still exact; "ulp" moves by single ulps there instead.
    offset = draw(st.sampled_from([0.0, -3.0, 1.0e6]))
    ulp = offset == 1.0e6 and draw(st.booleans())
    n = draw(st.integers(0, 24))
    cells = st.integers(0, 8)
    centre = draw(st.lists(st.tuples(cells, cells, cells), min_size=n, max_size=n))
    half = draw(st.lists(st.tuples(*[st.integers(0, 2)] * 3), min_size=n, max_size=n))
    ops = []
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(["move", "move", "move", "add", "remove"]))
        if kind == "move":
            ops.append(
                ("move", draw(st.integers(0, 2**31)), draw(st.sampled_from([0.0, 0.1, 0.5, 1.0])))
            )
        elif kind == "add":
            ops.append(("add", draw(st.integers(0, 2**31)), draw(st.integers(0, 4))))
        else:
            ops.append(("remove", draw(st.integers(0, 2**31)), draw(st.integers(0, 3))))
    return variant, offset, ulp, np.array(centre, float).reshape(-1, 3), half, ops


def _bounds(centre, half, offset, ulp):
    centre = np.asarray(centre, float).reshape(-1, 3)
    half = np.asarray(half, float).reshape(-1, 3)
    if ulp:
        # Steps of one ulp at 1e6: exercise comparisons where rounding would be visible.
        base = np.full(centre.shape, offset)
        lower = base + (centre - half) * np.spacing(offset)
        upper = base + (centre + half) * np.spacing(offset)
    else:
        lower = offset + (centre - half) * LATTICE
        upper = offset + (centre + half) * LATTICE
    return lower, upper


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenes())
def test_matches_brute_force_over_random_motion(scene):
    variant, offset, ulp, centre, half, ops = scene
    half = np.array(half, float).reshape(-1, 3)
    sap = _configured(variant)
    oracle = BroadPhaseOracle()
    lower, upper = _bounds(centre, half, offset, ulp)
    before = sap.pairs.copy()
    added, removed = sap.update(lower, upper)
    want = oracle.update(lower, upper)
    _check_frame(sap, oracle, before, added, removed, *want)
    assert removed.shape == (0, 2)
    for kind, seed, amount in ops:
        rng = np.random.default_rng(seed)
        before = sap.pairs.copy()
        n = centre.shape[0]
        if kind == "move":
            # Small lattice steps for every box, and a fraction `amount` teleporting anywhere.
            centre = centre + rng.integers(-1, 2, size=centre.shape)
            jump = rng.random(n) < amount
            centre[jump] = rng.integers(0, 9, size=(int(jump.sum()), 3))
            lower, upper = _bounds(centre, half, offset, ulp)
            added, removed = sap.update(lower, upper)
            want = oracle.update(lower, upper)
            _check_frame(sap, oracle, before, added, removed, *want)
        elif kind == "add":
            new_c = rng.integers(0, 9, size=(amount, 3)).astype(float)
            new_h = rng.integers(0, 3, size=(amount, 3)).astype(float)
            lo, hi = _bounds(new_c, new_h, offset, ulp)
            ids, added = sap.add(lo, hi)
            want_ids, want_added = oracle.add(lo, hi)
            np.testing.assert_array_equal(ids, want_ids)
            _check_frame(sap, oracle, before, added, np.empty((0, 2), np.int64), want_added,
                         np.empty((0, 2), np.int64))  # fmt: skip
            centre = np.concatenate([centre, new_c])
            half = np.concatenate([half, new_h])
        else:
            gone = rng.choice(n, size=min(amount, n), replace=False)
            removed = sap.remove(gone)
            want_removed = oracle.remove(gone)
            _assert_same(removed, want_removed, "removed by remove()")
            _assert_same(sap.pairs, oracle.sorted(), "pairs after remove()")
            sap._check_invariants()
            keep = np.setdiff1d(np.arange(n), gone)
            centre, half = centre[keep], half[keep]
        assert len(sap) == centre.shape[0]


# ---------------------------------------------------------------- larger scenes


@pytest.mark.parametrize("offset", [0.0, 1.0e6])
def test_thousands_of_boxes_with_teleports(offset):
    rng = np.random.default_rng(7)
    n = 1500
    centre = rng.uniform(0, 30, (n, 3))
    half = rng.uniform(0, 0.8, (n, 3))
    half[::50] = 0.0  # points
    sap = SweepAndPrune()
    oracle = BroadPhaseOracle()
    used_full = used_incremental = False
    for frame in range(12):
        # Frames 4 and 9 teleport half the boxes: the automatic fallback must kick in there.
        if frame in (4, 9):
            jump = rng.random(n) < 0.5
            centre[jump] = rng.uniform(0, 30, (int(jump.sum()), 3))
        else:
            centre += rng.normal(0, 0.05, centre.shape)
        lower, upper = offset + centre - half, offset + centre + half
        before = sap.pairs.copy()
        added, removed = sap.update(lower, upper)
        _check_frame(sap, oracle, before, added, removed, *oracle.update(lower, upper))
        if frame > 0:
            used_full |= sap.stats["full_resort"]
            used_incremental |= not sap.stats["full_resort"]
        if frame in (4, 9):
            assert sap.stats["full_resort"], sap.stats
    assert used_full and used_incremental


@pytest.mark.parametrize("seed", [0, 1])
def test_grid_columns_match_brute_force(seed):
    """Many columns: boxes spanning several, pairs sharing several, boxes crossing cells."""
    rng = np.random.default_rng(seed)
    n = 300
    centre = rng.uniform(0, 12, (n, 3))
    half = rng.uniform(0.05, 0.6, (n, 3))
    half[:3] = 3.0  # a few boxes across many columns
    centre[3:9] = np.round(centre[3:9])  # bounds on cell boundaries (cells of 0.5 here)
    sap = SweepAndPrune()
    sap._grid_options = {"cell_edges": 0.5, "boxes_per_column": 0.5}
    oracle = BroadPhaseOracle()
    incremental = 0
    for frame in range(16):
        centre += rng.normal(0, 0.15, centre.shape)  # crosses a cell boundary every few frames
        lower, upper = centre - half, centre + half
        before = sap.pairs.copy()
        added, removed = sap.update(lower, upper)
        _check_frame(sap, oracle, before, added, removed, *oracle.update(lower, upper))
        incremental += not sap.stats["full_resort"]
        if frame == 0:
            assert (sap._grid[:, 2] > 4).all()
            spans = sap._rng[:, :, [1, 3]] - sap._rng[:, :, [0, 2]]
            assert (spans.max(axis=2) > 0).mean() > 0.3  # many boxes in several columns
        if frame % 5 == 4:
            before = sap.pairs.copy()
            new_c = rng.uniform(0, 12, (5, 3))
            new_h = rng.uniform(0.05, 0.6, (5, 3))
            ids, got = sap.add(new_c - new_h, new_c + new_h)
            want_ids, want = oracle.add(new_c - new_h, new_c + new_h)
            np.testing.assert_array_equal(ids, want_ids)
            _assert_same(got, want, "added by add()")
            sap._check_invariants()
            centre = np.concatenate([centre, new_c])
            half = np.concatenate([half, new_h])
            gone = rng.choice(len(sap), size=4, replace=False)
            _assert_same(sap.remove(gone), oracle.remove(gone), "removed by remove()")
            sap._check_invariants()
            keep = np.setdiff1d(np.arange(centre.shape[0]), gone)
            centre, half = centre[keep], half[keep]
    assert incremental >= 12


def test_grid_coarsens_when_boxes_span_too_many_columns():
    rng = np.random.default_rng(2)
    n = 4000
    centre = rng.uniform(0, 60, (n, 3))
    half = rng.uniform(0.25, 0.75, (n, 3))
    box = np.empty((n, 6))
    box[:, 0::2], box[:, 1::2] = centre - half, centre + half
    grid, cells = choose_grid(box)
    assert (grid[:, 2] > 1).all()
    np.testing.assert_array_equal(cells, compute_cells(box, grid))
    # Half the boxes as large as the scene: listed in every column unless the grid coarsens.
    box[: n // 2, 0::2] = 0.0
    box[: n // 2, 1::2] = 60.0
    grid, cells = choose_grid(box)
    spans = (cells[:, 1::2] - cells[:, 0::2] + 1).astype(float)
    per_axis = (spans[:, [1, 2, 0]] * spans[:, [2, 0, 1]]).sum(axis=0)
    assert per_axis.max() <= 2.0 * n


def test_identical_and_degenerate_boxes():
    lower = np.array([[0, 0, 0], [0, 0, 0], [0, 0, 0], [1, 1, 1], [1, 0, 0], [2, 2, 2]], float)
    upper = np.array([[1, 1, 1], [1, 1, 1], [0, 0, 0], [1, 1, 1], [2, 1, 1], [3, 3, 3]], float)
    sap = SweepAndPrune()
    added, removed = sap.update(lower, upper)
    want = brute_force_pairs(lower, upper)
    np.testing.assert_array_equal(added, want)
    assert removed.shape == (0, 2)
    np.testing.assert_array_equal(sap.pairs, want)
    # Identical unit boxes 0 and 1, the point box 2 at their corner, the point 3 at the far
    # corner, box 4 sharing a face with 0 and 1: all touch, so all overlap (closed intervals).
    assert {(0, 1), (0, 2), (1, 2), (0, 3), (1, 3), (0, 4), (1, 4), (3, 4)} <= set(
        map(tuple, sap.pairs.tolist())
    )
    assert (2, 5) not in set(map(tuple, sap.pairs.tolist()))


def test_touching_then_separating_by_one_ulp():
    lower = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    upper = np.array([[1.0, 1.0, 1.0], [2.0, 1.0, 1.0]])
    sap = SweepAndPrune()
    added, _ = sap.update(lower, upper)
    np.testing.assert_array_equal(added, [[0, 1]])
    lower[1, 0] = upper[1, 0] = np.nextafter(1.0, 2.0)
    upper[1, 0] = 2.0
    added, removed = sap.update(lower, upper)
    np.testing.assert_array_equal(removed, [[0, 1]])
    assert added.shape == (0, 2) and sap.pairs.shape == (0, 2)
    lower[1, 0] = 1.0
    added, removed = sap.update(lower, upper)
    np.testing.assert_array_equal(added, [[0, 1]])


# ---------------------------------------------------------------- API behaviour


def test_public_name_and_output_types():
    assert rbd.SweepAndPrune is SweepAndPrune
    sap = rbd.SweepAndPrune()
    added, removed = sap.update(np.zeros((0, 3)), np.zeros((0, 3)))
    for array in (added, removed, sap.pairs):
        assert array.shape == (0, 2) and array.dtype == np.int64
    assert len(sap) == 0
    added, removed = sap.update([[0, 0, 0], [5, 5, 5]], [[1, 1, 1], [6, 6, 6]])
    assert added.shape == (0, 2) and len(sap) == 2
    with pytest.raises(ValueError):
        sap.pairs[0:1] = 1  # read-only view of the state


def test_fallback_mid_frame_and_up_front():
    rng = np.random.default_rng(5)
    centre = rng.uniform(0, 20, (400, 3))
    oracle = BroadPhaseOracle()
    sap = _configured("tiny_budget")
    sap.update(centre - 0.5, centre + 0.5)
    oracle.update(centre - 0.5, centre + 0.5)
    centre += rng.normal(0, 0.05, centre.shape)
    before = sap.pairs.copy()
    added, removed = sap.update(centre - 0.5, centre + 0.5)
    # Abandoned after a few swaps, then rebuilt: still exact.
    assert sap.stats["full_resort"] and 3 < sap.stats["swaps"] < 20
    _check_frame(sap, oracle, before, added, removed, *oracle.update(centre - 0.5, centre + 0.5))
    sap = SweepAndPrune()
    sap.update(centre - 0.5, centre + 0.5)
    centre[:200] = rng.uniform(0, 20, (200, 3))
    before = sap.pairs.copy()
    added, removed = sap.update(centre - 0.5, centre + 0.5)
    # Half the boxes teleported: predicted far over budget, no insertion sort at all.
    assert sap.stats["full_resort"] and sap.stats["swaps"] == 0
    assert sap.stats["predicted_swaps"] > sap.stats["budget"]
    _check_frame(sap, oracle, before, added, removed, *oracle.update(centre - 0.5, centre + 0.5))


def test_coherent_frames_stay_incremental_and_count_swaps():
    rng = np.random.default_rng(1)
    centre = rng.uniform(0, 20, (500, 3))
    sap = SweepAndPrune()
    sap.update(centre - 0.5, centre + 0.5)
    assert sap.stats["full_resort"]  # the first frame is a full sort
    centre += rng.normal(0, 0.01, centre.shape)
    sap.update(centre - 0.5, centre + 0.5)
    assert not sap.stats["full_resort"]
    assert 0 < sap.stats["swaps"] < sap.stats["budget"]
    assert sap.stats["pairs"] == len(sap.pairs)


@pytest.mark.parametrize(
    ("lower", "upper", "message"),
    [
        ([[0, 0, 0], [1, 1, 1]], [[1, 1, 1], [0.5, 2, 2]], "lower > upper"),
        ([[0, 0, np.nan], [1, 1, 1]], [[1, 1, 1], [2, 2, 2]], "non-finite"),
        ([[0, 0, 0], [1, 1, 1]], [[1, 1, np.inf], [2, 2, 2]], "non-finite"),
        ([[0, 0, 0], [1, 1, 1]], [[1, 1, 1]], "same shape"),
        ([[0, 0], [1, 1]], [[1, 1], [2, 2]], "shape"),
        ([[0, 0, 0]], [[1, 1, 1]], "add\\(\\) or remove\\(\\)"),
        ([[0, 0, 0]] * 3, [[1, 1, 1]] * 3, "add\\(\\) or remove\\(\\)"),
        ("abc", [[1, 1, 1]], "numeric"),
    ],
)
def test_bad_input_raises_and_changes_nothing(lower, upper, message):
    sap = SweepAndPrune()
    sap.update([[0, 0, 0], [0.5, 0.5, 0.5]], [[1, 1, 1], [2, 2, 2]])
    state = (sap.pairs.copy(), sap.lower.copy(), sap.upper.copy(), sap._val.copy(), dict(sap.stats))
    for name in ("update", "add"):
        if name == "add" and "add" in message:
            continue  # add() takes any number of rows
        with pytest.raises(ValueError, match=message):
            getattr(sap, name)(lower, upper)
        np.testing.assert_array_equal(sap.pairs, state[0])
        np.testing.assert_array_equal(sap.lower, state[1])
        np.testing.assert_array_equal(sap.upper, state[2])
        np.testing.assert_array_equal(sap._val, state[3])
        assert sap.stats == state[4]
        sap._check_invariants()


@pytest.mark.parametrize("ids", [[2], [-1], [0, 0], [[0]], [0.5]])
def test_remove_rejects_bad_ids(ids):
    sap = SweepAndPrune()
    sap.update([[0, 0, 0], [0, 0, 0]], [[1, 1, 1], [1, 1, 1]])
    with pytest.raises(ValueError):
        sap.remove(ids)
    assert len(sap) == 2 and sap.pairs.tolist() == [[0, 1]]


def test_add_remove_contract():
    sap = SweepAndPrune()
    box = np.array([[0.0, 0.0, 0.0]]), np.array([[1.0, 1.0, 1.0]])
    ids, added = sap.add(*box)
    assert ids.tolist() == [0] and added.shape == (0, 2)
    ids, added = sap.add(np.repeat(box[0], 3, axis=0), np.repeat(box[1], 3, axis=0))
    assert ids.tolist() == [1, 2, 3]
    assert added.tolist() == [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]
    # The next update reports only what changed since add(), not add()'s pairs again.
    lower = np.zeros((4, 3))
    upper = np.ones((4, 3))
    upper[3] = lower[3] = 5.0
    added, removed = sap.update(lower, upper)
    assert added.shape == (0, 2)
    assert removed.tolist() == [[0, 3], [1, 3], [2, 3]]
    # remove() renumbers like np.delete and reports the lost pairs in the old numbering.
    removed = sap.remove([1])
    assert removed.tolist() == [[0, 1], [1, 2]]
    assert sap.pairs.tolist() == [[0, 1]] and len(sap) == 3
    np.testing.assert_array_equal(sap.lower, np.delete(lower, 1, axis=0))
    added, removed = sap.update(np.delete(lower, 1, axis=0), np.delete(upper, 1, axis=0))
    assert added.shape == removed.shape == (0, 2)
    assert sap.remove([]).shape == (0, 2)
    with pytest.raises(ValueError, match="strategy"):
        SweepAndPrune("bubble")


# ---------------------------------------------------------------- the pair table


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.booleans(), st.integers(0, 40), st.integers(0, 40)), max_size=300))
def test_pair_table_matches_a_set(operations):
    keys, flags, meta = pair_table.new_table(0)  # 16 slots: forces growth and wrap-around
    reference = set()
    for insert, i, j in operations:
        if i == j:
            continue
        key = unordered_pair_key(i, j)
        if insert:
            keys, flags, _ = pair_table.table_insert(keys, flags, meta, key, pair_table.IN_SET)
            reference.add(key)
        else:
            slot = pair_table.table_find(keys, key)
            assert (slot >= 0) == (key in reference)
            if slot >= 0:
                pair_table.table_delete(keys, flags, meta, slot)
                reference.discard(key)
        assert meta[0] == len(reference)
    assert sorted(keys[keys >= 0].tolist()) == sorted(reference)
    for key in reference:
        assert pair_table.table_find(keys, key) >= 0
    pairs = keys_to_pairs(np.array(sorted(reference), dtype=np.int64))
    assert all(i < j for i, j in pairs.tolist())
