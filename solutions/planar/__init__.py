"""Planar equation build-up: bodies with coordinates q_i = (x_i, y_i, phi_i), joints and drivers."""
