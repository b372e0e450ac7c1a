"""Seeing runs: the live view in the browser, offline playback pages, and animated GIFs."""

from thesis_rbd.viz.gif import write_gif
from thesis_rbd.viz.html import render_html, write_html

__all__ = ["render_html", "write_gif", "write_html"]
