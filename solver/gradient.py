"""Cell gradients (weighted least squares), slope limiters and face interpolation, vectorised over cells.

A gradient needs the cell values ``phi (nc,)`` and the boundary-face values ``phi_b (nb,)`` (the value at
each boundary face centre, supplied by the boundary conditions). The least-squares stencil is the face
neighbours of each cell plus its boundary-face centres; it is exact for linear fields on any mesh.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .fvmesh import FVMesh
from .kernels import (
    CompiledCSR,
    clip_to_cells,
    interpolate_faces,
    interpolate_faces_1,
    interpolate_faces_2,
    merge_row_pairs,
    normal_matrices,
    paired_row_gradient,
    quadratic_face_rows,
    quadratic_fit_tables,
    spd_condition_bound,
    stencil_operator_rows,
    unsigned,
)


def extended(phi: np.ndarray, phi_b: np.ndarray) -> np.ndarray:
    """``concat(phi (nc, ...), phi_b (nb, ...))``: the array :attr:`FVMesh.cell_other` indexes."""
    return np.concatenate([phi, phi_b])


def ls_gradient(mesh: FVMesh, phi: np.ndarray, phi_b: np.ndarray) -> np.ndarray:
    """Least-squares cell gradient ``(nc, ..., 2)`` of ``phi (nc, ...)`` (units of phi per metre).

    ``phi_b``: values at the boundary-face centres ``(nb, ...)``. Exact for a linear field. A vector
    field ``(nc, 2)`` gives ``grad[c, component, direction]``. The sum of two sparse products with the
    operators of :func:`ls_operators` (the weighted sum ``sum_k ls_weights[c, k] (phi_k - phi_c)`` of
    :attr:`FVMesh.ls_weights`, equal to it up to round-off), in one compiled pass over the cells on their
    paired-row form (:func:`solver.kernels.paired_row_gradient`, bitwise the two products).
    """
    nc, nb = mesh.n_cells, mesh.n_boundary
    cells, faces = paired_ls_operators(mesh)
    g = paired_row_gradient(*cells, *faces, np.ascontiguousarray(phi, dtype=float).reshape(nc, -1),
                            np.ascontiguousarray(phi_b, dtype=float).reshape(nb, -1))
    return g.reshape(phi.shape + (2,))


def ls_operators(mesh: FVMesh):
    """The least-squares gradient as two sparse matrices (built once per mesh, cached in ``mesh.info``;
    :class:`solver.kernels.CompiledCSR`, whose ``matrix`` is the scipy CSR): ``(cell (2 nc, nc), boundary
    (2 nc, nb))``, row ``2 c + i`` giving direction ``i`` of cell ``c``'s gradient from the cell values and
    from the boundary-face values, 1/m.

    Why: the gradient is linear in the values, and one compiled sparse product replaces the gather of the
    ``(nc, 4)`` stencil values and an ``einsum`` over it (about 5x faster per call, ~11 calls per outer
    iteration)."""
    cached = mesh.info.get("ls_operators")
    if cached is not None:
        return cached
    import scipy.sparse as sp

    nc, nb = mesh.n_cells, mesh.n_boundary
    w = mesh.ls_weights                                                  # (nc, 4, 2)
    rows = (2 * np.arange(nc)[:, None, None] + np.arange(2)[None, None, :]) * np.ones_like(w, dtype=np.int64)
    cols = np.broadcast_to(mesh.cell_other[:, :, None], w.shape)
    diag_rows = 2 * np.arange(nc)[:, None] + np.arange(2)[None, :]       # -sum_k w[c, k, i] on column c
    diag_cols = np.broadcast_to(np.arange(nc)[:, None], (nc, 2))
    r = np.concatenate([rows.ravel(), diag_rows.ravel()])
    c = np.concatenate([cols.ravel(), diag_cols.ravel()])
    v = np.concatenate([w.ravel(), -w.sum(axis=1).ravel()])
    full = sp.csr_matrix((v, (r, c)), shape=(2 * nc, nc + nb))
    full.sum_duplicates()
    full.eliminate_zeros()
    out = (CompiledCSR(full[:, :nc]), CompiledCSR(full[:, nc:]))
    mesh.info["ls_operators"] = out
    return out


def paired_ls_operators(mesh: FVMesh):
    """The two operators of :func:`ls_operators` with the rows of both directions of a cell merged
    (:func:`paired_rows`): ``((indptr, indices, values) of the cell part, (...) of the boundary part)``,
    cached in ``mesh.info``. Why: a cell's two rows hold the same columns, so one pass reads each value once
    for both directions (the gradient of a vector field in 0.2 instead of 0.4 ms at 16 641 cells)."""
    cached = mesh.info.get("paired_ls_operators")
    if cached is None:
        cached = mesh.info["paired_ls_operators"] = tuple(paired_rows(op.matrix) for op in ls_operators(mesh))
    return cached


def paired_rows(op) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A CSR matrix ``(2 n, m)`` (sorted columns) as ``n`` paired rows: ``indptr (n + 1,)`` and ``indices``
    (unsigned) of the union of the columns of rows ``2 i`` and ``2 i + 1`` in ascending order, and ``values
    (nnz, 2)``: the two rows' entries, 0 on a column only the other row has."""
    op = op.tocsr()
    op.sort_indices()
    indptr, indices, values = merge_row_pairs(op.indptr.astype(np.int64), op.indices.astype(np.int64),
                                              np.asarray(op.data, dtype=float))
    return unsigned(indptr), unsigned(indices), values


def neighbour_bounds(mesh: FVMesh, phi: np.ndarray, phi_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(max, min)`` over each cell and its face neighbours (boundary-face values included)."""
    vals = extended(phi, phi_b)[mesh.cell_other]
    return np.maximum(vals.max(axis=1), phi), np.minimum(vals.min(axis=1), phi)


def _barth_jespersen(mesh, phi, phi_b, grad, k):
    """Barth & Jespersen (1989): ``psi = min_f min(1, Δmax/Δ_f)`` (or Δmin for negative Δ_f)."""
    if phi.ndim > 1:
        return np.stack([_barth_jespersen(mesh, phi[:, i], phi_b[:, i], grad[:, i], k)
                         for i in range(phi.shape[1])], axis=1)
    pmax, pmin = neighbour_bounds(mesh, phi, phi_b)
    delta = np.einsum("cki,ci->ck", mesh.cell_r, grad)
    dmax = (pmax - phi)[:, None]
    dmin = (pmin - phi)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(delta > 0, dmax / delta, np.where(delta < 0, dmin / delta, 1.0))
    return np.clip(ratio, 0.0, 1.0).min(axis=1)


def _venkatakrishnan(mesh, phi, phi_b, grad, k):
    """Venkatakrishnan (1995) smooth limiter with ``eps² = (k h)³``, ``h = sqrt(cell area)``.

    ``k`` (default 5) trades monotonicity (small k) for accuracy in smooth regions (large k). Per cell,
    with ``Δ_f = grad·(x_f - x_P)`` and ``d1`` the distance to the neighbourhood's max (``Δ_f >= 0``) or min:
    ``psi = min_f clip(((d1² + eps²) Δ_f + 2 Δ_f² d1) / ((d1² + 2 Δ_f² + d1 Δ_f + eps²) Δ_f), 0, 1)``; one
    compiled loop over the cells (:func:`solver.kernels.venkatakrishnan`), about 10x the numpy form's speed.
    """
    eps2 = mesh.info.get(("venkatakrishnan_eps2", k))
    if eps2 is None:
        eps2 = mesh.info[("venkatakrishnan_eps2", k)] = (k * mesh.cell_size()) ** 3
    flat = np.ascontiguousarray(phi, dtype=float).reshape(mesh.n_cells, -1)
    return _venkatakrishnan_psi(mesh, flat, phi_b, grad, eps2, np.zeros(flat.shape[1])).reshape(phi.shape)


def _venkatakrishnan_psi(mesh, flat, phi_b, grad, eps2_cell, eps2_component):
    """``psi (nc, m)`` of Venkatakrishnan's limiter function for ``flat (nc, m)`` with ``eps² = eps2_cell (nc,)
    + eps2_component (m,)`` (one of them zero): one compiled loop over the cells
    (:func:`solver.kernels.venkatakrishnan`)."""
    from .kernels import venkatakrishnan

    nc, nb = mesh.n_cells, mesh.n_boundary
    return venkatakrishnan(flat, np.ascontiguousarray(phi_b, dtype=float).reshape(nb, -1), mesh.cell_other,
                           mesh.cell_r, np.ascontiguousarray(grad, dtype=float).reshape(nc, -1, 2),
                           np.ascontiguousarray(eps2_cell, dtype=float),
                           np.ascontiguousarray(eps2_component, dtype=float))


#: Scale of the limiter's ``k`` in :func:`_venkatakrishnan_wang`: ``K' = (k WANG_K_SCALE)^(3/2)``.
WANG_K_SCALE = 0.01


def _venkatakrishnan_wang(mesh, phi, phi_b, grad, k):
    """Venkatakrishnan's limiter with Wang's ``eps``: ``eps = K' (max phi - min phi)``, the range of each
    component over the whole field (cells and boundary faces), with ``K' = (k / 100)^(3/2)``, i.e.
    ``eps² = (k / 100)³ (max - min)²``: Venkatakrishnan's ``(K h)³`` with a fixed nondimensional ``h``
    of 1/100 instead of the cell size, in units of the field's range (SU2's ``VENKATAKRISHNAN`` likewise
    uses a fixed reference length, on variables scaled by the free stream). ``limiter_k`` 5, 10, 13.6,
    20 give ``K'`` = 0.011, 0.032, 0.050, 0.089 (SU2's ``VENKATAKRISHNAN_WANG`` default is 0.05), and
    ``k -> 0`` the bounded min-max limit (``eps ∝ k^(3/2)``).

    The limiter function is :func:`_venkatakrishnan`'s; only ``eps`` differs. Venkatakrishnan's
    ``eps² = (K h)³`` (Venkatakrishnan 1995, J. Comput. Phys. 118, 120-130) compares m³ with the square of
    the field's unit, so how strongly it limits depends on the units and the scale of the problem; in
    the leading-edge boundary layer of the NACA 0012 case (c = 1 m, U = 1 m/s, h = √area of the thin
    wall cells) it is ~1e-4 U against neighbour differences of ~0.1 U, a min-max limiter there
    (docs/explanation/validation.md), and on the blades (C0 = 10 m/s,
    chord ~0.1 m) relatively stronger still. Wang's ``eps`` is a fraction of the field's own range: ``psi`` is
    unchanged when the field is scaled or offset (any unit, any speed) and when the mesh is scaled (any
    length unit); differences between neighbours well below ``eps`` (smooth, resolved variation: the outer
    flow, a resolved shear layer) pass nearly unlimited, while those of the order of the range (the
    potential start's slip velocity meeting the no-slip wall, a front a few cells wide) are limited as
    by Venkatakrishnan's function with ``eps -> 0``. Not strictly monotone: a reconstruction may
    overshoot the neighbourhood by up to ``eps / √8``.

    References: Z. J. Wang, "A fast nested multi-grid viscous flow solver for adaptive Cartesian/quad
    grids", AIAA Paper 96-2091 (1996), Int. J. Numer. Meth. Fluids 33 (2000) 657-680; SU2's
    ``SLOPE_LIMITER_FLOW= VENKATAKRISHNAN_WANG`` (``eps = VENKAT_LIMITER_COEFF (q_max - q_min)`` over the
    domain, su2code.github.io, "Gradients and limiters"); on the choice of ``eps`` and the loss of
    accuracy where Venkatakrishnan's limiter acts in smooth regions, K. Michalak and C. Ollivier-Gooch,
    "Limiters for unstructured higher-order accurate solutions of the Euler equations", AIAA Paper
    2008-776. One compiled loop over the cells (:func:`solver.kernels.venkatakrishnan`, as Venkatakrishnan's).
    """
    nc, nb = mesh.n_cells, mesh.n_boundary
    flat = np.ascontiguousarray(phi, dtype=float).reshape(nc, -1)
    flat_b = np.ascontiguousarray(phi_b, dtype=float).reshape(nb, -1)
    hi, lo = flat.max(axis=0), flat.min(axis=0)
    if nb:
        hi, lo = np.maximum(hi, flat_b.max(axis=0)), np.minimum(lo, flat_b.min(axis=0))
    eps2 = (k * WANG_K_SCALE) ** 3 * (hi - lo) ** 2
    return _venkatakrishnan_psi(mesh, flat, flat_b, grad, np.zeros(nc), eps2).reshape(phi.shape)


def _no_limiter(mesh, phi, phi_b, grad, k):
    """No limiting (``psi = 1``)."""
    return np.ones_like(phi)


#: Limiters by name: ``f(mesh, phi, phi_b, grad, k) -> psi`` in [0, 1], ``(nc,)`` for a scalar ``phi (nc,)``,
#: ``(nc, m)`` per component for ``phi (nc, m)`` (``grad (nc, m, 2)``).
LIMITERS: dict[str, Callable] = {
    "venkatakrishnan": _venkatakrishnan,
    "venkatakrishnan_wang": _venkatakrishnan_wang,
    "barth_jespersen": _barth_jespersen,
    "none": _no_limiter,
}


def limited_gradient(mesh: FVMesh, phi, phi_b, grad=None, limiter: str = "venkatakrishnan",
                     k: float = 5.0) -> np.ndarray:
    """``psi * grad`` with ``psi`` from the named limiter in :data:`LIMITERS` (``grad`` computed if None);
    ``phi`` a scalar ``(nc,)`` or a vector ``(nc, m)`` field (each component limited on its own)."""
    if grad is None:
        grad = ls_gradient(mesh, phi, phi_b)
    try:
        fn = LIMITERS[limiter]
    except KeyError:
        raise ValueError(f"unknown limiter {limiter!r}; choose from {sorted(LIMITERS)}") from None
    return grad * fn(mesh, phi, phi_b, grad, k)[..., None]


def interpolate_linear(mesh: FVMesh, phi: np.ndarray) -> np.ndarray:
    """Linear interpolation of cell values ``(nc, ...)`` (a field, a gradient, a coefficient) to the internal
    faces ``(ni, ...)``: ``w phi_P + (1 - w) phi_N`` with the distance weights :attr:`FVMesh.weight`. The one
    plain face interpolation of the solver; :func:`interpolate_corrected` adds the skewness correction and
    :func:`face_average` the quadratic face mean. One compiled loop over the faces
    (:func:`solver.kernels.interpolate_faces`, bitwise the product with the ``"linear"`` operator of
    :func:`face_operators`)."""
    flat = np.ascontiguousarray(phi, dtype=float).reshape(mesh.n_cells, -1)
    m = flat.shape[1]
    if m == 1:
        out = interpolate_faces_1(*linear_weights(mesh), flat[:, 0])
    else:
        out = (interpolate_faces_2 if m == 2 else interpolate_faces)(*linear_weights(mesh), flat)
    return out.reshape((mesh.n_internal,) + phi.shape[1:])


def linear_weights(mesh: FVMesh) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(w, 1 - w, owner, neighbour)`` ``(ni,)`` of the internal faces (cached in ``mesh.info``; unsigned
    indices, :func:`solver.kernels.unsigned`): the arguments of the compiled face interpolations
    (:func:`solver.kernels.interpolate_faces`)."""
    cached = mesh.info.get("linear_weights")
    if cached is None:
        ni = mesh.n_internal
        w = np.ascontiguousarray(mesh.weight[:ni], dtype=float)
        cached = mesh.info["linear_weights"] = (w, 1.0 - w, unsigned(mesh.owner[:ni]), unsigned(mesh.neighbour[:ni]))
    return cached


def interpolate_corrected(mesh: FVMesh, phi: np.ndarray, grad: np.ndarray) -> np.ndarray:
    """Face-centre values on internal faces from both sides' linear reconstructions::

        phi_f = w (phi_P + grad_P·(x_f - x_P)) + (1 - w) (phi_N + grad_N·(x_f - x_N))

    ``phi (nc, ...)``, ``grad (nc, ..., 2)``. Exact for linear fields on skewed meshes, where plain
    linear interpolation along P-N misses the face centre (a first-order skewness error). One sparse
    product on the stacked values and gradient components (:func:`face_operators`).
    """
    nc = mesh.n_cells
    stacked = np.concatenate([phi.reshape(nc, -1), grad[..., 0].reshape(nc, -1), grad[..., 1].reshape(nc, -1)])
    return (face_operators(mesh)["corrected"] @ stacked).reshape((mesh.n_internal,) + phi.shape[1:])


def face_operators(mesh: FVMesh) -> dict:
    """Sparse internal-face interpolation operators (built once per mesh, cached in ``mesh.info``):
    ``"linear"`` ``(ni, nc)`` with ``w`` and ``1 - w`` on the owner and neighbour columns, and
    ``"corrected"`` ``(ni, 3 nc)`` acting on ``concat(phi, d phi/dx, d phi/dy)``: the linear operator and
    the reconstruction terms ``w (x_f - x_P)`` and ``(1 - w) (x_f - x_N)``; and ``"d_length"`` ``(nf,)``,
    ``|d|`` of every face, m. Why: a compiled sparse product (:class:`solver.kernels.CompiledCSR`)
    instead of gathers, ``einsum`` and temporaries per call (the face velocity is built twice per
    iteration)."""
    cached = mesh.info.get("face_operators")
    if cached is not None:
        return cached
    import scipy.sparse as sp

    nc, ni = mesh.n_cells, mesh.n_internal
    o, n = mesh.owner[:ni], mesh.neighbour[:ni]
    w = mesh.weight[:ni]
    rows = np.concatenate([np.arange(ni), np.arange(ni)])
    cols = np.concatenate([o, n])
    linear = sp.csr_matrix((np.concatenate([w, 1.0 - w]), (rows, cols)), shape=(ni, nc))
    xf = mesh.face_centre[:ni]
    ro, rn = w[:, None] * (xf - mesh.centroid[o]), (1.0 - w)[:, None] * (xf - mesh.centroid[n])
    parts = [linear] + [sp.csr_matrix((np.concatenate([ro[:, d], rn[:, d]]), (rows, cols)), shape=(ni, nc))
                        for d in range(2)]
    out = {"linear": CompiledCSR(linear), "corrected": CompiledCSR(sp.hstack(parts, format="csr")),
           "d_length": np.linalg.norm(mesh.d, axis=1)}
    mesh.info["face_operators"] = out
    return out


def green_gauss_gradient(mesh: FVMesh, phi: np.ndarray, phi_b: np.ndarray, grad: np.ndarray,
                         bounded: bool = False) -> np.ndarray:
    """Green–Gauss cell gradient ``(nc, ..., 2)`` of ``phi (nc, ...)``: ``(1/V) sum_f phi_f S_f`` with the face
    values of :func:`interpolate_corrected` (reconstructed from both sides with ``grad (nc, ..., 2)``, e.g.
    the least-squares gradient) and ``phi_b (nb, ...)`` on boundary faces. Exact for linear fields; being a
    sum of face terms, its truncation errors telescope between neighbours (a conservative pressure force).
    ``bounded``: each internal face value clipped to the range of its two cells' values (a reconstruction
    that cannot overshoot, e.g. the log layer's concave profile extrapolated from a wall cell)."""
    phi_f = interpolate_corrected(mesh, phi, grad)
    if bounded:
        phi_f = bound_to_cells(mesh, phi_f, phi)
    return gauss_sum(mesh, np.concatenate([phi_f, phi_b]))


def bound_to_cells(mesh: FVMesh, phi_f: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Internal-face values ``phi_f (ni, ...)``, each component clipped to the range of its owner's and neighbour's
    values ``phi (nc, ...)`` (one compiled pass, :func:`solver.kernels.clip_to_cells`)."""
    _, _, owner, neighbour = linear_weights(mesh)
    faces = np.ascontiguousarray(phi_f.reshape(mesh.n_internal, -1), dtype=float)
    cells = np.ascontiguousarray(phi.reshape(len(phi), -1), dtype=float)
    return clip_to_cells(faces, cells, owner, neighbour).reshape(phi_f.shape)


def green_gauss_linear_gradient(mesh: FVMesh, phi: np.ndarray, phi_b: np.ndarray, grad=None) -> np.ndarray:
    """Green–Gauss cell gradient ``(nc, 2)`` on plain linear face values ``w phi_P + (1 - w) phi_N`` (OpenFOAM's
    ``Gauss linear``; ``grad`` is not used). Not exact on skewed meshes (the face centre is off the P-N line),
    but its face values depend on the two cells alone: the corrected values of :func:`green_gauss_gradient`
    bring in the neighbours' gradients, and as the momentum source's pressure gradient they made table5's
    nose a limit cycle that OpenFOAM does not have (docs/decisions/0006-green-gauss-relaxation.md)."""
    return gauss_sum(mesh, np.concatenate([interpolate_linear(mesh, phi), phi_b]))


def gauss_sum(mesh: FVMesh, phi_f: np.ndarray) -> np.ndarray:
    """``(1/V) sum_f phi_f S_f`` per cell, ``(nc, ..., 2)``, of the face values ``phi_f (nf, ...)`` (internal
    then boundary): one compiled sparse product with the cached ``(2 nc, nf)`` operator of the signed
    ``S_f / V`` (4 ``bincount`` passes per component took 1 ms on a 20 000-cell mesh)."""
    op = mesh.info.get("gauss_sum")
    if op is None:
        import scipy.sparse as sp

        nc, ni, nf = mesh.n_cells, mesh.n_internal, len(mesh.sf)
        faces = np.concatenate([np.arange(nf), np.arange(ni)])
        cells = np.concatenate([mesh.owner, mesh.neighbour[:ni]])
        sign = np.concatenate([np.ones(nf), -np.ones(ni)])
        blocks = [sp.csr_matrix((sign * mesh.sf[faces, k] / mesh.volume[cells], (cells, faces)), shape=(nc, nf))
                  for k in range(2)]
        op = mesh.info["gauss_sum"] = CompiledCSR(sp.vstack(blocks, format="csr"))
    nc = mesh.n_cells
    out = (op @ phi_f.reshape(len(phi_f), -1)).reshape((2, nc) + phi_f.shape[1:])
    return np.moveaxis(out, 0, -1)


# ------------------------------------------------------------------------------ quadratic reconstruction
#: Condition-number limit of a cell's scaled quadratic least-squares system; beyond it (or with fewer than
#: 6 stencil points) the cell falls back to the linear least-squares gradient and a zero Hessian.
_QUAD_COND_LIMIT = 1e8


def quadratic_operators(mesh: FVMesh) -> dict:
    """Sparse operators of the quadratic least-squares reconstruction (built once per mesh, cached in
    ``mesh.info``).

    Each cell fits ``phi(x) = phi_P + g·(x - x_P) + ½ (x - x_P)ᵀ H (x - x_P)`` to the centroid values of its
    vertex neighbours (cells sharing a node) and the boundary-face centre values touching its nodes
    (inverse-distance-squared weights, coordinates scaled by the cell size). Returns ``{"hess": (3 ops:
    xx, xy, yy), "face": op}`` (the gradient operators are only used to build ``face`` and not kept),
    each a CSR matrix acting on ``concat(phi (nc,), phi_b (nb,))``: cell Hessian entries, and the
    average over each internal face of the two sides'
    reconstructions (weights ``w``, ``1 - w``) — exact for quadratic fields, where the linear
    reconstruction leaves an O(h²) face error that does not cancel between the faces of a triangle.
    """
    cached = mesh.info.get("quadratic")
    if cached is not None:
        return cached
    import scipy.sparse as sp

    nc, ni, nb = mesh.n_cells, mesh.n_internal, mesh.n_boundary
    npts = len(mesh.points)
    rows, cols, start = [], [], 0
    for conn in mesh.cells.values():
        rows.append(np.repeat(np.arange(start, start + len(conn)), conn.shape[1]))
        cols.append(conn.ravel())
        start += len(conn)
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    c2n = sp.csr_matrix((np.ones(rows.size), (rows, cols)), (nc, npts))
    b2n = sp.csr_matrix((np.ones(2 * nb), (np.repeat(np.arange(nb), 2), mesh.faces[ni:].ravel())), (nb, npts))
    stencil = sp.hstack([c2n @ c2n.T, c2n @ b2n.T]).tocsr()
    stencil.setdiag(0.0)
    stencil.eliminate_zeros()
    stencil.sort_indices()
    counts = np.diff(stencil.indptr)
    kmax = int(counts.max())
    # padded (nc, kmax) stencil tables
    cell_of = np.repeat(np.arange(nc), counts)
    slot = np.arange(stencil.indices.size) - stencil.indptr[cell_of]
    other = np.zeros((nc, kmax), dtype=np.int64)
    valid = np.zeros((nc, kmax), dtype=bool)
    other[cell_of, slot] = stencil.indices
    valid[cell_of, slot] = True
    xall = np.concatenate([mesh.centroid, mesh.face_centre[ni:]])
    h = np.sqrt(mesh.volume)
    # s = (x - x_P) / h (0 off the stencil), a = [s_x, s_y, s_x²/2, s_x s_y, s_y²/2], aw = a / |s|²:
    # kernels.quadratic_fit_tables (the numpy form's operations, bitwise)
    a, aw = quadratic_fit_tables(xall, mesh.centroid, h, other, valid)
    normal = normal_matrices(aw, a)                                   # np.einsum("cki,ckj->cij", aw, a)
    ok = counts >= 6
    # the condition number only decides ``ok``: a Cholesky bound (at most 25x the condition number) places
    # almost every cell far below the limit; the SVD's value decides the rest, as it decided every cell
    # (the same ``ok``: a bound below limit / 100 leaves the SVD's value far below the limit)
    bound = spd_condition_bound(normal, ok)
    exact = np.flatnonzero(ok & ~(bound < 1e-2 * _QUAD_COND_LIMIT))
    cond = np.where(ok, 0.0, np.inf)
    if exact.size:
        cond[exact] = np.linalg.cond(normal[exact])
    ok &= cond < _QUAD_COND_LIMIT
    normal[~ok] = np.eye(5)
    coef = np.linalg.solve(normal, np.swapaxes(aw, 1, 2))            # (nc, 5, kmax): per unit scaled value
    coef /= np.stack([h, h, h * h, h * h, h * h], 1)[..., None]     # back to physical units
    # fallback cells: linear least-squares gradient, zero Hessian
    coef[~ok] = 0.0
    n_all = nc + nb

    s_indptr, s_indices = stencil.indptr.astype(np.int64), stencil.indices.astype(np.int64)

    def op(k):
        # the stencil's weights minus their row sum on the diagonal (stencil_operator_rows: the arrays of
        # csr_matrix((vals[valid], (cell_of, stencil.indices))) - diags(vals.sum(axis=1)), bitwise)
        vals = np.where(valid, coef[:, k, :], 0.0)
        indptr, indices, data = stencil_operator_rows(s_indptr, s_indices, vals, vals.sum(axis=1))
        return sp.csr_matrix((data, indices, indptr), (nc, n_all))

    grad = [op(0), op(1)]
    hess = [op(2), op(3), op(4)]
    if np.any(~ok):
        bad = np.flatnonzero(~ok)
        lw = mesh.ls_weights[bad]                                      # (k, 4, 2)
        oth = mesh.cell_other[bad]
        for d in range(2):
            rr = np.repeat(bad, oth.shape[1])
            vals = lw[..., d].ravel()
            lin = sp.csr_matrix((vals, (rr, oth.ravel())), (nc, n_all)) - sp.csr_matrix(
                (lw[..., d].sum(axis=1), (bad, bad)), (nc, n_all))
            grad[d] = (grad[d] + lin).tocsr()
    # face-average operator (internal faces): the mean over the face x = x_f + t e, t in [-1/2, 1/2], of each
    # side's reconstruction about x_P, weighted w and 1 - w; one compiled loop (the sums of the scipy form
    # sum_s sum_t diags(c_t) @ (sel_s @ op_t), bitwise: kernels.quadratic_face_rows)
    edge = mesh.points[mesh.faces[:ni, 1]] - mesh.points[mesh.faces[:ni, 0]]
    cells = np.stack([mesh.owner[:ni], mesh.neighbour[:ni]])
    weights = np.stack([mesh.weight[:ni], 1.0 - mesh.weight[:ni]])
    coefficients = np.empty((2, 5, ni))
    for s, side in enumerate(cells):
        r = mesh.face_centre[:ni] - mesh.centroid[side]
        coefficients[s] = (r[:, 0], r[:, 1], 0.5 * (r[:, 0] ** 2 + edge[:, 0] ** 2 / 12.0),
                           r[:, 0] * r[:, 1] + edge[:, 0] * edge[:, 1] / 12.0,
                           0.5 * (r[:, 1] ** 2 + edge[:, 1] ** 2 / 12.0))
    ops = grad + hess
    indptr, indices, data = quadratic_face_rows(
        n_all, 2, weights, cells, coefficients, np.stack([op.indptr.astype(np.int64) for op in ops]),
        tuple(op.indices.astype(np.int64) for op in ops), tuple(op.data for op in ops))
    face = sp.csr_matrix((data, indices, indptr), shape=(ni, n_all))
    out = {"hess": tuple(hess), "face": face.tocsr(), "fallback": int(np.count_nonzero(~ok))}
    mesh.info["quadratic"] = out
    return out


def face_average(mesh: FVMesh, phi: np.ndarray, phi_b: np.ndarray, faces: np.ndarray | None = None) -> np.ndarray:
    """Mean of ``phi (nc, ...)`` over each internal face ``(ni, ...)`` from the two sides' quadratic
    reconstructions (:func:`quadratic_operators`): exact for quadratic fields, so that the face fluxes of
    a smooth field have O(h³) errors per unit length and its discrete divergence is second order on
    triangles too. ``faces``: the internal faces to evaluate (``(len(faces), ...)`` returned; default
    all), through the rows of the operator for those faces (cached per face set; bitwise the full
    product's rows)."""
    v = extended(phi, phi_b)
    flat = v.reshape(v.shape[0], -1)
    op = quadratic_operators(mesh)["face"] if faces is None else _face_average_rows(mesh, faces)
    n = mesh.n_internal if faces is None else len(faces)
    return (op @ flat).reshape((n,) + phi.shape[1:])


def _face_average_rows(mesh: FVMesh, faces: np.ndarray):
    """Rows ``faces`` of the face-average operator (:func:`quadratic_operators`), cached in ``mesh.info``
    per face set. A CSR row slice keeps each row's entries in order: its product is bitwise the full
    product's rows."""
    cache = mesh.info.setdefault("face_average_rows", {})
    key = faces.tobytes()
    if key not in cache:
        cache[key] = CompiledCSR(quadratic_operators(mesh)["face"][faces])
    return cache[key]


def boundary_face_curvature(mesh: FVMesh, phi: np.ndarray, phi_b: np.ndarray,
                            faces: np.ndarray | None = None) -> np.ndarray:
    """``(nb, ...)`` mean over each boundary face of the owner's quadratic reconstruction minus its value
    at the face centre: ``eᵀ H e / 24`` with ``e`` the face's edge vector and ``H`` the owner's Hessian
    (:func:`quadratic_operators`). Added to a face-centre value it gives the face mean, consistently with
    :func:`face_average` on the internal faces.

    ``faces``: local boundary-face indices (``face - n_internal``) to evaluate, ``(len(faces), ...)``
    returned; default all. Only the owners' Hessian rows are computed (:func:`_boundary_hessians`): the
    outlet faces that need it are a few percent of the cells."""
    faces = np.arange(mesh.n_boundary) if faces is None else np.asarray(faces)
    v = extended(phi, phi_b)
    flat = v.reshape(v.shape[0], -1)
    *hessians, (ex, ey) = _boundary_hessians(mesh, faces)
    hxx, hxy, hyy = (op @ flat for op in hessians)
    out = (hxx * ex**2 + 2.0 * hxy * ex * ey + hyy * ey**2) / 24.0
    return out.reshape((faces.size,) + phi.shape[1:])


def _boundary_hessians(mesh: FVMesh, faces: np.ndarray) -> tuple:
    """The rows of the Hessian operators (:func:`quadratic_operators`) at the owners of the boundary faces
    ``faces`` (local indices) and the faces' edge vectors ``(ex, ey)`` ``(k, 1)`` each, cached in ``mesh.info``
    per face set. Row slices keep each row's entries in order: the products are bitwise those of the full
    operators."""
    cache = mesh.info.setdefault("boundary_hessians", {})
    key = faces.tobytes()
    if key not in cache:
        f = mesh.n_internal + faces
        owners = mesh.owner[f]
        e = mesh.points[mesh.faces[f, 1]] - mesh.points[mesh.faces[f, 0]]
        cache[key] = (*(CompiledCSR(h[owners]) for h in quadratic_operators(mesh)["hess"]), (e[:, :1], e[:, 1:]))
    return cache[key]
