"""A bouncing ball: each apex is e^2 of the one before (restitution e = 0.8, floor 1.0).

Runs the built-in scene, finds the apexes of the ball's lowest point (where it stops rising),
prints each apex height and its ratio to the previous one against e^2 = 0.64, and writes a
playback page with the contact points drawn.

    python examples/bouncing_ball.py [SECONDS] [FOLDER]
"""

import sys
from pathlib import Path

import numpy as np

import thesis_rbd as rbd
from thesis_rbd.viz import write_html

seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 4.0
page = Path(sys.argv[2] if len(sys.argv) > 2 else ".") / "bouncing_ball.html"

scene = rbd.scenes.get("bouncing_ball")
world = scene.build()
ball = world.names.index("ball")
floor = world.names.index("floor")
restitution = float(world.bodies.restitution[ball] * world.bodies.restitution[floor])
radius = 0.5
trajectory = rbd.simulate(world, seconds, record_contacts=True)

# the lowest point of the ball above the floor's top face (z = 0); an apex is a frame where it
# stops rising; the first frame is the drop height
height = trajectory.positions[:, ball, 2] - radius
rising = np.diff(height) > 0
apex_frames = np.flatnonzero(rising[:-1] & ~rising[1:]) + 1
apexes = np.concatenate([[height[0]], height[apex_frames]])
apexes = apexes[apexes > 1e-3]  # below 1 mm the ball is resting, not bouncing

print(scene.summary)
print(f"restitution e = {restitution:g}, e^2 = {restitution**2:g}")
print(f"{'apex':>4} {'t (s)':>7} {'height (m)':>11} {'ratio':>7} {'ratio / e^2':>12}")
times = np.concatenate([[trajectory.times[0]], trajectory.times[apex_frames]])
for number in range(len(apexes)):
    if number == 0:
        print(f"{number:>4} {times[number]:>7.3f} {apexes[number]:>11.4f}")
        continue
    ratio = apexes[number] / apexes[number - 1]
    print(
        f"{number:>4} {times[number]:>7.3f} {apexes[number]:>11.4f} {ratio:>7.4f} "
        f"{ratio / restitution**2:>12.4f}"
    )
print(f"{len(trajectory.contact_points)} contact points recorded over {len(trajectory)} frames")

trajectory.metadata.update(scene=scene.name, summary=scene.summary)
write_html(trajectory, page)
print(f"wrote {page}")
