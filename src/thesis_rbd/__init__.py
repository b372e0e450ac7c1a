"""thesis_rbd: validated rigid-body simulation in Python.

Collision detection after the JAOC design (sweep-and-prune broad phase, OBBTree narrow phase,
exact contact report) and quaternion rigid-body dynamics, cross-checked against python-fcl and
pybullet. Public names only; see DESIGN.md for the contract.
"""

from thesis_rbd import spatial
from thesis_rbd.collision import CollisionResult, Contacts, OBBTree, collide
from thesis_rbd.collision.sap import SweepAndPrune
from thesis_rbd.geometry import MassProperties, TriangleMesh, load_mesh, mass_properties, shapes
from thesis_rbd.world import World

__all__ = [
    "CollisionResult",
    "Contacts",
    "MassProperties",
    "OBBTree",
    "SweepAndPrune",
    "TriangleMesh",
    "World",
    "collide",
    "load_mesh",
    "mass_properties",
    "shapes",
    "spatial",
]

__version__ = "0.1.0"
