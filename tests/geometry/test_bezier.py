"""Bezier evaluation, derivatives and curvature against closed forms."""

import numpy as np
import pytest
from scipy.special import comb

from geometry import BezierCurve, camber_line


def test_points_match_bernstein_sum():
    rng = np.random.default_rng(0)
    cp = rng.normal(size=(5, 2))
    u = np.linspace(0, 1, 11)
    bernstein = np.stack([comb(4, i) * u**i * (1 - u) ** (4 - i) for i in range(5)], axis=1)
    np.testing.assert_allclose(BezierCurve(cp).points(u), bernstein @ cp, atol=1e-14)


def test_derivatives_match_finite_differences():
    cp = np.array([[0, 0], [1, 2], [3, -1], [4, 1], [5, 0]], float)
    curve, u, h = BezierCurve(cp), np.array([0.2, 0.5, 0.8]), 1e-5
    fd1 = (curve.points(u + h) - curve.points(u - h)) / (2 * h)
    fd2 = (curve.points(u + h) - 2 * curve.points(u) + curve.points(u - h)) / h**2
    np.testing.assert_allclose(curve.derivative(u, 1), fd1, atol=1e-8)
    np.testing.assert_allclose(curve.derivative(u, 2), fd2, atol=1e-3)
    # End derivatives of a degree-m curve: m (Q1 - Q0) and m (m - 1) (Q0 - 2 Q1 + Q2) (Eq. 9 and 12).
    np.testing.assert_allclose(curve.derivative([0.0], 1)[0], 4 * (cp[1] - cp[0]))
    np.testing.assert_allclose(curve.derivative([0.0], 2)[0], 12 * (cp[0] - 2 * cp[1] + cp[2]))


def test_parabola_curvature_and_sign():
    # Q(u) traces y = x^2 for x in [-1, 1]: curvature 2 at the vertex, positive (turning left).
    curve = BezierCurve([[-1, 1], [0, -1], [1, 1]])
    assert curve.curvature([0.5])[0] == pytest.approx(2.0)
    assert BezierCurve(curve.control_points[::-1]).curvature([0.5])[0] == pytest.approx(-2.0)


def test_degenerate_end_tangent_uses_next_derivative():
    curve = BezierCurve([[0, 0], [0, 0], [1, 1]])  # zero speed at u = 0
    np.testing.assert_allclose(curve.unit_tangent([0.0])[0], np.array([1, 1]) / np.sqrt(2))
    back = BezierCurve([[0, 0], [1, 1], [1, 1]])  # zero speed at u = 1
    np.testing.assert_allclose(back.unit_tangent([1.0])[0], np.array([1, 1]) / np.sqrt(2))


@pytest.mark.parametrize("alpha,beta1,beta1bar", [(30, 0, 60), (9.013, -0.179, 27.983), (-5, -20, 10), (10, 10, 10)])
def test_camber_line_angles(alpha, beta1, beta1bar):
    camber = camber_line(0.1, *np.radians([alpha, beta1, beta1bar]))
    cl0, _, cl2 = camber.control_points
    np.testing.assert_allclose(cl0, 0.0)
    np.testing.assert_allclose(np.linalg.norm(cl2), 0.1)
    assert np.degrees(np.arctan2(cl2[1], cl2[0])) == pytest.approx(alpha)
    t0, t2 = camber.unit_tangent([0.0, 1.0])
    assert np.degrees(np.arctan2(t0[1], t0[0])) == pytest.approx(beta1)
    assert np.degrees(np.arctan2(t2[1], t2[0])) == pytest.approx(beta1bar)
