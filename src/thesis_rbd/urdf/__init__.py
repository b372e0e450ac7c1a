"""Robots and mechanisms from URDF and MJCF files: ``load_urdf`` and ``load_mjcf`` build a
file's links and joints into a ``World`` and return a ``Robot``, its joint-space view. URDF is
parsed by yourdfpy (``pip install thesis_rbd[urdf]``), MJCF compiled by the ``mujoco``
package; both are optional."""

from thesis_rbd.urdf.loader import load_urdf
from thesis_rbd.urdf.mjcf import load_mjcf
from thesis_rbd.urdf.robot import Robot

__all__ = ["Robot", "load_mjcf", "load_urdf"]
