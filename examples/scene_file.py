"""Scenes as TOML files: write one, load it, change its world, run it, save and reload the run.

python examples/scene_file.py [SECONDS] [FOLDER]
"""

import sys
import tempfile
from pathlib import Path

import thesis_rbd as rbd

seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 3.0
folder = Path(sys.argv[2]) if len(sys.argv) > 2 else Path(tempfile.mkdtemp())

path = folder / "spinners.toml"
path.write_text(
    """
description = "Three shapes spinning in place, one of them pushed off-centre"
seconds = 3.0

[world]
dt = 0.004166666666666667
integrator = "rk4"
angular_drag = 0.05

[[body]]
name = "ring"
shape = { type = "torus", major_radius = 1.0, minor_radius = 0.3 }
mass = 2.0
position = [-3.0, 0.0, 0.0]
angular_velocity = [0.0, 0.0, 3.0]

[[body]]
name = "can"
shape = { type = "cylinder", radius = 0.5, height = 1.5 }
density = 1000.0
angular_velocity = [4.0, 0.0, 0.0]

[[body]]
name = "ball"
shape = { type = "icosphere", radius = 0.6, subdivisions = 3 }
mass = 1.0
position = [3.0, 0.0, 0.0]

[[body.force]]
force = [0.0, 5.0, 0.0]
point = [3.0, 0.0, 0.6]
duration = 0.5
"""
)

scene = rbd.load_scene(path)
print(f"{scene.name}: {scene.summary}")
for body in scene.bodies:
    print(f"  {body.name}: {body.shape['type']} with {len(body.mesh.faces)} faces")

world = scene.with_world(integrator="symplectic_euler").build()
print(f"stages: {' -> '.join(world.stages)}")
trajectory = rbd.simulate(world, seconds)
trajectory.save(folder / "spinners.npz")
again = rbd.Trajectory.load(folder / "spinners.npz")
print(f"saved and reloaded {again}")
for name, position in zip(again.names, again.positions[-1], strict=True):
    print(f"  {name} ends at {position.round(3)}")
