"""The joints of a run as nodes of a viser scene, shared by the live view and the playback page.

A joint is drawn on each of its two bodies: a dark dot at its anchor and, for a hinge or a
slider, a short dark segment through the anchor along its axis. Both are stored in the body's
own frame (``World.joint_frames``) and drawn as children of the body's mesh node, so viser moves
them with the body and nothing is sent per frame; the world's side of a joint is drawn fixed.
A hinge's two sides coincide while it holds; a slider's anchor on its body runs along the
world's segment.
"""

from __future__ import annotations

import numpy as np

__all__ = ["JOINT_COLOR", "JointNodes", "world_anchors"]

JOINT_COLOR = (40, 40, 40)
# Sizes as fractions of the length that spans the scene (as the contact markers are): the
# dots' diameter, an axis segment's half length and its thickness.
_DOT = 0.012
_HALF_AXIS = 0.06
_THICKNESS = 0.003


def world_anchors(joints: dict) -> np.ndarray:
    """(k, 3) world points of the joints' sides on the world (``joints``: the keys of
    ``World.joint_frames``), for framing the view: a hinge to the world may lie off its body."""
    bodies = np.asarray(joints["bodies"], dtype=np.int64).reshape(-1, 2)
    anchors = np.asarray(joints["anchors"], dtype=np.float64).reshape(-1, 2, 3)
    return anchors[bodies < 0].reshape(-1, 3)


class JointNodes:
    """Each joint's anchors and axes as nodes of one viser scene.

    Parameters
    ----------
    scene : viser.SceneApi
        ``server.scene`` of a ``viser.ViserServer``.
    body_nodes : sequence of str
        n names of the bodies' mesh nodes (``BodyNodes.handles[i].name``): a body's joint
        nodes are its children ``<node>/joint_anchors`` and ``<node>/joint_axes``; the world's
        are ``/joint_anchors`` and ``/joint_axes``.
    joints : dict
        The keys of ``World.joint_frames``: ``bodies`` (m, 2) int (-1: the world),
        ``anchors`` and ``axes`` (m, 2, 3) in each body's frame relative to its centre of
        mass (world frame for the world), axes zero where a kind has none.
    size : float
        A length that spans the scene (m): the markers scale with it.

    Attributes
    ----------
    anchors : list of viser.PointCloudHandle
        One per body holding a joint (then the world's), each with the anchors on it.
    axes : list of viser.LineSegmentsHandle
        One per body holding a hinge or slider (then the world's), segments (k, 2, 3).
    """

    def __init__(self, scene, body_nodes, joints: dict, size: float):
        if not size > 0:
            raise ValueError(f"size must be positive, got {size!r}")
        sides = np.asarray(joints["bodies"], dtype=np.int64).reshape(-1)
        anchors = np.asarray(joints["anchors"], dtype=np.float64).reshape(-1, 3)
        axes = np.asarray(joints["axes"], dtype=np.float64).reshape(-1, 3)
        half = _HALF_AXIS * size * axes
        segments = np.stack([anchors - half, anchors + half], axis=1)
        has_axis = np.any(axes != 0.0, axis=1)
        self.anchors, self.axes = [], []
        # bodies in order, the world (-1) last: one node of each kind per body, not per joint
        for body in sorted(set(sides.tolist()), key=lambda b: (b < 0, b)):
            parent = "" if body < 0 else body_nodes[body]
            mine = sides == body
            self.anchors.append(
                scene.add_point_cloud(
                    f"{parent}/joint_anchors",
                    points=anchors[mine].astype(np.float32),
                    colors=JOINT_COLOR,
                    point_size=_DOT * size,
                    point_shape="circle",
                    precision="float32",
                )
            )
            if np.any(mine & has_axis):
                self.axes.append(
                    scene.add_line_segments(
                        f"{parent}/joint_axes",
                        points=segments[mine & has_axis].astype(np.float32),
                        colors=JOINT_COLOR,
                        thickness=_THICKNESS * size,
                    )
                )
