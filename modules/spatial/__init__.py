# Generated from solutions/spatial/__init__.py by `make modules` (every homework stubbed): do not edit by hand.
"""Spatial (3D) multibody systems: bodies with q_i = (x, y, z, e0, e1, e2, e3), joints, mass and forces."""
