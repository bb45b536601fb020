"""Leading-edge continuity of the joined curve J (pressure side reversed, then suction side).

J(τ) = P(−τ) for τ ≤ 0 and S(τ) for τ ≥ 0, so J'(0⁻) = −P'(0), J''(0⁻) = P''(0). Each class must hold to
1e-9 relative on random parameters from Table 6, in both modes.
"""

import numpy as np
import pytest

from geometry import ParameterSpace, blade_curves
from geometry.bezier import cross

RTOL = 1e-9


def joined_derivatives(curves):
    s1, s2 = curves.suction.derivative([0.0], 1)[0], curves.suction.derivative([0.0], 2)[0]
    p1, p2 = curves.pressure.derivative([0.0], 1)[0], curves.pressure.derivative([0.0], 2)[0]
    return (-p1, p2), (s1, s2)


def unit(v):
    return v / np.linalg.norm(v)


def curvature(d1, d2):
    return cross(d1, d2) / np.linalg.norm(d1) ** 3


def random_blades(mode, continuity, n=40, seed=7):
    space = ParameterSpace.default(mode, continuity)
    return [blade_curves(space.spec(x)) for x in space.sample(n, np.random.default_rng(seed))]


def close(a, b):
    return np.linalg.norm(np.asarray(a) - np.asarray(b)) <= RTOL * max(np.linalg.norm(b), 1e-300)


@pytest.mark.parametrize("mode", ["design", "toolpath"])
@pytest.mark.parametrize("continuity", ["G0", "G1", "C1", "G2", "C2"])
def test_leading_edge_continuity(mode, continuity):
    for curves in random_blades(mode, continuity):
        assert close(curves.pressure.start, curves.suction.start)  # G0 for every class
        (l1, l2), (r1, r2) = joined_derivatives(curves)
        if continuity in ("G1", "C1", "G2", "C2"):
            assert close(unit(l1), unit(r1))
        if continuity in ("C1", "C2"):
            assert close(l1, r1)
        if continuity in ("G2", "C2"):
            assert close(curvature(l1, l2), curvature(r1, r2))
        if continuity == "C2":
            assert close(l2, r2)


@pytest.mark.parametrize("continuity", ["G1", "C1"])
def test_lower_classes_are_not_curvature_continuous(continuity):
    """The checks above can fail: without G2 the curvature jumps at the leading edge."""
    jumps = [abs(curvature(*left) - curvature(*right)) / abs(curvature(*right))
             for left, right in map(joined_derivatives, random_blades("design", continuity, n=10))]
    assert min(jumps) > 1e-3


def test_g2_k2_is_a_free_shape_parameter():
    """k2 moves P2 along the leading-edge tangent without changing the curvature there."""
    space = ParameterSpace.default("design", "G2")
    spec = space.spec(space.sample(1, np.random.default_rng(3))[0])
    a, b = blade_curves(spec.with_values(k2=0.5)), blade_curves(spec.with_values(k2=2.0))
    assert np.linalg.norm(a.pressure.control_points[2] - b.pressure.control_points[2]) > 1e-4
    assert curvature(*joined_derivatives(a)[0]) == pytest.approx(curvature(*joined_derivatives(b)[0]), rel=RTOL)


def test_paper_equation_13_as_printed_is_not_c2():
    """Eq. 13 at k1 = k2 = 1 gives P2 = 5 S0 - 3 S1 + S2; the second derivatives then differ."""
    curves = random_blades("design", "C2", n=1)[0]
    s0, s1, s2 = curves.suction.control_points[:3]
    printed = 5 * s0 - 3 * s1 + s2
    p0, p1 = curves.pressure.control_points[:2]
    assert not close(12 * (p0 - 2 * p1 + printed), curves.suction.derivative([0.0], 2)[0])
    np.testing.assert_allclose(curves.pressure.control_points[2], 4 * s0 - 4 * s1 + s2, atol=1e-15)
