"""The AMG hierarchy with refreshed Galerkin operators (:mod:`solver.amg`) and its use by the pressure CG."""

import numpy as np
import pytest
import scipy.sparse as sp

from solver.amg import GalerkinHierarchy, galerkin_map
from solver.linalg import AMG_HIERARCHIES, FVPattern, LinearSystem, VCycle, _amg_cg, _seeded, _with_fast_smoothers
from solver.validation.meshes import square_mesh


@pytest.fixture(scope="module")
def mesh():
    return square_mesh(24, triangles="checker", strength=0.4, distort=0.3, seed=5)


def pressure_like_system(mesh, seed: int) -> LinearSystem:
    """A pinned FV Laplacian with random face coefficients (as the p' system without an outlet), random rhs;
    the same pattern for every seed."""
    rng = np.random.default_rng(seed)
    c = rng.uniform(0.5, 2.0, mesh.n_internal)
    o, n = mesh.owner[:mesh.n_internal], mesh.neighbour[:mesh.n_internal]
    diag = np.bincount(o, c, mesh.n_cells) + np.bincount(n, c, mesh.n_cells)
    diag[0] *= 2.0
    pattern = mesh.info.setdefault("test_pattern", FVPattern.from_mesh(mesh))
    return LinearSystem(pattern.matrix(diag, -c, -c), rng.standard_normal(mesh.n_cells), np.zeros(mesh.n_cells),
                        pattern)


@pytest.mark.parametrize("symmetric", [False, True])
def test_galerkin_map_equals_triple_product(mesh, symmetric):
    """``G A.data`` (and the mirrored entries) equals scipy's ``P^T A P`` for a matrix other than the one the
    interpolation was built on, on every level; a non-symmetric ``A`` with ``symmetric=False``."""
    A = pressure_like_system(mesh, 1).A
    ml = _seeded(AMG_HIERARCHIES["ruge_stuben"], A)
    assert len(ml.levels) >= 3
    B = pressure_like_system(mesh, 2).A
    if not symmetric:
        B = B.copy()
        B.data *= np.random.default_rng(3).uniform(0.5, 1.5, B.nnz)
    indptr, indices, data = B.indptr, B.indices, B.data
    for lvl in ml.levels[:-1]:
        G, rows, c_indptr, c_indices, mirror = galerkin_map(indptr, indices, lvl.P, symmetric)
        coarse = np.empty(c_indices.size)
        coarse[rows] = G @ data
        coarse[mirror[0]] = coarse[mirror[1]]
        mine = sp.csr_matrix((coarse, c_indices, c_indptr), shape=(lvl.P.shape[1],) * 2)
        ref = (lvl.P.T @ sp.csr_matrix((data, indices, indptr), shape=(lvl.P.shape[0],) * 2) @ lvl.P).tocsr()
        assert abs(mine - ref).max() <= 1e-13 * abs(ref).max()
        assert symmetric == (mirror.shape[1] > 0)
        indptr, indices, data = c_indptr, c_indices, coarse


def galerkin_map_numpy(indptr: np.ndarray, indices: np.ndarray, P: sp.csr_matrix, symmetric: bool = False):
    """:func:`solver.amg.galerkin_map` in the sort-based numpy form it replaced (``np.unique`` over every
    product's key), kept as its reference: the same returns."""
    n = indptr.size - 1
    rows = np.repeat(np.arange(n), np.diff(indptr))
    cols = np.asarray(indices, dtype=np.int64)
    P = P.tocsr()
    p_len = np.diff(P.indptr)
    len_i, len_j = p_len[rows], p_len[cols]
    count = len_i * len_j                           # products P[i, I] A[i, j] P[j, J] per entry (i, j)
    entry = np.repeat(np.arange(cols.size), count)
    offset = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    per_row = len_j[entry]
    slot_i = P.indptr[rows[entry]] + offset // per_row
    slot_j = P.indptr[cols[entry]] + offset % per_row
    n_c = P.shape[1]
    big_i, big_j = P.indices[slot_i].astype(np.int64), P.indices[slot_j].astype(np.int64)
    coarse, position = np.unique(big_i * n_c + big_j, return_inverse=True)
    position = position.ravel()
    c_rows, c_cols = coarse // n_c, coarse % n_c
    c_indptr = np.concatenate([[0], np.cumsum(np.bincount(c_rows, minlength=n_c))])
    if symmetric:
        formed = np.flatnonzero(c_rows <= c_cols)
        copied = np.flatnonzero(c_rows > c_cols)
        source = np.searchsorted(coarse, c_cols[copied] * n_c + c_rows[copied])
        if not np.array_equal(coarse[source], c_cols[copied] * n_c + c_rows[copied]):
            raise ValueError("the coarse pattern is not symmetric")
        keep = big_i <= big_j
        row_of = np.full(coarse.size, -1, dtype=np.int64)
        row_of[formed] = np.arange(formed.size)
        G = sp.csr_matrix((P.data[slot_i[keep]] * P.data[slot_j[keep]], (row_of[position[keep]], entry[keep])),
                          shape=(formed.size, cols.size))
        mirror = np.stack([copied, source])
    else:
        formed = np.arange(coarse.size)
        G = sp.csr_matrix((P.data[slot_i] * P.data[slot_j], (position, entry)), shape=(coarse.size, cols.size))
        mirror = np.zeros((2, 0), dtype=np.int64)
    return G, formed, c_indptr, c_cols, mirror


@pytest.mark.parametrize("symmetric", [False, True])
def test_galerkin_map_equals_its_numpy_form(mesh, symmetric):
    """The compiled Galerkin map (row by row) against the sort-based numpy form: every returned array equal,
    ``G``'s values bitwise, on every level."""
    A = pressure_like_system(mesh, 1).A
    ml = _seeded(AMG_HIERARCHIES["ruge_stuben"], A)
    indptr, indices = A.indptr, A.indices
    for lvl in ml.levels[:-1]:
        ref = galerkin_map_numpy(indptr, indices, lvl.P, symmetric)
        got = galerkin_map(indptr, indices, lvl.P, symmetric)
        assert np.array_equal(got[0].indptr, ref[0].indptr) and np.array_equal(got[0].indices, ref[0].indices)
        assert got[0].shape == ref[0].shape and got[0].data.tobytes() == ref[0].data.tobytes()
        for a, b in zip(got[1:], ref[1:], strict=True):
            assert np.array_equal(a, b)
        indptr, indices = ref[2], ref[3]


def test_refreshed_cycle_equals_v_cycle_of_the_new_galerkin_operators(mesh):
    """After :meth:`GalerkinHierarchy.refresh` with another matrix, the cycle is :class:`VCycle` on a
    hierarchy with the same interpolation and the exact Galerkin operators of that matrix (to round-off:
    Cholesky instead of pinv on the coarsest level)."""
    from pyamg.multilevel import MultilevelSolver

    A = pressure_like_system(mesh, 1).A
    ml = _seeded(AMG_HIERARCHIES["ruge_stuben"], A)
    new = pressure_like_system(mesh, 4)
    levels, B = [], new.A
    for lvl in ml.levels[:-1]:
        level = MultilevelSolver.Level()
        level.A, level.P, level.R = B, lvl.P, lvl.R
        levels.append(level)
        B = (lvl.R @ B @ lvl.P).tocsr()
    last = MultilevelSolver.Level()
    last.A = B
    reference = VCycle(_with_fast_smoothers(MultilevelSolver(levels + [last], coarse_solver="pinv")))
    cycle = GalerkinHierarchy(ml, A.indptr, A.indices, symmetric=True)
    assert cycle.matches(new.A)
    cycle.refresh(new.A.data)
    np.testing.assert_allclose(cycle(new.b), reference(new.b), rtol=1e-10, atol=1e-12 * np.abs(reference(new.b)).max())


def test_amg_cg_galerkin_keeps_one_set_up_and_meets_the_tolerance(mesh):
    """``galerkin=True``: one set-up for a sequence of matrices of one pattern, each solve to ``tol``;
    ``rebuild_above`` forces a new set-up after a solve above that many CG iterations."""
    state: dict = {}
    first = None
    for seed in range(5):
        system = pressure_like_system(mesh, seed)
        x, stats = _amg_cg(system, 1e-8, 100, state, rebuild_every=1000, galerkin=True)
        assert np.linalg.norm(system.b - system.A @ x) <= 1e-8 * np.linalg.norm(system.b)
        assert 0 < stats.iterations < 30
        first = state["ml"] if first is None else first
        assert state["ml"] is first and isinstance(state["precondition"], GalerkinHierarchy)
    _amg_cg(pressure_like_system(mesh, 7), 1e-8, 100, state, rebuild_every=1000, galerkin=True, rebuild_above=0)
    assert state["ml"] is not first


def test_amg_cg_refresh_after_reuses_the_first_set_up_as_built(mesh):
    """``refresh_after=2``: the first two calls solve with the operators of the first matrix, the third
    refreshes them from its own."""
    state: dict = {}
    systems = [pressure_like_system(mesh, seed) for seed in range(3)]
    for k, system in enumerate(systems):
        _amg_cg(system, 1e-8, 100, state, rebuild_every=1000, galerkin=True, rebuild_above=0, refresh_after=2)
        np.testing.assert_array_equal(state["precondition"].levels[0].data, systems[0 if k < 2 else 2].A.data)


@pytest.mark.parametrize("tol", [0.5, 0.1, 1e-3])
def test_gauss_seidel_to_tol_stops_at_the_first_sweep_below_tol(tol):
    """``gauss_seidel_to_tol`` does the fewest symmetric sweeps that bring the residual's 1-norm to ``tol``
    times the initial one (bitwise ``gauss_seidel`` with that many sweeps), at most ``maxiter``; none from
    an exact solution."""
    from solver.linalg import FVPattern, LinearSystem, SolverSettings
    from solver.validation.meshes import square_mesh

    mesh = square_mesh(8, triangles="checker", strength=0.4, distort=0.3, seed=5, size=2.0)
    rng = np.random.default_rng(4)
    pattern = FVPattern.from_mesh(mesh)
    ni, nc = mesh.n_internal, mesh.n_cells
    A = pattern.matrix(4.0 + rng.uniform(0, 1, nc), -rng.uniform(0.1, 1.0, ni), -rng.uniform(0.1, 1.0, ni))
    system = LinearSystem(A, rng.standard_normal(nc), rng.standard_normal(nc), pattern)
    x, stats = SolverSettings("gauss_seidel_to_tol", tol, 50).solve(system)
    r0 = np.abs(system.residual()).sum()
    assert np.abs(system.residual(x)).sum() <= tol * r0 and stats.iterations >= 1
    np.testing.assert_array_equal(x, SolverSettings("gauss_seidel", tol, stats.iterations).solve(system)[0])
    if stats.iterations > 1:
        fewer = SolverSettings("gauss_seidel", tol, stats.iterations - 1).solve(system)[0]
        assert np.abs(system.residual(fewer)).sum() > tol * r0
    capped, capped_stats = SolverSettings("gauss_seidel_to_tol", 1e-30, 3).solve(system)
    assert capped_stats.iterations == 3
    np.testing.assert_array_equal(capped, SolverSettings("gauss_seidel", 0.1, 3).solve(system)[0])
    exact = LinearSystem(A, A @ x, x.copy(), pattern)
    assert SolverSettings("gauss_seidel_to_tol", tol, 8).solve(exact)[1].iterations in (0, 1)
