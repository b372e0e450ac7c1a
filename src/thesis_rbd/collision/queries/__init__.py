"""Queries on two posed meshes, answered through their OBBTrees: collide, distance, ray casts,
continuous collision, and batches of poses in one call."""
