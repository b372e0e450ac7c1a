"""Triangle meshes, primitive shapes and mass properties."""

from thesis_rbd.geometry import shapes
from thesis_rbd.geometry.mass import MassProperties, mass_properties
from thesis_rbd.geometry.mesh import TriangleMesh, load_mesh

__all__ = ["MassProperties", "TriangleMesh", "load_mesh", "mass_properties", "shapes"]
