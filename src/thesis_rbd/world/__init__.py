"""The world and its step: bodies, forces and the stages that advance them."""

from thesis_rbd.world.stage_names import STAGE_NAMES
from thesis_rbd.world.world import NonFiniteStateError, World

__all__ = ["STAGE_NAMES", "NonFiniteStateError", "World"]
