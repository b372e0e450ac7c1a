"""The Dzhanibekov effect: a box spun about its intermediate axis turns over, again and again.

Runs the built-in scene, finds the flips (the spin axis reversing its direction), checks that
energy and angular momentum are conserved, and writes a playback page.

    python examples/dzhanibekov.py [SECONDS] [FOLDER]
"""

import sys
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

import thesis_rbd as rbd
from thesis_rbd.viz import write_html

seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 12.0
page = Path(sys.argv[2] if len(sys.argv) > 2 else ".") / "dzhanibekov.html"

scene = rbd.scenes.get("dzhanibekov")
world = scene.build()
energy, momentum = world.kinetic_energy(), world.angular_momentum(0)
trajectory = rbd.simulate(world, seconds)

# the body's y axis (the spin axis) in the world: its y component changes sign at each flip
spin_axis = Rotation.from_quat(trajectory.orientations[:, 0]).apply([0.0, 1.0, 0.0])
flips = trajectory.times[np.flatnonzero(np.diff(np.sign(spin_axis[:, 1])))]
print(f"{scene.summary}\nflips at t = {np.round(flips, 2).tolist()} s")
print(f"relative energy drift: {abs(world.kinetic_energy() - energy) / energy:.1e}")
print(f"angular momentum drift: {np.linalg.norm(world.angular_momentum(0) - momentum):.1e}")

trajectory.metadata["scene"] = scene.name
write_html(trajectory, page)
print(f"wrote {page}")
