"""Compiled kernels (:mod:`solver.kernels`) against the numpy expressions they replace, on a small skewed
mixed mesh: equal bitwise (the same operations in the same order), or within round-off where the kernel
documents a different summation order."""

import numpy as np
import pytest
import scipy.sparse as sp

from solver.assembly import deferred_correction
from solver.gradient import LIMITERS, ls_gradient, neighbour_bounds
from solver.validation.meshes import square_mesh


@pytest.fixture(scope="module")
def mesh():
    return square_mesh(10, triangles="checker", strength=0.4, distort=0.3, seed=5, size=2.0)


@pytest.fixture(scope="module")
def field(mesh):
    """A smooth field with a sharp front (so that the limiter acts), its boundary values and LS gradient."""
    rng = np.random.default_rng(1)

    def f(xy):
        return np.tanh(8.0 * (xy[:, 0] - 0.9 - 0.3 * xy[:, 1])) + 0.1 * xy[:, 1] ** 2

    phi = f(mesh.centroid) + 1e-3 * rng.standard_normal(mesh.n_cells)
    phi_b = f(mesh.face_centre[mesh.n_internal:])
    return phi, phi_b, ls_gradient(mesh, phi, phi_b)


def venkatakrishnan_numpy(mesh, phi, phi_b, grad, k):
    """The numpy form of Venkatakrishnan's limiter (the reference of :func:`kernels.venkatakrishnan`)."""
    pmax, pmin = neighbour_bounds(mesh, phi, phi_b)
    delta = np.einsum("cki,ci->ck", mesh.cell_r, grad)
    d1 = np.where(delta >= 0, (pmax - phi)[:, None], (pmin - phi)[:, None])
    eps2 = ((k * mesh.cell_size()) ** 3)[:, None]
    num = (d1**2 + eps2) * delta + 2.0 * delta**2 * d1
    den = d1**2 + 2.0 * delta**2 + d1 * delta + eps2
    with np.errstate(divide="ignore", invalid="ignore"):
        psi = np.where(np.abs(delta) > 1e-300, num / (den * delta), 1.0)
    return np.clip(psi, 0.0, 1.0).min(axis=1)


@pytest.mark.parametrize("k", [0.3, 1.0])
def test_venkatakrishnan_equals_numpy_form(mesh, field, k):
    phi, phi_b, grad = field
    psi = LIMITERS["venkatakrishnan"](mesh, phi, phi_b, grad, k)
    ref = venkatakrishnan_numpy(mesh, phi, phi_b, grad, k)
    assert ref.min() < 0.5                       # the front is limited: the test exercises the formula
    np.testing.assert_array_equal(psi, ref)
    two = LIMITERS["venkatakrishnan"](mesh, np.column_stack([phi, -2 * phi]), np.column_stack([phi_b, -2 * phi_b]),
                                      np.stack([grad, -2 * grad], axis=1), k)          # a vector field
    np.testing.assert_array_equal(two, np.column_stack([ref, venkatakrishnan_numpy(mesh, -2 * phi, -2 * phi_b,
                                                                                   -2 * grad, k)]))


def deferred_correction_numpy(mesh, flux, grad_ho):
    """The numpy form of the deferred correction (the reference of :func:`kernels.deferred_correction`)."""
    ni = mesh.n_internal
    o, n = mesh.owner[:ni], mesh.neighbour[:ni]
    F = flux[:ni]
    extra = (1,) * (grad_ho.ndim - 2)
    xf = mesh.face_centre[:ni]
    r_up = np.where((F >= 0)[:, None], xf - mesh.centroid[o], xf - mesh.centroid[n])
    g_up = np.where((F >= 0).reshape((-1, 1) + extra), grad_ho[o], grad_ho[n])
    return F.reshape((-1,) + extra) * np.einsum("f...d,fd->f...", g_up, r_up)


@pytest.mark.parametrize("vector", [False, True])
def test_deferred_correction_equals_numpy_form(mesh, field, vector):
    rng = np.random.default_rng(2)
    flux = rng.standard_normal(mesh.n_faces)
    flux[:5] = 0.0                               # F = 0 takes the owner side
    grad = field[2] if not vector else rng.standard_normal((mesh.n_cells, 2, 2))
    np.testing.assert_array_equal(deferred_correction(mesh, flux, grad), deferred_correction_numpy(mesh, flux, grad))


def test_deferred_correction_of_zero_gradient_is_zero(mesh):
    out = deferred_correction(mesh, np.ones(mesh.n_faces), np.zeros((mesh.n_cells, 2, 2)))
    assert out.shape == (mesh.n_internal, 2) and not out.any()


def face_velocity_numpy(mesh, u, u_b, grad_u, bounded=False):
    """The numpy form of the capped quadratic face velocity (the reference of
    :func:`kernels.cap_quadratic_correction` and, ``bounded``, :func:`kernels.clip_to_cells` inside
    :func:`solver.pressure.face_velocity`)."""
    from solver.gradient import face_average, face_operators, interpolate_corrected
    from solver.pressure import QUADRATIC_CAP, _triangles

    lin = interpolate_corrected(mesh, u, grad_u)
    tri = _triangles(mesh)
    ni = mesh.n_internal
    o, n = mesh.owner[:ni], mesh.neighbour[:ni]
    if bounded:
        lin = np.clip(lin, np.minimum(u[o], u[n]), np.maximum(u[o], u[n]))
    slope = np.linalg.norm(grad_u, axis=-1)
    cap = QUADRATIC_CAP * face_operators(mesh)["d_length"][:ni, None] * 0.5 * (slope[o] + slope[n])
    cap *= (tri[o] | tri[n])[:, None]
    return lin + np.clip(face_average(mesh, u, u_b) - lin, -cap, cap)


def rough_velocity(mesh):
    """A smooth velocity with noise (so that the quadratic cap and the bound act on some faces), its
    boundary values and LS gradient."""
    rng = np.random.default_rng(3)
    xy, xb = mesh.centroid, mesh.face_centre[mesh.n_internal:]
    u = np.column_stack([np.sin(3 * xy[:, 0]) * xy[:, 1] ** 2, np.cos(2 * xy[:, 1])])
    u += 0.05 * rng.standard_normal((mesh.n_cells, 2))
    u_b = np.column_stack([np.sin(3 * xb[:, 0]) * xb[:, 1] ** 2, np.cos(2 * xb[:, 1])])
    return u, u_b, ls_gradient(mesh, u, u_b)


@pytest.mark.parametrize("bounded", [False, True])
def test_face_velocity_equals_numpy_form(mesh, bounded):
    from solver.pressure import _quadratic_faces, face_velocity

    u, u_b, grad_u = rough_velocity(mesh)
    ref = face_velocity_numpy(mesh, u, u_b, grad_u, bounded)
    out = face_velocity(mesh, u, u_b, grad_u, bounded)
    assert 0 < _quadratic_faces(mesh).size < mesh.n_internal         # mixed mesh: both kinds of face
    np.testing.assert_array_equal(out, ref)


def test_bounded_face_velocity_stays_within_its_two_cells_on_quadrilaterals():
    """``bounded``: the reconstruction is clipped where it overshoots both cells and kept where it does not
    (on quadrilaterals there is no quadratic correction on top)."""
    from solver.gradient import interpolate_corrected
    from solver.pressure import face_velocity

    quads = square_mesh(10, triangles="none", strength=0.4, distort=0.3, seed=5, size=2.0)
    u, u_b, grad_u = rough_velocity(quads)
    ni = quads.n_internal
    lo = np.minimum(u[quads.owner[:ni]], u[quads.neighbour[:ni]])
    hi = np.maximum(u[quads.owner[:ni]], u[quads.neighbour[:ni]])
    corrected = interpolate_corrected(quads, u, grad_u)
    inside = (corrected >= lo) & (corrected <= hi)
    assert 0 < inside.sum() < inside.size                            # the bound acts on some faces only
    out = face_velocity(quads, u, u_b, grad_u, bounded=True)
    assert ((out >= lo) & (out <= hi)).all()
    np.testing.assert_array_equal(out[inside], corrected[inside])
    np.testing.assert_array_equal(face_velocity(quads, u, u_b, grad_u), corrected)


def test_rhie_chow_faces_equal_numpy_form(mesh):
    """The internal-face Rhie–Chow fluxes (:func:`kernels.rhie_chow_faces`) equal bitwise their numpy form."""
    from solver.gradient import interpolate_linear, linear_weights
    from solver.kernels import rhie_chow_faces

    rng = np.random.default_rng(13)
    ni, nc = mesh.n_internal, mesh.n_cells
    o, n = mesh.owner[:ni], mesh.neighbour[:ni]
    u_f, p, r_au, grad_p = rng.standard_normal((ni, 2)), rng.standard_normal(nc), rng.uniform(0.1, 1, nc), \
        rng.standard_normal((nc, 2))
    e = (mesh.sf - mesh.t_vec)[:ni]
    ref = 1.5 * (np.einsum("fd,fd->f", u_f, mesh.sf[:ni]) - interpolate_linear(mesh, r_au) * (
        mesh.diff_coeff[:ni] * (p[n] - p[o]) - np.einsum("fd,fd->f", interpolate_linear(mesh, grad_p), e)))
    out = rhie_chow_faces(*linear_weights(mesh), u_f, mesh.sf[:ni], e, mesh.diff_coeff[:ni], p, r_au, grad_p, 1.5)
    np.testing.assert_array_equal(out, ref)


def test_gauss_seidel_pair_equals_two_separate_solves(mesh):
    """The u and v momentum systems swept together (:meth:`MomentumSystem.solve`) give the two separate
    pyamg-kernel solves (:func:`symmetric_gauss_seidel`) to round-off."""
    from solver.linalg import FVPattern, LinearSystem, SolverSettings, symmetric_gauss_seidel
    from solver.momentum import MomentumSystem

    rng = np.random.default_rng(4)
    pattern = FVPattern.from_mesh(mesh)
    ni, nc = mesh.n_internal, mesh.n_cells
    upper, lower = -rng.uniform(0.1, 1.0, ni), -rng.uniform(0.1, 1.0, ni)
    diags = [4.0 + rng.uniform(0, 1, nc) for _ in range(2)]
    systems = [LinearSystem(pattern.matrix(d, upper, lower), rng.standard_normal(nc), rng.standard_normal(nc))
               for d in diags]
    mom = MomentumSystem(*systems, 0.5 * (diags[0] + diags[1]), np.zeros(nc), 0.9,
                         (pattern, upper, lower, *diags))
    gs = SolverSettings("gauss_seidel", 0.1, 5)
    ref = []
    for system in systems:
        x = system.x0.copy()
        symmetric_gauss_seidel(system.A, x, system.b, 5)
        ref.append(x)
    np.testing.assert_allclose(mom.solve(gs), np.column_stack(ref), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(gs.solve(systems[0])[0], ref[0], rtol=1e-12, atol=1e-14)   # one system alone
    indptr, indices, _ = pattern.off_diagonal
    off = sp.csr_matrix((pattern.off_diagonal_values(upper, lower), indices, indptr), shape=(nc, nc))
    np.testing.assert_array_equal((off + sp.diags(diags[0])).toarray(), systems[0].A.toarray())


def test_split_by_pattern_equals_split_diagonal(mesh):
    """:meth:`LinearSystem.split` by the pattern's slots (a system built on the pattern) equals
    :func:`kernels.split_diagonal` of the matrix bitwise, zero diagonal entries included; the pattern's
    unsigned index arrays are the matrix's; :meth:`FVPattern.with_diagonal` is :meth:`FVPattern.matrix`."""
    from solver.kernels import split_diagonal
    from solver.linalg import FVPattern, LinearSystem, unsigned_csr

    rng = np.random.default_rng(7)
    pattern = FVPattern.from_mesh(mesh)
    ni, nc = mesh.n_internal, mesh.n_cells
    diag = 4.0 + rng.uniform(0, 1, nc)
    diag[[0, 5]] = 0.0
    upper, lower = -rng.uniform(0.1, 1.0, ni), -rng.uniform(0.1, 1.0, ni)
    system = LinearSystem(pattern.matrix(diag, upper, lower), rng.standard_normal(nc), rng.standard_normal(nc),
                          pattern)
    assert pattern.built(system.A)
    other = rng.uniform(1, 2, nc)
    np.testing.assert_array_equal(pattern.with_diagonal(system.A, other).data, pattern.matrix(other, upper, lower).data)
    for got, ref in zip(system.split(), split_diagonal(*unsigned_csr(system.A)), strict=True):
        np.testing.assert_array_equal(got, ref)
    for got, ref in zip(system.csr_arrays(), unsigned_csr(system.A), strict=True):
        np.testing.assert_array_equal(got, ref)


def test_residual_norms_equal_numpy_form(mesh):
    """:meth:`LinearSystem.residual_norms` (compiled) against its numpy form, to round-off (the 1-norms are
    summed in another order); and the floor of a uniform field."""
    from solver.linalg import FVPattern, LinearSystem

    rng = np.random.default_rng(6)
    pattern = FVPattern.from_mesh(mesh)
    ni, nc = mesh.n_internal, mesh.n_cells
    A = pattern.matrix(4.0 + rng.uniform(0, 1, nc), -rng.uniform(0.1, 1.0, ni), -rng.uniform(0.1, 1.0, ni))
    for x in (rng.standard_normal(nc), np.full(nc, 2.0)):
        system = LinearSystem(A, rng.standard_normal(nc), x)
        ax = A @ x
        axbar = np.asarray(A.sum(axis=1)).ravel() * x.mean()
        norm = np.abs(ax - axbar).sum() + np.abs(system.b - axbar).sum()
        ref = (np.abs(system.b - ax).sum(), max(norm, 1e-2 * np.abs(A.diagonal() * x).sum()))
        np.testing.assert_allclose(system.residual_norms(), ref, rtol=1e-13)


def spalding_numpy(u_t, y, nu, c):
    """The vectorised numpy bisection (the reference of :func:`kernels.spalding_u_tau`)."""
    re_y = np.maximum(np.asarray(u_t, float) * y / nu, 1e-300)
    kap, eb = c.kappa, np.exp(-c.kappa * c.spalding_b)

    def g(up):
        ku = kap * up
        return re_y / up - (up + eb * (np.exp(ku) - 1.0 - ku - ku**2 / 2.0 - ku**3 / 6.0))

    lo = np.zeros_like(re_y)
    hi = np.sqrt(re_y) * (1.0 + 1e-12)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        pos = g(np.maximum(mid, 1e-300)) > 0
        lo = np.where(pos, mid, lo)
        hi = np.where(pos, hi, mid)
    u_plus = 0.5 * (lo + hi)
    return np.where(re_y > 1e-200, np.asarray(u_t, float) / np.maximum(u_plus, 1e-300), 0.0)


def test_spalding_equals_numpy_form():
    """Sublayer to log layer and a zero speed; equal to the numpy bisection up to the last bits of ``exp``
    (numba's and numpy's may differ by an ulp on some machines; bitwise where they agree)."""
    from solver.turbulence.closures import SSTConstants, spalding_u_tau

    rng = np.random.default_rng(7)
    y = 10.0 ** rng.uniform(-7, -2, 400)
    u_t = np.concatenate([[0.0], 10.0 ** rng.uniform(-3, 1.5, 399)])
    c = SSTConstants()
    np.testing.assert_allclose(spalding_u_tau(u_t, y, 1e-6, c), spalding_numpy(u_t, y, 1e-6, c), rtol=1e-14, atol=0)


def pressure_like_system(n=24):
    """A pinned FV Laplacian (as the p' system without an outlet) on a skewed mixed mesh, random rhs."""
    from solver.linalg import FVPattern, LinearSystem

    m = square_mesh(n, triangles="checker", strength=0.4, distort=0.3, seed=5)
    rng = np.random.default_rng(8)
    c = rng.uniform(0.5, 2.0, m.n_internal)
    diag = np.bincount(m.owner[:m.n_internal], c, m.n_cells) + np.bincount(m.neighbour[:m.n_internal], c, m.n_cells)
    diag[0] *= 2.0
    A = FVPattern.from_mesh(m).matrix(diag, -c, -c)
    return LinearSystem(A, rng.standard_normal(m.n_cells), np.zeros(m.n_cells))


def test_v_cycle_equals_pyamg_cycle_to_round_off():
    """:class:`VCycle` (compiled products and sweeps) against pyamg's own V-cycle with symmetric
    Gauss–Seidel smoothers: the same preconditioner up to the rounding of the sweeps."""
    from solver.linalg import AMG_HIERARCHIES, VCycle, _seeded

    system = pressure_like_system()
    ml = _seeded(AMG_HIERARCHIES["ruge_stuben"], system.A)
    assert len(ml.levels) >= 3 and VCycle.applies(ml)
    np.testing.assert_allclose(VCycle(ml)(system.b), ml.aspreconditioner(cycle="V").matvec(system.b), rtol=1e-11,
                               atol=1e-12 * np.abs(system.b).max())


@pytest.mark.parametrize("hierarchy", ["ruge_stuben", "smoothed_aggregation"])
def test_preconditioned_cg_equals_scipy_cg(hierarchy):
    """:func:`preconditioned_cg` gives bitwise scipy's ``cg`` with the same preconditioner, and
    :func:`_amg_cg` picks :class:`VCycle` for Ruge–Stüben, pyamg's cycle for smoothed aggregation."""
    import scipy.sparse.linalg as spla

    from solver.linalg import AMG_HIERARCHIES, VCycle, _amg_cg, _seeded

    system = pressure_like_system()
    state = {}
    x, stats = _amg_cg(system, 1e-6, 50, state, hierarchy=hierarchy)
    assert isinstance(state["precondition"], VCycle) == (hierarchy == "ruge_stuben")
    M = spla.LinearOperator(system.A.shape, state["precondition"])
    ref, info = spla.cg(system.A, system.b, x0=system.x0, rtol=1e-6, atol=0.0, maxiter=50, M=M)
    assert info == 0 and 1 < stats.iterations < 50
    np.testing.assert_array_equal(x, ref)
    assert len(_seeded(AMG_HIERARCHIES[hierarchy], system.A).levels) >= 3


def test_gauss_seidel_sweeps_equal_pyamg_to_round_off(mesh):
    """:func:`kernels.gauss_seidel_sweeps` on :func:`kernels.split_diagonal` against pyamg's symmetric
    sweeps (:func:`solver.linalg.symmetric_gauss_seidel`), with a zero-diagonal row left unchanged."""
    from solver.kernels import gauss_seidel_sweeps, split_diagonal
    from solver.linalg import symmetric_gauss_seidel, unsigned_csr

    system = pressure_like_system(10)
    A = system.A.copy()
    A[3, 3] = 0.0                                   # a row pyamg skips
    x_ref, x = np.full(A.shape[0], 0.5), np.full(A.shape[0], 0.5)
    symmetric_gauss_seidel(A, x_ref, system.b, 3)
    gauss_seidel_sweeps(*split_diagonal(*unsigned_csr(A)), x, system.b, 3)
    assert x[3] == 0.5
    np.testing.assert_allclose(x, x_ref, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("vector", [False, True])
def test_ls_gradient_equals_its_two_sparse_products(mesh, field, vector):
    """:func:`ls_gradient` (paired rows, one compiled pass) equals bitwise the sum of the products of its two
    CSR operators (scipy), for a scalar and a vector field."""
    from solver.gradient import ls_operators

    phi, phi_b, _ = field
    if vector:
        phi, phi_b = np.column_stack([phi, phi**2]), np.column_stack([phi_b, -phi_b])
    cell_op, boundary_op = (op.matrix for op in ls_operators(mesh))
    nc, nb = mesh.n_cells, mesh.n_boundary
    ref = (cell_op @ phi.reshape(nc, -1) + boundary_op @ phi_b.reshape(nb, -1)).reshape(nc, 2, -1)
    ref = np.moveaxis(ref, 1, 2).reshape(phi.shape + (2,))
    np.testing.assert_array_equal(ls_gradient(mesh, phi, phi_b), ref)


@pytest.mark.parametrize("shape", [(), (2,), (2, 2), (3,)])
def test_interpolate_linear_equals_its_operator(mesh, shape):
    """:func:`interpolate_linear` (compiled face loops) equals bitwise the product with its CSR operator."""
    from solver.gradient import face_operators, interpolate_linear

    phi = np.random.default_rng(11).standard_normal((mesh.n_cells,) + shape)
    ref = face_operators(mesh)["linear"].matrix @ phi.reshape(mesh.n_cells, -1)
    np.testing.assert_array_equal(interpolate_linear(mesh, phi), ref.reshape((mesh.n_internal,) + shape))


def test_face_gradient_terms_equal_numpy_forms(mesh):
    """The non-orthogonal diffusion of a scalar and the variable-viscosity stress of the momentum equations
    (compiled face loops) equal bitwise their numpy forms (interpolation, ``einsum``, products)."""
    from solver.assembly import non_orthogonal_diffusion
    from solver.gradient import interpolate_linear, linear_weights
    from solver.kernels import viscous_face_stress

    rng = np.random.default_rng(12)
    ni, nc = mesh.n_internal, mesh.n_cells
    gamma, grad, grad_u = rng.uniform(0.1, 1.0, ni), rng.standard_normal((nc, 2)), rng.standard_normal((nc, 2, 2))
    t, sf = mesh.t_vec[:ni], mesh.sf[:ni]
    ref = gamma * np.einsum("fd,fd->f", interpolate_linear(mesh, grad), t)
    np.testing.assert_array_equal(non_orthogonal_diffusion(mesh, gamma, grad), ref)
    g_f = interpolate_linear(mesh, grad_u)
    ref = gamma[:, None] * (np.einsum("fcd,fd->fc", g_f, t) + np.einsum("fdc,fd->fc", g_f, sf))
    np.testing.assert_array_equal(viscous_face_stress(*linear_weights(mesh), grad_u, t, sf, gamma), ref)


@pytest.mark.parametrize("columns", [None, 1, 2, 6])
def test_compiled_csr_product_equals_scipy(mesh, columns):
    from solver.gradient import face_operators
    from solver.kernels import CompiledCSR

    op = face_operators(mesh)["corrected"]
    assert isinstance(op, CompiledCSR)
    rng = np.random.default_rng(9)
    x = rng.standard_normal(op.shape[1] if columns is None else (op.shape[1], columns))
    np.testing.assert_array_equal(op @ x, op.matrix @ x)


def test_dot_last_equals_einsum():
    from solver.kernels import dot_last

    rng = np.random.default_rng(10)
    a, b, v = rng.standard_normal((300, 2, 2)), rng.standard_normal((300, 2)), rng.standard_normal((300, 2))
    np.testing.assert_array_equal(dot_last(a, b), np.einsum("fcd,fd->fc", a, b))
    np.testing.assert_array_equal(dot_last(np.swapaxes(a, 1, 2), b), np.einsum("fdc,fd->fc", a, b))
    np.testing.assert_array_equal(dot_last(v, b), np.einsum("ij,ij->i", v, b))


def test_velocity_invariants_equal_numpy_form():
    """The compiled invariants against the numpy form (``einsum`` over the symmetric and antisymmetric
    parts; bitwise on the development machine, to round-off wherever numpy pairs the sum differently)."""
    from solver.turbulence.closures import velocity_invariants

    g = np.random.default_rng(11).standard_normal((500, 2, 2))
    s = 0.5 * (g + np.swapaxes(g, 1, 2))
    w = 0.5 * (g - np.swapaxes(g, 1, 2))
    s2, w2 = velocity_invariants(g)
    np.testing.assert_allclose(s2, 2.0 * np.einsum("cij,cij->c", s, s), rtol=1e-15)
    np.testing.assert_allclose(w2, 2.0 * np.einsum("cij,cij->c", w, w), rtol=1e-15)
    np.testing.assert_allclose(velocity_invariants(np.array([[[0.0, 1.0], [0.0, 0.0]]])), [[1.0], [1.0]])  # shear


def test_log_mean_faces_equals_closure(mesh):
    from solver.kernels import log_mean_faces
    from solver.turbulence.closures import log_mean

    rng = np.random.default_rng(12)
    gamma = 10.0 ** rng.uniform(-6, -2, mesh.n_cells)
    gamma[:10] = 1e-4                                   # equal neighbours: the arithmetic-mean branch
    ni = mesh.n_internal
    o, n = mesh.owner[:ni], mesh.neighbour[:ni]
    np.testing.assert_allclose(log_mean_faces(gamma, o, n), log_mean(gamma[o], gamma[n]), rtol=1e-15, atol=0)


@pytest.mark.parametrize("vector", [False, True])
def test_stencil_and_scatter_equal_numpy_forms(mesh, vector):
    """:func:`upwind_stencil` and :func:`scatter_face_sources` (compiled) against their ``np.bincount``
    forms, bitwise; zero fluxes included."""
    from solver.assembly import scatter_face_sources, sum_per_cell, upwind_stencil

    rng = np.random.default_rng(13)
    ni, nc = mesh.n_internal, mesh.n_cells
    o, n = mesh.owner[:ni], mesh.neighbour[:ni]
    flux = rng.standard_normal(mesh.n_faces)
    flux[:7] = 0.0
    gamma = rng.uniform(0.1, 1.0, ni) if vector else 0.3
    st = upwind_stencil(mesh, flux, gamma)
    F, D = flux[:ni], gamma * mesh.diff_coeff[:ni]
    np.testing.assert_array_equal(st.upper, np.minimum(F, 0.0) - D)
    np.testing.assert_array_equal(st.lower, -np.maximum(F, 0.0) - D)
    np.testing.assert_array_equal(st.diag, np.bincount(o, np.maximum(F, 0.0) + D, nc)
                                  + np.bincount(n, np.maximum(-F, 0.0) + D, nc))
    shape = (2,) if vector else ()
    src, face = rng.standard_normal((nc,) + shape), rng.standard_normal((ni,) + shape)
    ref = src - sum_per_cell(o, face, nc) + sum_per_cell(n, face, nc)
    np.testing.assert_array_equal(scatter_face_sources(mesh, src, face), ref)


def _boundary_velocity_numpy(bnd, mesh, u, grad_u):
    """The numpy form of :meth:`BoundaryData.velocity` (the reference of :func:`kernels.boundary_velocity`)."""
    from solver.boundary import FIXED, SYMMETRY

    ni = mesh.n_internal
    o = mesh.owner[ni:]
    up = u[o]
    n = mesh.normal[ni:]
    if grad_u is not None:
        r = mesh.face_centre[ni:] - mesh.centroid[o]
        r_t = r - np.einsum("ij,ij->i", r, n)[:, None] * n
        up = up + np.einsum("fcd,fd->fc", grad_u[o], r_t)
    sym = up - np.einsum("ij,ij->i", up, n)[:, None] * n
    k = bnd.velocity_kind[:, None]
    return np.where(k == FIXED, bnd.u_fixed, np.where(k == SYMMETRY, sym, up))


def _boundary_pressure_numpy(bnd, mesh, p, grad_p):
    """The numpy form of :meth:`BoundaryData.pressure` (the reference of :func:`kernels.boundary_pressure`)."""
    ni = mesh.n_internal
    o = mesh.owner[ni:]
    pb = p[o].copy()
    if grad_p is not None:
        pb += np.einsum("ij,ij->i", grad_p[o], mesh.face_centre[ni:] - mesh.centroid[o])
    out = np.where(bnd.p_fixed, bnd.p_value, pb)
    for j, target in bnd.p_mean:
        f = ni + j
        prof = p[o[j]]
        if grad_p is not None:
            r = mesh.face_centre[f] - mesh.centroid[o[j]]
            n = mesh.normal[f]
            prof = prof + np.einsum("ij,ij->i", grad_p[o[j]], r - np.einsum("ij,ij->i", r, n)[:, None] * n)
        w = mesh.length[f]
        out[j] = prof - np.dot(w, prof) / w.sum() + target
    return out


@pytest.mark.parametrize("outlet", ["pressure_outlet", "mean"])
def test_boundary_values_equal_numpy_forms(mesh, outlet):
    """:meth:`BoundaryData.velocity` and :meth:`BoundaryData.pressure` (compiled) against their numpy forms,
    bitwise, with and without gradients; every velocity kind (fixed, zero gradient, symmetry) and a fixed or
    mean-pressure outlet."""
    from solver.boundary import resolve_boundaries

    out = {"type": "pressure_outlet", "p": 2.0}
    if outlet == "mean":
        out["mode"] = "mean"
    bnd = resolve_boundaries(mesh, {"left": {"type": "velocity_inlet", "velocity": (1.0, 0.2)}, "right": out,
                                    "bottom": "symmetry", "top": "wall"})
    rng = np.random.default_rng(14)
    u, p = rng.standard_normal((mesh.n_cells, 2)), rng.standard_normal(mesh.n_cells)
    grad_u, grad_p = rng.standard_normal((mesh.n_cells, 2, 2)), rng.standard_normal((mesh.n_cells, 2))
    for g in (grad_u, None):
        np.testing.assert_array_equal(bnd.velocity(mesh, u, g), _boundary_velocity_numpy(bnd, mesh, u, g))
    for g in (grad_p, None):
        np.testing.assert_array_equal(bnd.pressure(mesh, p, g), _boundary_pressure_numpy(bnd, mesh, p, g))


def test_sst_closure_kernels_equal_closures():
    """The compiled SST closures (:func:`kernels.sst_blending_arguments`, :func:`kernels.sst_f2_argument`,
    :func:`kernels.sst_omega_coefficients`) with numpy's tanh and powers on top, against the closures of
    :mod:`solver.turbulence.closures` and the numpy form of the omega sources, bitwise; cells across the F1
    switch, both signs of grad k · grad omega."""
    from solver.kernels import sst_blending_arguments, sst_f2_argument, sst_omega_coefficients
    from solver.turbulence.closures import SSTConstants, blend, cross_diffusion, eddy_viscosity, f1, f2

    c = SSTConstants()
    rng = np.random.default_rng(15)
    n, nu, rho, mu = 2000, 1.5e-5, 1.2, 1.8e-5
    k, omega = 10.0 ** rng.uniform(-6, 1, n), 10.0 ** rng.uniform(-1, 6, n)
    d = 10.0 ** rng.uniform(-6, 0, n)
    grad_k, grad_w = rng.standard_normal((n, 2)) * 1e2, rng.standard_normal((n, 2)) * 1e5
    strain = 10.0 ** rng.uniform(-1, 4, n)
    arg1, arg2, kw = sst_blending_arguments(k, omega, d, grad_k, grad_w, nu, c.sigma_w2, c.beta_star, c.cd_floor)
    F1 = np.tanh(arg1**4)
    np.testing.assert_array_equal(F1, f1(k, omega, d, nu, cross_diffusion(grad_k, grad_w, omega, c), c))
    np.testing.assert_array_equal(np.tanh(arg2**2), f2(k, omega, d, nu, c))
    np.testing.assert_array_equal(np.tanh(sst_f2_argument(k, omega, d, nu, c.beta_star)**2), f2(k, omega, d, nu, c))
    assert 0.05 < (F1 > 0.5).mean() < 0.95
    nu_t = eddy_viscosity(k, omega, strain, f2(k, omega, d, nu, c), c)
    p_w = strain**2
    su, sp, gam_w, gam_k = sst_omega_coefficients(F1, omega, kw, p_w, nu_t, rho, mu, c.beta1, c.beta2, c.gamma1,
                                                  c.gamma2, c.sigma_w1, c.sigma_w2, c.sigma_k1, c.sigma_k2)
    beta, gamma = blend(F1, c.beta1, c.beta2), blend(F1, c.gamma1, c.gamma2)
    cdw = 2.0 * (1.0 - F1) * c.sigma_w2 / omega * np.einsum("ij,ij->i", grad_k, grad_w)
    np.testing.assert_array_equal(su, rho * (gamma * p_w + beta * omega**2 + np.maximum(cdw, 0.0)))
    np.testing.assert_array_equal(sp, rho * (2.0 * beta * omega + np.maximum(-cdw, 0.0) / omega))
    np.testing.assert_array_equal(gam_w, mu + rho * blend(F1, c.sigma_w1, c.sigma_w2) * nu_t)
    np.testing.assert_array_equal(gam_k, mu + rho * blend(F1, c.sigma_k1, c.sigma_k2) * nu_t)
    assert (cdw > 0).any() and (cdw < 0).any()


def _scalar_system_numpy(mesh, pattern, phi, phi_b, dirichlet, flux, gamma, grad, sp, su, alpha, fixed_cells,
                         fixed_values):
    """The numpy form of :func:`solver.transport.scalar_system` with upwind convection (the reference of
    :func:`kernels.scalar_boundary_terms` and :func:`kernels.decouple_fixed_cells`)."""
    from solver.assembly import non_orthogonal_diffusion, scatter_face_sources, upwind_stencil
    from solver.linalg import LinearSystem

    ni, nc = mesh.n_internal, mesh.n_cells
    o, n = mesh.owner[:ni], mesh.neighbour[:ni]
    st = upwind_stencil(mesh, flux, gamma[:ni])
    diag, upper, lower = st.diag, st.upper, st.lower
    src = su * mesh.volume
    diag += sp * mesh.volume
    src = scatter_face_sources(mesh, src, -non_orthogonal_diffusion(mesh, gamma[:ni], grad))
    ob = mesh.owner[ni:]
    Fb = flux[ni:]
    Db = np.where(dirichlet, gamma[ni:] * mesh.diff_coeff[ni:], 0.0)
    out = Fb > 0
    diag_b = Db + np.where(out, Fb, 0.0)
    src_b = Db * phi_b + np.where(dirichlet, gamma[ni:] * np.einsum("fd,fd->f", grad[ob], mesh.t_vec[ni:]), 0.0)
    src_b -= np.where(out, 0.0, Fb * np.where(dirichlet, phi_b, phi[ob]))
    diag += np.bincount(ob, diag_b, nc)
    src += np.bincount(ob, src_b, nc)
    d = diag / alpha
    b = src + (1.0 - alpha) * d * phi
    is_fixed = np.zeros(nc, bool)
    is_fixed[fixed_cells] = True
    upper = np.where(is_fixed[o], 0.0, upper)
    lower = np.where(is_fixed[n], 0.0, lower)
    d[fixed_cells] = 1.0
    b[fixed_cells] = fixed_values
    return LinearSystem(pattern.matrix(d, upper, lower), b, phi.copy(), pattern)


def test_scalar_system_equals_numpy_form(mesh):
    """:func:`solver.transport.scalar_system` (boundary terms and fixed cells compiled) against its numpy
    form, bitwise: inflow and outflow faces, dirichlet and zero-gradient faces, fixed cells."""
    from solver.linalg import FVPattern
    from solver.transport import scalar_system

    rng = np.random.default_rng(16)
    nc, nb = mesh.n_cells, mesh.n_boundary
    pattern = FVPattern.from_mesh(mesh)
    phi, phi_b = rng.uniform(0.5, 2.0, nc), rng.uniform(0.5, 2.0, nb)
    dirichlet = rng.random(nb) < 0.5
    flux, gamma = rng.standard_normal(mesh.n_faces), rng.uniform(0.1, 1.0, mesh.n_faces)
    grad, sp, su = rng.standard_normal((nc, 2)), rng.uniform(0, 1, nc), rng.standard_normal(nc)
    fixed = rng.choice(nc, 7, replace=False)
    args = (mesh, pattern, phi, phi_b, dirichlet, flux, gamma, grad)
    new = scalar_system(*args, np.zeros((nc, 2)), sp, su, 0.8, fixed, np.full(7, 3.0))
    ref = _scalar_system_numpy(*args, sp, su, 0.8, fixed, np.full(7, 3.0))
    np.testing.assert_array_equal(new.A.data, ref.A.data)
    np.testing.assert_array_equal(new.b, ref.b)
    assert (flux[mesh.n_internal:][dirichlet] < 0).any() and (flux[mesh.n_internal:][~dirichlet] < 0).any()


def _momentum_boundary_numpy(mesh, bnd, u, u_b, Fb, grad_u, mu):
    """The numpy form of :func:`solver.momentum._boundary` (the reference of
    :func:`kernels.momentum_boundary_terms`)."""
    from solver.assembly import sum_per_cell
    from solver.boundary import FIXED, SYMMETRY, ZERO_GRADIENT

    ni, nc = mesh.n_internal, mesh.n_cells
    o = mesh.owner[ni:]
    kind = bnd.velocity_kind
    fixed, zg, sym = kind == FIXED, kind == ZERO_GRADIENT, kind == SYMMETRY
    Db = mu * mesh.diff_coeff[ni:]
    diag_f = np.where(fixed, Db, 0.0) + np.where(zg, np.maximum(Fb, 0.0), 0.0)
    src_f = np.where(fixed[:, None], (Db[:, None] - Fb[:, None]) * u_b
                     + np.reshape(mu, (-1, 1)) * np.einsum("fcd,fd->fc", grad_u[o], mesh.t_vec[ni:]), 0.0)
    src_f -= np.where(zg[:, None], Fb[:, None] * u_b - np.maximum(Fb, 0.0)[:, None] * u[o], 0.0)
    nrm = mesh.normal[ni:]
    dn = np.einsum("ij,ij->i", mesh.d[ni:], nrm)
    Dn = np.where(sym, mu * mesh.length[ni:] / dn, 0.0)
    cross = Dn * nrm[:, 0] * nrm[:, 1]
    src_f[:, 0] -= cross * u[o, 1]
    src_f[:, 1] -= cross * u[o, 0]
    sym_d = Dn[:, None] * nrm**2
    return np.bincount(o, diag_f, nc), sum_per_cell(o, src_f, nc), sum_per_cell(o, sym_d, nc)


@pytest.mark.parametrize("per_face", [False, True])
def test_momentum_boundary_equals_numpy_form(mesh, per_face):
    """:func:`solver.momentum._boundary` (compiled) against its numpy form, bitwise: fixed, zero-gradient
    (inflow and outflow) and symmetry faces, a scalar or per-face viscosity."""
    from solver.boundary import resolve_boundaries
    from solver.momentum import _boundary

    bnd = resolve_boundaries(mesh, {"left": {"type": "velocity_inlet", "velocity": (1.0, 0.2)},
                                    "right": "pressure_outlet", "bottom": "symmetry", "top": "wall"})
    rng = np.random.default_rng(17)
    nc, nb = mesh.n_cells, mesh.n_boundary
    u, u_b = rng.standard_normal((nc, 2)), rng.standard_normal((nb, 2))
    Fb, grad_u = rng.standard_normal(nb), rng.standard_normal((nc, 2, 2))
    mu = rng.uniform(0.1, 1.0, nb) if per_face else 0.3
    for new, ref in zip(_boundary(mesh, bnd, u, u_b, Fb, grad_u, mu),
                        _momentum_boundary_numpy(mesh, bnd, u, u_b, Fb, grad_u, mu), strict=True):
        np.testing.assert_array_equal(new, ref)


def test_spd_condition_bound_brackets_the_condition_number():
    """The Cholesky screen of the quadratic fit's conditioning: between cond and 25 cond (5 x 5), inf where the
    matrix is not positive definite or not asked for."""
    from solver.kernels import spd_condition_bound

    rng = np.random.default_rng(3)
    a = rng.standard_normal((300, 12, 5)) * np.logspace(0, 4, 5)
    normal = np.einsum("cki,ckj->cij", a, a)
    normal[0] = 0.0
    normal[1] = np.diag([1.0, 1.0, 1.0, 1.0, -1.0])
    use = np.ones(300, dtype=bool)
    use[2] = False
    bound = spd_condition_bound(normal, use)
    assert np.isinf(bound[:3]).all()
    ratio = bound[3:] / np.linalg.cond(normal[3:])
    assert ratio.min() >= 1.0 - 1e-12 and ratio.max() <= 25.0


def test_quadratic_face_rows_equal_scipy_sums(mesh):
    """The face-average operator's compiled assembly against the twelve scipy products it replaces (sorted
    CSR, bitwise), on random operators of the mesh's shape."""
    from solver.kernels import quadratic_face_rows

    rng = np.random.default_rng(4)
    nc, ni, nb = mesh.n_cells, mesh.n_internal, mesh.n_boundary
    n_all = nc + nb
    ops = [sp.random(nc, n_all, density=0.02, random_state=rng, format="csr") for _ in range(5)]
    ops = [(op - sp.diags(np.asarray(op.sum(axis=1)).ravel(), shape=(nc, n_all))).tocsr() for op in ops]
    cells = np.stack([mesh.owner[:ni], mesh.neighbour[:ni]])
    weights = np.stack([mesh.weight[:ni], 1.0 - mesh.weight[:ni]])
    coefficients = rng.standard_normal((2, 5, ni))
    sel_i = sp.hstack([sp.identity(nc, format="csr"), sp.csr_matrix((nc, nb))]).tocsr()
    face = None
    for s in range(2):
        sel = sp.csr_matrix((weights[s], (np.arange(ni), cells[s])), (ni, nc))
        for mat, c in [(sel_i, None)] + list(zip(ops, coefficients[s], strict=True)):
            part = sel @ mat if c is None else sp.diags(c) @ (sel @ mat)
            face = part if face is None else face + part
    indptr, indices, data = quadratic_face_rows(
        n_all, 2, weights, cells, coefficients, np.stack([op.indptr.astype(np.int64) for op in ops]),
        tuple(op.indices.astype(np.int64) for op in ops), tuple(op.data for op in ops))
    face = face.tocsr()
    assert face.has_sorted_indices
    assert np.array_equal(indptr, face.indptr) and np.array_equal(indices, face.indices)
    assert data.tobytes() == face.data.tobytes()


def test_stencil_operator_rows_equal_scipy_difference():
    """The quadratic fit's operator rows against scipy's ``csr(values) - csr(diag(row sums))`` (sorted CSR,
    zeros dropped, bitwise), with zero values and a zero row sum among them."""
    from solver.kernels import stencil_operator_rows

    rng = np.random.default_rng(5)
    nc, n_all, kmax = 60, 75, 9
    counts = rng.integers(1, kmax, nc)
    rows = [np.sort(rng.choice(np.setdiff1d(np.arange(n_all), [c]), k, replace=False)) for c, k in enumerate(counts)]
    indptr, indices = np.concatenate([[0], np.cumsum(counts)]), np.concatenate(rows)
    cell_of = np.repeat(np.arange(nc), counts)
    valid = np.zeros((nc, kmax), dtype=bool)
    valid[cell_of, np.arange(indices.size) - indptr[cell_of]] = True
    vals = np.where(valid, rng.standard_normal((nc, kmax)), 0.0)
    vals[3] = 0.0
    vals[7, 1:] = 0.0
    ref = (sp.csr_matrix((vals[valid], (cell_of, indices)), (nc, n_all))
           - sp.csr_matrix((vals.sum(axis=1), (np.arange(nc), np.arange(nc))), (nc, n_all))).tocsr()
    got = stencil_operator_rows(indptr.astype(np.int64), indices.astype(np.int64), vals, vals.sum(axis=1))
    assert np.array_equal(got[0], ref.indptr) and np.array_equal(got[1], ref.indices)
    assert got[2].tobytes() == ref.data.tobytes()


def test_merge_row_pairs_equals_unique_form():
    """Row pairs of a sorted CSR matrix merged: the arrays of the ``np.unique`` / ``searchsorted`` form."""
    from solver.kernels import merge_row_pairs

    op = sp.random(40, 30, density=0.2, random_state=np.random.default_rng(6), format="csr")
    op.sort_indices()
    n, m = op.shape[0] // 2, op.shape[1]
    row = np.repeat(np.arange(op.shape[0]), np.diff(op.indptr))
    key = (row // 2) * m + op.indices
    union = np.unique(key)
    values = np.zeros((union.size, 2))
    values[np.searchsorted(union, key), row % 2] = op.data
    indptr, indices, got = merge_row_pairs(op.indptr.astype(np.int64), op.indices.astype(np.int64), op.data)
    assert np.array_equal(indptr, np.searchsorted(union, np.arange(n + 1) * m))
    assert np.array_equal(indices, union % m) and got.tobytes() == values.tobytes()


@pytest.mark.parametrize("k", [6, 13, 31])
def test_normal_matrices_equal_einsum(k):
    """The stacked normal matrices of the quadratic fit against ``np.einsum("cki,ckj->cij")`` (bitwise)."""
    from solver.kernels import normal_matrices

    rng = np.random.default_rng(k)
    a = rng.standard_normal((200, k, 5))
    a[:, k // 2:] *= rng.random((200, 1, 1)) < 0.5               # zero-padded stencils, as the fit's
    aw = a * rng.uniform(0.1, 3.0, (200, k, 1))
    assert normal_matrices(aw, a).tobytes() == np.einsum("cki,ckj->cij", aw, a).tobytes()


def test_quadratic_fit_tables_equal_numpy_form(mesh):
    """The quadratic fit's padded design matrices against the numpy lines they replace (bitwise)."""
    from solver.kernels import quadratic_fit_tables

    rng = np.random.default_rng(7)
    nc, kmax = mesh.n_cells, 14
    xall = np.concatenate([mesh.centroid, mesh.face_centre[mesh.n_internal:]])
    other = rng.integers(0, len(xall), (nc, kmax))
    other[other == np.arange(nc)[:, None]] = nc                  # never the cell itself
    valid = rng.random((nc, kmax)) < 0.7
    h = np.sqrt(mesh.volume)
    s = np.where(valid[..., None], (xall[other] - mesh.centroid[:, None, :]) / h[:, None, None], 0.0)
    a = np.stack([s[..., 0], s[..., 1], 0.5 * s[..., 0] ** 2, s[..., 0] * s[..., 1], 0.5 * s[..., 1] ** 2], -1)
    w = np.where(valid, 1.0 / np.where(valid, np.einsum("ckj,ckj->ck", s, s), 1.0), 0.0)
    got_a, got_aw = quadratic_fit_tables(xall, mesh.centroid, h, other, valid)
    assert got_a.tobytes() == a.tobytes() and got_aw.tobytes() == (a * w[..., None]).tobytes()
