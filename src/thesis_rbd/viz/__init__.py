"""Playback of trajectories: a self-contained HTML page and an animated GIF."""

from thesis_rbd.viz.gif import write_gif
from thesis_rbd.viz.html import render_html, write_html

__all__ = ["render_html", "write_gif", "write_html"]
