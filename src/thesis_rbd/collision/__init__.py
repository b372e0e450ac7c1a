"""Collision detection: OBBTree narrow phase, sweep-and-prune broad phase, contact reports."""

from thesis_rbd.collision.sap import SweepAndPrune

__all__ = ["SweepAndPrune"]
