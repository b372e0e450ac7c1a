"""Collision detection: OBBTree narrow phase, sweep-and-prune broad phase, contact reports."""
