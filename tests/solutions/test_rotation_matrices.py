"""The rotation matrices written once (``solutions.rotation_matrices``), checked against independent forms."""

import math

import numpy as np
import pytest

from solutions.elements import ConstraintElement
from solutions.planar.joints import PlanarElement, Revolute
from solutions.rotation_matrices import (
    euler_rotation,
    g_entries,
    l_entries,
    planar_rotation,
    rotation_entries,
    unit_rotation_entries,
)
from solutions.spatial.joints import EulerNormalization, SpatialElement


def rodrigues(axis, angle):
    """I + sin(chi) u~ + (1 - cos(chi)) u~^2 (eq. 8.8), written here from the notes."""
    u = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    ut = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    return np.eye(3) + math.sin(angle) * ut + (1.0 - math.cos(angle)) * (ut @ ut)


@pytest.mark.parametrize("axis, angle", [([0, 0, 1], 0.3), ([1, 2, -2], 2.5), ([1, 0, 0], math.pi)])
def test_both_forms_of_a_p_are_rodrigues_for_unit_p(axis, angle):
    u = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    p = np.array([math.cos(angle / 2), *(math.sin(angle / 2) * u)])
    assert np.allclose(np.reshape(rotation_entries(*p), (3, 3)), rodrigues(axis, angle), atol=1e-15)
    assert np.allclose(np.reshape(unit_rotation_entries(*p), (3, 3)), rodrigues(axis, angle), atol=1e-15)
    assert np.allclose(euler_rotation(p), rodrigues(axis, angle), atol=1e-15)


def test_the_homogeneous_form_is_g_l_transpose_for_any_p_and_the_unit_form_is_not():
    p = np.array([0.9, -0.3, 0.5, 0.2])  # |p| != 1
    G, L = np.reshape(g_entries(*p), (3, 4)), np.reshape(l_entries(*p), (3, 4))
    assert np.allclose(np.reshape(rotation_entries(*p), (3, 3)), G @ L.T, atol=1e-15)
    assert not np.allclose(np.reshape(unit_rotation_entries(*p), (3, 3)), G @ L.T)


def test_g_and_l_give_the_angular_velocity_of_a_rotation_about_a_fixed_axis():
    """p(t) = (cos(w t / 2), u sin(w t / 2)): omega = 2 G p' = w u globally, and omega' = 2 L p' = w u too."""
    u, w, t = np.array([2.0, -1.0, 2.0]) / 3.0, 1.7, 0.4
    p = np.array([math.cos(w * t / 2), *(math.sin(w * t / 2) * u)])
    pd = 0.5 * w * np.array([-math.sin(w * t / 2), *(math.cos(w * t / 2) * u)])
    assert np.allclose(2 * np.reshape(g_entries(*p), (3, 4)) @ pd, w * u)
    assert np.allclose(2 * np.reshape(l_entries(*p), (3, 4)) @ pd, w * u)


def test_planar_rotation_is_the_spatial_rotation_about_z():
    phi = 0.7
    assert np.allclose(planar_rotation(phi), rodrigues([0, 0, 1], phi)[:2, :2], atol=1e-15)


def test_sympy_symbols_go_through_the_same_expression():
    sp = pytest.importorskip("sympy")
    e = sp.symbols("e0:4")
    A = sp.Matrix(3, 3, rotation_entries(*e))
    values = dict(zip(e, (0.9, -0.3, 0.5, 0.2), strict=True))
    assert np.allclose(np.array(A.subs(values), dtype=float), np.reshape(rotation_entries(0.9, -0.3, 0.5, 0.2), (3, 3)))


def test_the_element_interface_is_declared_and_shared():
    assert issubclass(PlanarElement, ConstraintElement) and issubclass(SpatialElement, ConstraintElement)
    assert isinstance(Revolute("O", -1, 0, si=np.zeros(2), sj=np.zeros(2)), ConstraintElement)
    assert EulerNormalization("n", -1, 0).psi_t(None, None, 0.0).shape == (1,)

    class NoGamma(PlanarElement):
        def constraints(self, qi, qj, t):
            return np.zeros(1)

        def jacobian(self, qi, qj, t):
            return np.zeros((1, 3)), np.zeros((1, 3))

    with pytest.raises(TypeError, match="gamma"):
        NoGamma("x", -1, 0)
