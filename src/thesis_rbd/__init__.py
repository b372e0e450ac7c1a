"""thesis_rbd: validated rigid-body simulation in Python.

Collision detection after the JAOC design (sweep-and-prune broad phase, OBBTree narrow phase,
exact contact report) and quaternion rigid-body dynamics, cross-checked against python-fcl and
pybullet. Public names only; the contract is docs/design.md.
"""

from thesis_rbd import scenes, spatial
from thesis_rbd.collision import (
    CollisionResult,
    Contacts,
    ContinuousResult,
    DistanceResult,
    OBBTree,
    RayHits,
    collide,
    collide_batch,
    continuous_collide,
    distance,
    distance_batch,
    ray_cast,
)
from thesis_rbd.collision.broad_phase.sap import SweepAndPrune
from thesis_rbd.geometry import MassProperties, TriangleMesh, load_mesh, mass_properties, shapes
from thesis_rbd.scene import Scene, SceneError, load_scene
from thesis_rbd.studies import StudyError, StudyTable, study
from thesis_rbd.trajectory import Trajectory, simulate
from thesis_rbd.urdf import Robot, load_mjcf, load_urdf
from thesis_rbd.world import NonFiniteStateError, World

__all__ = [
    "CollisionResult",
    "Contacts",
    "ContinuousResult",
    "DistanceResult",
    "MassProperties",
    "NonFiniteStateError",
    "OBBTree",
    "RayHits",
    "Robot",
    "Scene",
    "SceneError",
    "StudyError",
    "StudyTable",
    "SweepAndPrune",
    "Trajectory",
    "TriangleMesh",
    "World",
    "collide",
    "collide_batch",
    "continuous_collide",
    "distance",
    "distance_batch",
    "load_mesh",
    "load_mjcf",
    "load_scene",
    "load_urdf",
    "mass_properties",
    "ray_cast",
    "scenes",
    "shapes",
    "simulate",
    "spatial",
    "study",
]

__version__ = "0.1.0"
