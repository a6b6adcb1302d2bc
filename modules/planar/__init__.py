# Generated from solutions/planar/__init__.py by `make modules` (every homework stubbed): do not edit by hand.
"""Planar equation build-up: bodies with coordinates q_i = (x_i, y_i, phi_i), joints and drivers."""
