"""Rigid-body dynamics: body arrays, forces, integrators, contact response."""
