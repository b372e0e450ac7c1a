"""Your own shape: a mesh from vertices and faces, saved to a file, loaded back, and thrown.

Builds a closed triangular prism by hand, writes it as an OBJ (any format trimesh reads works:
STL, PLY, glTF...), loads it with ``rbd.load_mesh``, looks at its mass properties, and runs it
as a tumbling projectile. Then the same body is described in a TOML scene file that refers to
the mesh by a path relative to the scene, and run from there.

    python examples/custom_mesh.py [SECONDS] [FOLDER]
"""

import sys
import tempfile
from pathlib import Path

import numpy as np

import thesis_rbd as rbd
from thesis_rbd.viz import write_html

seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 2.0
folder = Path(sys.argv[2]) if len(sys.argv) > 2 else Path(tempfile.mkdtemp())

# a prism: a right triangle of legs 1 m extruded 2 m along z, faces counter-clockwise outside
vertices = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 2], [1, 0, 2], [0, 1, 2]]
faces = [
    [0, 2, 1], [3, 4, 5],             # bottom, top
    [0, 1, 4], [0, 4, 3],             # side y = 0
    [0, 3, 5], [0, 5, 2],             # side x = 0
    [1, 2, 5], [1, 5, 4],             # slanted side
]  # fmt: skip
prism = rbd.TriangleMesh(vertices, faces)
prism.to_trimesh().export(folder / "prism.obj")

mesh = rbd.load_mesh(folder / "prism.obj")
props = rbd.mass_properties(mesh, density=500.0)  # wood
print(f"volume {props.volume:.3f} m^3, mass {props.mass:.1f} kg")
print(f"centre of mass (mesh frame) {np.round(props.center_of_mass, 4)}")
print(f"inertia about it:\n{np.round(props.inertia, 3)}")

world = rbd.World(gravity=(0, 0, -9.81))
body = world.add_body(mesh, density=500.0, linear_velocity=(3, 0, 5), angular_velocity=(0, 4, 1))
trajectory = rbd.simulate(world, seconds, record_every=4)
print(f"after {seconds} s the prism's centre of mass is at {np.round(world.position(body), 3)}")

# the same, as a scene file beside the mesh
scene_file = folder / "prism.toml"
scene_file.write_text(
    """
description = "A wooden prism thrown end over end"
seconds = 2.0
[world]
gravity = [0.0, 0.0, -9.81]
[[body]]
name = "prism"
shape = { type = "mesh", path = "prism.obj" }
density = 500.0
linear_velocity = [3.0, 0.0, 5.0]
angular_velocity = [0.0, 4.0, 1.0]
"""
)
from_file = rbd.simulate(rbd.load_scene(scene_file).build(), seconds, record_every=4)
assert np.allclose(from_file.positions, trajectory.positions)
from_file.save(folder / "prism.npz")
write_html(from_file, folder / "prism.html")
print(f"wrote {folder / 'prism.npz'} and {folder / 'prism.html'}")
