"""Island labelling against a plain breadth-first search over the contact graph."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from thesis_rbd.dynamics.islands import find_islands


def reference_components(n, body_a, body_b, static):
    """Connected components of dynamic bodies, as a set of frozensets (static bodies cut)."""
    neighbours = {i: set() for i in range(n)}
    for a, b in zip(body_a, body_b, strict=True):
        if not static[a] and not static[b]:
            neighbours[a].add(b)
            neighbours[b].add(a)
    seen, components = set(), set()
    for start in range(n):
        if static[start] or start in seen:
            continue
        stack, component = [start], set()
        while stack:
            i = stack.pop()
            if i in component:
                continue
            component.add(i)
            stack.extend(neighbours[i] - component)
        seen |= component
        components.add(frozenset(component))
    return components


@given(st.integers(0, 10**6), st.integers(1, 30), st.integers(0, 60))
def test_islands_match_breadth_first_search(seed, n, c):
    rng = np.random.default_rng(seed)
    static = rng.random(n) < 0.2
    body_a = rng.integers(0, n, c)
    body_b = (body_a + rng.integers(1, max(n, 2), c)) % max(n, 1)
    keep = body_a != body_b
    body_a, body_b = body_a[keep].astype(np.int64), body_b[keep].astype(np.int64)
    keep = ~(static[body_a] & static[body_b])
    body_a, body_b = body_a[keep], body_b[keep]
    body_island, order, start = find_islands(n, body_a, body_b, static)

    assert np.all(body_island[static] == -1)
    assert sorted(order.tolist()) == list(range(len(body_a)))
    # bodies share an island label exactly when they are connected
    expected = reference_components(n, body_a, body_b, static)
    for component in expected:
        labels = {body_island[i] for i in component}
        assert len(labels) == 1
    labelled = [frozenset(np.flatnonzero(body_island == i)) for i in range(len(start) - 1)]
    assert set(labelled) <= expected
    # every contact sits in the island of its dynamic body
    for i in range(len(start) - 1):
        for k in order[start[i] : start[i + 1]]:
            a, b = body_a[k], body_b[k]
            assert body_island[a if not static[a] else b] == i
