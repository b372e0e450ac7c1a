"""Collision detection: OBBTree narrow phase, sweep-and-prune broad phase, contact reports,
and the queries beyond overlap (distance, continuous collision, rays, pose batches)."""

from thesis_rbd.collision.broad_phase.sap import SweepAndPrune
from thesis_rbd.collision.mesh.contact_report import Contacts
from thesis_rbd.collision.mesh.obbtree import OBBTree
from thesis_rbd.collision.queries.batch import collide_batch, distance_batch
from thesis_rbd.collision.queries.collide import CollisionResult, collide
from thesis_rbd.collision.queries.continuous import ContinuousResult, continuous_collide
from thesis_rbd.collision.queries.distance import DistanceResult, distance
from thesis_rbd.collision.queries.ray import RayHits, ray_cast

__all__ = [
    "CollisionResult",
    "Contacts",
    "ContinuousResult",
    "DistanceResult",
    "OBBTree",
    "RayHits",
    "SweepAndPrune",
    "collide",
    "collide_batch",
    "continuous_collide",
    "distance",
    "distance_batch",
    "ray_cast",
]
