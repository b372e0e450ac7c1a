"""Collision detection: OBBTree narrow phase, sweep-and-prune broad phase, contact reports."""

from thesis_rbd.collision.collide import CollisionResult, collide
from thesis_rbd.collision.contacts import Contacts
from thesis_rbd.collision.distance import DistanceResult, distance
from thesis_rbd.collision.obbtree import OBBTree
from thesis_rbd.collision.sap import SweepAndPrune

__all__ = [
    "CollisionResult",
    "Contacts",
    "DistanceResult",
    "OBBTree",
    "SweepAndPrune",
    "collide",
    "distance",
]
