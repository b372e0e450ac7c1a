"""Robots and mechanisms from URDF files: ``load_urdf`` builds a file's links and joints into
a ``World`` and returns a ``Robot``, its joint-space view. Parsing goes through yourdfpy, an
optional dependency (``pip install thesis_rbd[urdf]``)."""

from thesis_rbd.urdf.loader import load_urdf
from thesis_rbd.urdf.robot import Robot

__all__ = ["Robot", "load_urdf"]
