"""Venkatakrishnan's limiter with Wang's eps (``LIMITERS["venkatakrishnan_wang"]``): monotone on a step,
unlimited on a smooth field, independent of the field's and the mesh's units; its compiled kernel equals
the numpy form."""

import numpy as np
import pytest

from solver.gradient import LIMITERS, WANG_K_SCALE, limited_gradient, ls_gradient, neighbour_bounds
from solver.validation.meshes import square_mesh

WANG = LIMITERS["venkatakrishnan_wang"]


def skewed(size=2.0):
    return square_mesh(12, triangles="checker", strength=0.4, distort=0.3, seed=5, size=size)


def sample(mesh, f):
    """Cell values, boundary-face values and least-squares gradient of ``f(xy)``."""
    phi, phi_b = f(mesh.centroid), f(mesh.face_centre[mesh.n_internal:])
    return phi, phi_b, ls_gradient(mesh, phi, phi_b)


def wang_numpy(mesh, phi, phi_b, grad, k):
    """The numpy form (the reference of :func:`solver.kernels.venkatakrishnan` with a per-component eps²),
    scalar ``phi``."""
    pmax, pmin = neighbour_bounds(mesh, phi, phi_b)
    delta = np.einsum("cki,ci->ck", mesh.cell_r, grad)
    d1 = np.where(delta >= 0, (pmax - phi)[:, None], (pmin - phi)[:, None])
    rng = max(phi.max(), phi_b.max()) - min(phi.min(), phi_b.min())
    eps2 = (k * WANG_K_SCALE) ** 3 * rng**2
    num = (d1**2 + eps2) * delta + 2.0 * delta**2 * d1
    den = d1**2 + 2.0 * delta**2 + d1 * delta + eps2
    with np.errstate(divide="ignore", invalid="ignore"):
        psi = np.where(np.abs(delta) > 1e-300, num / (den * delta), 1.0)
    return np.clip(psi, 0.0, 1.0).min(axis=1)


def step(xy):
    return np.where(xy[:, 0] > 1.0 + 0.2 * xy[:, 1], 1.0, 0.0)


def smooth(xy):
    return 0.3 * np.sin(1.3 * xy[:, 0] + 0.4) + 0.2 * xy[:, 1]


@pytest.mark.parametrize("k", [1.0, 5.0])
def test_kernel_equals_numpy_form(k):
    m = skewed()
    phi, phi_b, g = sample(m, lambda xy: np.tanh(8.0 * (xy[:, 0] - 0.9 - 0.3 * xy[:, 1])) + 0.1 * xy[:, 1] ** 2)
    ref = wang_numpy(m, phi, phi_b, g, k)
    assert ref.min() < 0.5                                   # the front is limited: the formula is exercised
    np.testing.assert_array_equal(WANG(m, phi, phi_b, g, k), ref)
    # a vector field: each component with its own range
    two = WANG(m, np.column_stack([phi, -3 * phi + 7]), np.column_stack([phi_b, -3 * phi_b + 7]),
               np.stack([g, -3 * g], axis=1), k)
    np.testing.assert_allclose(two[:, 0], ref, rtol=0, atol=0)
    np.testing.assert_allclose(two[:, 1], ref, rtol=0, atol=1e-12)


@pytest.mark.parametrize("k", [1.0, 5.0])
def test_monotone_on_a_step(k):
    """A unit step: the limited reconstruction stays within the neighbourhood's bounds (no new extrema,
    up to eps = k % of the jump), and the cells at the front are limited hard."""
    m = skewed()
    phi, phi_b, g = sample(m, step)
    lim = limited_gradient(m, phi, phi_b, g, "venkatakrishnan_wang", k)
    face = phi[:, None] + np.einsum("cki,ci->ck", m.cell_r, lim)
    hi, lo = neighbour_bounds(m, phi, phi_b)
    overshoot = np.maximum(face - hi[:, None], lo[:, None] - face).max()
    assert overshoot <= 0.36 * (k * WANG_K_SCALE) ** 1.5   # Venkatakrishnan's function: max psi Δ = eps / √8
    unlimited = phi[:, None] + np.einsum("cki,ci->ck", m.cell_r, g)
    assert np.maximum(unlimited - hi[:, None], lo[:, None] - unlimited).max() > 0.1   # which the step needs
    psi = WANG(m, phi, phi_b, g, k)
    front = hi - lo > 0.5
    assert psi[front].max() < 0.7 and np.all(psi[hi == lo] == 1.0)


def test_linear_field_unlimited():
    """A linear field: psi = 1 in every interior cell of a uniform mesh (y = d1/Δ = 2 on every face)."""
    m = square_mesh(12, triangles="none")
    phi, phi_b, g = sample(m, lambda xy: 3.0 * xy[:, 0] - 2.0 * xy[:, 1] + 1.0)
    interior = np.all(m.cell_other < m.n_cells, axis=1)
    assert interior.sum() == 100 and np.allclose(WANG(m, phi, phi_b, g, 5.0)[interior], 1.0, rtol=0, atol=1e-14)
    assert np.allclose(limited_gradient(m, phi, phi_b, g, "venkatakrishnan_wang")[interior], [3.0, -2.0])


@pytest.mark.parametrize("f", [lambda xy: 3.0 * xy[:, 0] - 2.0 * xy[:, 1], smooth])
def test_smooth_field_unlimited_as_k_grows(f):
    """On the skewed mesh a smooth field is limited less as k grows (eps = K' × its range), and not at
    all once eps is of the order of the range (k = 100: K' = 1)."""
    m = skewed()
    phi, phi_b, g = sample(m, f)
    interior = np.all(m.cell_other < m.n_cells, axis=1)
    mins = [WANG(m, phi, phi_b, g, k)[interior].min() for k in (5.0, 10.0, 20.0, 100.0)]
    assert np.all(np.diff(mins) > 0) and mins[-1] > 0.995


@pytest.mark.parametrize("f", [step, smooth])
def test_independent_of_units(f):
    """Dimension check: the field scaled by 10 (or offset), the mesh scaled by 1/100: psi unchanged (to
    round-off); Venkatakrishnan's (K h)³ eps is not."""
    m = skewed()
    phi, phi_b, g = sample(m, f)
    psi = WANG(m, phi, phi_b, g, 5.0)
    np.testing.assert_allclose(WANG(m, 10 * phi, 10 * phi_b, 10 * g, 5.0), psi, rtol=0, atol=1e-12)
    np.testing.assert_allclose(WANG(m, phi + 3.0, phi_b + 3.0, g, 5.0), psi, rtol=0, atol=1e-12)
    small = skewed(size=0.02)
    p2, pb2, g2 = sample(small, lambda xy: f(xy * 100.0))
    np.testing.assert_allclose(WANG(small, p2, pb2, g2, 5.0), psi, rtol=0, atol=1e-9)
    venkat = LIMITERS["venkatakrishnan"]
    assert np.abs(venkat(m, 10 * phi, 10 * phi_b, 10 * g, 5.0) - venkat(m, phi, phi_b, g, 5.0)).max() > 0.05
