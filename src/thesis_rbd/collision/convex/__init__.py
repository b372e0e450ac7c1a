"""The convex path: hulls as flat polyhedra, the separating-axis test (boxes in closed form,
GJK and EPA for many vertices), face-clipped manifolds, step-to-step coherence, and the world
narrow phase over convex body pairs."""
