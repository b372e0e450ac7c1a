"""The thesis's example of use (section 6.2), in Python.

Two unit boxes of mass 10; the second is pushed by (2, 0, 0) N for one second and turned
1 rad about (-1, -2, 0). The Java original loops ``sim.update()`` forever; here the loop runs
for a given time and prints where the boxes are: box2 reaches box1 at about 4.7 s and the
contact response sets both moving together.

    python examples/thesis_example.py [SECONDS]
"""

import math
import sys

import numpy as np

import thesis_rbd as rbd

seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 8.0

# create the simulator object (no gravity: no effect is on unless asked for)
world = rbd.World(dt=1 / 240, integrator="rk4")

# the spin of the second box: 1 rad about the axis (-1, -2, 0); quaternions are (x, y, z, w)
axis = np.array([-1.0, -2.0, 0.0]) / math.sqrt(5.0)
turned = (*(math.sin(0.5) * axis), math.cos(0.5))

# two boxes with width = height = length = 1 and mass 10, at (2, 0, 0) and (0, 0, 0)
box = rbd.shapes.box((1.0, 1.0, 1.0))
id1 = world.add_body(box, mass=10.0, position=(2.0, 0.0, 0.0), name="box1")
id2 = world.add_body(box, mass=10.0, position=(0.0, 0.0, 0.0), orientation=turned, name="box2")

# give one of the bodies a little power: (2, 0, 0) N for 1 s
world.apply_force(id2, (2.0, 0.0, 0.0), duration=1.0)

# do the simulation, one second at a time
print(f"stages: {' -> '.join(world.stages)}")
steps_per_second = round(1.0 / world.dt)
while world.time < seconds - 1e-9:
    world.step(min(steps_per_second, max(1, round((seconds - world.time) / world.dt))))
    x1, x2 = world.position(id1), world.position(id2)
    print(f"t = {world.time:5.2f} s   box1 at {np.round(x1, 3)}   box2 at {np.round(x2, 3)}")

if world.time >= 1.0:
    # the push delivered an impulse of 2 N s to the pair, whatever happened between them
    total = world.linear_momentum(id1) + world.linear_momentum(id2)
    print(f"total linear momentum {np.round(total, 9)} N s")
    assert np.allclose(total, [2.0, 0.0, 0.0])
