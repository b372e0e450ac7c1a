"""Collision detection: OBBTree narrow phase, sweep-and-prune broad phase, contact reports,
and the queries beyond overlap (distance, continuous collision, rays, pose batches)."""

from thesis_rbd.collision.batch import collide_batch, distance_batch
from thesis_rbd.collision.collide import CollisionResult, collide
from thesis_rbd.collision.contacts import Contacts
from thesis_rbd.collision.continuous import ContinuousResult, continuous_collide
from thesis_rbd.collision.distance import DistanceResult, distance
from thesis_rbd.collision.obbtree import OBBTree
from thesis_rbd.collision.ray import RayHits, ray_cast
from thesis_rbd.collision.sap import SweepAndPrune

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
