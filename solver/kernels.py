"""Compiled loops (numba) for the per-iteration work where numpy's gathers and temporaries dominate.

Each kernel is one formula of the module that calls it, written as a loop over cells or faces with the
same floating-point operations in the same order as the numpy (or scipy) expression it replaces, so that
the results are bitwise those of that form; the exceptions say so: the residual norms (running sums) and
the Gauss–Seidel sweeps (a multiplication by the reciprocal diagonal instead of pyamg's division) agree to
round-off. Each is checked against its numpy form on a small mesh in ``tests/solver/test_kernels.py``.

Index arrays of the sparse kernels are unsigned 32-bit copies (:func:`unsigned`): numba checks every signed
index for wrap-around, which made its sparse loops 2-3x slower than scipy's (``int32``) — and 32 bits carry
half the index traffic of 64 (the AMG V-cycle, whose levels do not all stay in cache, 5 % faster). A kernel
is one loop: a per-row helper function was not inlined and ran 4x slower. ``cache=True`` keeps the machine
code in ``__pycache__``: the first use on a machine compiles (about 10 s for all of them, once), later
processes load it (0.2 s).
"""

from __future__ import annotations

import numpy as np
from numba import njit


def unsigned(indices: np.ndarray) -> np.ndarray:
    """An index array as the kernels take it: unsigned 32-bit (``np.uint32``) copy of non-negative indices
    below 2**32 (any mesh or sparse matrix of this solver)."""
    return np.asarray(indices).astype(np.uint32)


@njit(cache=True)
def venkatakrishnan(phi, phi_b, cell_other, cell_r, grad, eps2_cell, eps2_component):
    """Venkatakrishnan's limiter ``psi (nc, m)`` of the ``m`` components of a field
    (:data:`solver.gradient.LIMITERS`).

    phi ``(nc, m)``, phi_b ``(nb, m)`` boundary-face values; cell_other ``(nc, 4)`` index into ``concat(phi,
    phi_b)`` across each cell face (the cell itself on padding); cell_r ``(nc, 4, 2)`` centroid -> face
    centre (zero on padding), m; grad ``(nc, m, 2)``; ``eps2 = eps2_cell[c] + eps2_component[i]``, one of the
    two zero: Venkatakrishnan's ``(k h)³`` per cell ``(nc,)``, or Wang's ``(K' × range)²`` per component
    ``(m,)`` (adding the zero changes no bit). Per cell and component, with ``Δ_f = grad·r_f`` and
    ``d1 = max - phi`` (``Δ_f >= 0``) or ``min - phi`` over the cell and its face neighbours:
    ``psi = min_f clip(((d1² + eps2) Δ_f + 2 Δ_f² d1) / ((d1² + 2 Δ_f² + d1 Δ_f + eps2) Δ_f), 0, 1)``
    (1 where ``|Δ_f| <= 1e-300``)."""
    nc, m = phi.shape
    psi = np.empty((nc, m))
    for c in range(nc):
        for i in range(m):
            pmax = phi[c, i]
            pmin = phi[c, i]
            for k in range(cell_other.shape[1]):
                j = cell_other[c, k]
                v = phi[j, i] if j < nc else phi_b[j - nc, i]
                pmax = max(pmax, v)
                pmin = min(pmin, v)
            best = 1.0
            e2 = eps2_cell[c] + eps2_component[i]
            for k in range(cell_r.shape[1]):
                delta = cell_r[c, k, 0] * grad[c, i, 0] + cell_r[c, k, 1] * grad[c, i, 1]
                d1 = pmax - phi[c, i] if delta >= 0 else pmin - phi[c, i]
                if abs(delta) > 1e-300:
                    num = (d1**2 + e2) * delta + 2.0 * delta**2 * d1
                    den = d1**2 + 2.0 * delta**2 + d1 * delta + e2
                    p = min(max(num / (den * delta), 0.0), 1.0)
                else:
                    p = 1.0
                if p < best or p != p:
                    best = p
            psi[c, i] = best
    return psi


@njit(cache=True)
def deferred_correction(flux, grad, r_owner, r_neighbour, owner, neighbour):
    """``F_f grad_U·(x_f - x_U)`` per internal face and component ``(ni, m)`` (:func:`solver.assembly.
    deferred_correction`): ``U`` the upwind cell (owner where ``F_f >= 0``), grad ``(nc, m, 2)``,
    r_owner / r_neighbour ``(ni, 2)`` face centre minus owner / neighbour centroid, m."""
    ni = r_owner.shape[0]
    m = grad.shape[1]
    out = np.empty((ni, m))
    for f in range(ni):
        F = flux[f]
        if F >= 0:
            c, r0, r1 = owner[f], r_owner[f, 0], r_owner[f, 1]
        else:
            c, r0, r1 = neighbour[f], r_neighbour[f, 0], r_neighbour[f, 1]
        for i in range(m):
            out[f, i] = F * (grad[c, i, 0] * r0 + grad[c, i, 1] * r1)
    return out


@njit(cache=True)
def cap_quadratic_correction(lin, face_mean, faces, owner, neighbour, grad, d_length, cap_fraction):
    """Add to the linear face values ``lin (ni, m)`` (in place) the quadratic correction ``face_mean - lin``
    of the faces ``faces`` (``face_mean (len(faces), m)``), each component's clipped to
    ``± cap_fraction |d| (|grad_P| + |grad_N|) / 2`` (:func:`solver.pressure.face_velocity`); grad
    ``(nc, m, 2)``, d_length ``(nf,)`` m."""
    for j in range(faces.shape[0]):
        f = faces[j]
        o, n = owner[f], neighbour[f]
        for c in range(lin.shape[1]):
            slope_o = np.sqrt(grad[o, c, 0] * grad[o, c, 0] + grad[o, c, 1] * grad[o, c, 1])
            slope_n = np.sqrt(grad[n, c, 0] * grad[n, c, 0] + grad[n, c, 1] * grad[n, c, 1])
            cap = cap_fraction * d_length[f] * 0.5 * (slope_o + slope_n)
            lin[f, c] += min(max(face_mean[j, c] - lin[f, c], -cap), cap)


@njit(cache=True)
def clip_to_cells(phi_f, phi, owner, neighbour):
    """Each face value ``phi_f (ni, k)`` clipped, in place, to the range of its owner's and neighbour's values
    ``phi (nc, k)``; one pass (numpy's gathers, minimum and maximum took 2 ms on 35 000 faces)."""
    for f in range(phi_f.shape[0]):
        for j in range(phi_f.shape[1]):
            a, b = phi[owner[f], j], phi[neighbour[f], j]
            lo, hi = (a, b) if a < b else (b, a)
            v = phi_f[f, j]
            phi_f[f, j] = lo if v < lo else (hi if v > hi else v)
    return phi_f


@njit(cache=True)
def symmetric_gauss_seidel_pair(indptr, indices, data, inv_diag_x, inv_diag_y, x, y, b_x, b_y, sweeps):
    """``sweeps`` symmetric Gauss–Seidel sweeps (rows ``0..n-1``, then ``n-1..0``) on the two systems
    ``(D_x + O) x = b_x`` and ``(D_y + O) y = b_y`` that share their off-diagonal part ``O`` (CSR arrays
    ``indptr, indices, data``, no diagonal entry) and differ in the diagonal ``D`` (the u and v momentum
    systems), ``1 / D`` given (0: row left unchanged); ``x``, ``y`` updated in place. The update of
    :func:`gauss_seidel_sweeps` for both systems in one pass: the matrix is read once and two independent
    dependency chains interleave (the pair costs about one pyamg solve; equal to it to round-off)."""
    n = x.shape[0]
    for _ in range(sweeps):
        for step in range(2 * n):
            i = step if step < n else 2 * n - 1 - step
            rx = b_x[i]
            ry = b_y[i]
            for jj in range(indptr[i], indptr[i + 1]):
                a = data[jj]
                j = indices[jj]
                rx -= a * x[j]
                ry -= a * y[j]
            if inv_diag_x[i] != 0.0:
                x[i] = rx * inv_diag_x[i]
            if inv_diag_y[i] != 0.0:
                y[i] = ry * inv_diag_y[i]


@njit(cache=True)
def residual_norms(indptr, indices, data, x, b, x_mean):
    """``(|b - A x|_1, |A x - A x̄|_1, |b - A x̄|_1, |diag(A) x|_1)`` of a CSR matrix ``A`` in one pass over
    its rows (:meth:`solver.linalg.LinearSystem.residual_norms`), ``A x̄`` the row sums times ``x_mean``.
    The row products are summed in column order as scipy's; the four 1-norms are running sums (numpy's
    ``sum`` is pairwise: the norms differ from the numpy form in the last bits only)."""
    r = 0.0
    n_ax = 0.0
    n_b = 0.0
    diag_x = 0.0
    for i in range(x.shape[0]):
        ax = 0.0
        row = 0.0
        for jj in range(indptr[i], indptr[i + 1]):
            j = indices[jj]
            ax += data[jj] * x[j]
            row += data[jj]
            if j == i:
                diag_x += abs(data[jj] * x[i])
        axbar = row * x_mean
        r += abs(b[i] - ax)
        n_ax += abs(ax - axbar)
        n_b += abs(b[i] - axbar)
    return r, n_ax, n_b, diag_x


@njit(cache=True)
def spalding_u_tau(u_t, y, nu, kappa, exp_kappa_b, halvings):
    """Friction velocity ``(n,)`` from Spalding's law of the wall by bisection on ``u+`` per face
    (:func:`solver.turbulence.closures.spalding_u_tau`, whose numpy form it follows operation by
    operation): ``Re_y / u+ = u+ + e^(-kappa B) (e^(kappa u+) - 1 - kappa u+ - (kappa u+)²/2 - (kappa u+)³/6)``
    with ``Re_y = u_t y / nu``, bracket ``(0, sqrt(Re_y) (1 + 1e-12)]``; ``exp_kappa_b`` = ``e^(-kappa B)``.
    Stops early once a halving leaves the bracket as it was (its midpoint rounds to the end it would replace):
    every later halving would do the same, so the result is bitwise that of all ``halvings`` (53 of 60 are
    done on a blade's wall faces)."""
    out = np.empty(u_t.shape[0])
    for f in range(u_t.shape[0]):
        re_y = max(u_t[f] * y[f] / nu, 1e-300)
        lo = 0.0
        hi = np.sqrt(re_y) * (1.0 + 1e-12)
        for _ in range(halvings):
            mid = 0.5 * (lo + hi)
            up = max(mid, 1e-300)
            ku = kappa * up
            g = re_y / up - (up + exp_kappa_b * (np.exp(ku) - 1.0 - ku - ku**2 / 2.0 - ku**3.0 / 6.0))
            if g > 0:
                if mid == lo:       # the bracket no longer moves: the halvings left would repeat this one
                    break
                lo = mid
            else:
                if mid == hi:
                    break
                hi = mid
        u_plus = 0.5 * (lo + hi)
        out[f] = u_t[f] / max(u_plus, 1e-300) if re_y > 1e-200 else 0.0
    return out


@njit(cache=True)
def csr_residual(indptr, indices, data, x, b):
    """``b - A x`` for a CSR matrix ``A`` (each row's products summed in column order, as scipy's)."""
    r = np.empty(b.shape[0])
    for i in range(b.shape[0]):
        s = 0.0
        for jj in range(indptr[i], indptr[i + 1]):
            s += data[jj] * x[indices[jj]]
        r[i] = b[i] - s
    return r


@njit(cache=True)
def csr_matvec(indptr, indices, data, x, n_rows):
    """``A x`` for a CSR matrix ``A`` with ``n_rows`` rows (sums in column order, as scipy's)."""
    y = np.empty(n_rows)
    for i in range(n_rows):
        s = 0.0
        for jj in range(indptr[i], indptr[i + 1]):
            s += data[jj] * x[indices[jj]]
        y[i] = s
    return y


@njit(cache=True)
def csr_matmat(indptr, indices, data, x, n_rows):
    """``A X`` ``(n_rows, m)`` for a CSR matrix ``A`` and ``X (n, m)``: each entry a running sum over the
    row in column order, as scipy's ``csr_matvecs``."""
    m = x.shape[1]
    y = np.empty((n_rows, m))
    for i in range(n_rows):
        for k in range(m):
            s = 0.0
            for jj in range(indptr[i], indptr[i + 1]):
                s += data[jj] * x[indices[jj], k]
            y[i, k] = s
    return y


@njit(cache=True)
def csr_matmat2(indptr, indices, data, x, n_rows):
    """:func:`csr_matmat` for two columns (vector fields): both running sums in one pass over the row
    (bitwise the same sums, twice as fast as the generic loop)."""
    y = np.empty((n_rows, 2))
    for i in range(n_rows):
        s0 = 0.0
        s1 = 0.0
        for jj in range(indptr[i], indptr[i + 1]):
            a = data[jj]
            j = indices[jj]
            s0 += a * x[j, 0]
            s1 += a * x[j, 1]
        y[i, 0] = s0
        y[i, 1] = s1
    return y


@njit(cache=True)
def paired_row_gradient(c_ptr, c_idx, c_val, b_ptr, b_idx, b_val, phi, phi_b):
    """The least-squares gradient ``(nc, m, 2)`` of ``phi (nc, m)`` with boundary-face values ``phi_b (nb, m)``
    from its two operators in paired-row form (:func:`solver.gradient.ls_operators`): per cell ``c`` one
    list of columns (``c_ptr``, ``c_idx``) with the weights of both directions ``c_val (nnz, 2)``, the same
    for the boundary faces (``b_*``). ``out[c, k, i] = sum_cells + sum_faces``, each a running sum in column
    order: bitwise the sum of the two CSR products ``(2 nc, ·)`` it replaces (a direction's zero weight on a
    column only the other direction has adds 0), reading each column once for both directions."""
    nc, m = phi.shape
    out = np.empty((nc, m, 2))
    for c in range(nc):
        for k in range(m):
            sx = 0.0
            sy = 0.0
            for jj in range(c_ptr[c], c_ptr[c + 1]):
                v = phi[c_idx[jj], k]
                sx += c_val[jj, 0] * v
                sy += c_val[jj, 1] * v
            tx = 0.0
            ty = 0.0
            for jj in range(b_ptr[c], b_ptr[c + 1]):
                v = phi_b[b_idx[jj], k]
                tx += b_val[jj, 0] * v
                ty += b_val[jj, 1] * v
            out[c, k, 0] = sx + tx
            out[c, k, 1] = sy + ty
    return out


@njit(cache=True)
def interpolate_faces(w, w1, owner, neighbour, phi):
    """``w phi[owner] + w1 phi[neighbour]`` ``(ni, m)`` for ``phi (nc, m)`` (:func:`solver.gradient.
    interpolate_linear`, ``w1 = 1 - w``): bitwise the product with the two-entry rows of its CSR operator
    (a running sum from 0 of two products: their sum in either order). :func:`interpolate_faces_1` and
    :func:`interpolate_faces_2`: the same for one and two columns, unrolled (twice as fast)."""
    m = phi.shape[1]
    out = np.empty((w.shape[0], m))
    for f in range(w.shape[0]):
        o = owner[f]
        n = neighbour[f]
        for k in range(m):
            out[f, k] = w[f] * phi[o, k] + w1[f] * phi[n, k]
    return out


@njit(cache=True)
def interpolate_faces_1(w, w1, owner, neighbour, phi):
    """:func:`interpolate_faces` of a cell scalar ``phi (nc,)`` -> ``(ni,)``."""
    out = np.empty(w.shape[0])
    for f in range(w.shape[0]):
        out[f] = w[f] * phi[owner[f]] + w1[f] * phi[neighbour[f]]
    return out


@njit(cache=True)
def interpolate_faces_2(w, w1, owner, neighbour, phi):
    """:func:`interpolate_faces` of ``phi (nc, 2)`` -> ``(ni, 2)``."""
    out = np.empty((w.shape[0], 2))
    for f in range(w.shape[0]):
        o = owner[f]
        n = neighbour[f]
        out[f, 0] = w[f] * phi[o, 0] + w1[f] * phi[n, 0]
        out[f, 1] = w[f] * phi[o, 1] + w1[f] * phi[n, 1]
    return out


@njit(cache=True)
def face_gradient_flux(w, w1, owner, neighbour, grad, t, gamma):
    """``gamma_f (grad_f · t_f)`` ``(ni,)``: the gradient ``grad (nc, 2)`` of a cell scalar interpolated
    linearly to the internal faces (:func:`interpolate_faces`) and dotted with ``t (ni, 2)``, times ``gamma
    (ni,)`` (:func:`solver.assembly.non_orthogonal_diffusion`; bitwise its interpolation, ``dot_last`` and
    product)."""
    out = np.empty(w.shape[0])
    for f in range(w.shape[0]):
        o = owner[f]
        n = neighbour[f]
        gx = w[f] * grad[o, 0] + w1[f] * grad[n, 0]
        gy = w[f] * grad[o, 1] + w1[f] * grad[n, 1]
        out[f] = gamma[f] * (gx * t[f, 0] + gy * t[f, 1])
    return out


@njit(cache=True)
def rhie_chow_faces(w, w1, owner, neighbour, u_f, sf, e, diff_coeff, p, r_au, grad_p, rho):
    """Rhie–Chow mass fluxes of the internal faces ``(ni,)`` (:func:`solver.pressure.rhie_chow_flux`):
    ``rho (u_f·S - d̄ (diff_coeff (p_N - p_P) - ḡ·e))`` with ``d̄``, ``ḡ`` the linear interpolations
    (:func:`interpolate_faces`) of ``r_au (nc,)`` and ``grad_p (nc, 2)``; ``u_f``, ``sf``, ``e`` ``(ni, 2)``.
    Bitwise the numpy form (interpolations, ``dot_last``, products in its order) in one pass."""
    out = np.empty(w.shape[0])
    for f in range(w.shape[0]):
        o = owner[f]
        n = neighbour[f]
        u_s = u_f[f, 0] * sf[f, 0] + u_f[f, 1] * sf[f, 1]
        d_bar = w[f] * r_au[o] + w1[f] * r_au[n]
        g0 = w[f] * grad_p[o, 0] + w1[f] * grad_p[n, 0]
        g1 = w[f] * grad_p[o, 1] + w1[f] * grad_p[n, 1]
        out[f] = rho * (u_s - d_bar * (diff_coeff[f] * (p[n] - p[o]) - (g0 * e[f, 0] + g1 * e[f, 1])))
    return out


@njit(cache=True)
def viscous_face_stress(w, w1, owner, neighbour, grad, t, sf, mu):
    """``mu_f ((grad u)_f · T_f + (grad u)_f^T · S_f)`` ``(ni, 2)`` (:func:`solver.momentum.momentum_system`,
    variable viscosity): the velocity gradient ``grad (nc, 2, 2)`` ``[cell, component, direction]``
    interpolated linearly to the internal faces, its non-orthogonal part along ``t (ni, 2)`` plus its
    transpose along ``sf (ni, 2)``, times ``mu (ni,)``; bitwise the numpy form (interpolation, two
    ``dot_last`` and their sum)."""
    out = np.empty((w.shape[0], 2))
    for f in range(w.shape[0]):
        o = owner[f]
        n = neighbour[f]
        g00 = w[f] * grad[o, 0, 0] + w1[f] * grad[n, 0, 0]
        g01 = w[f] * grad[o, 0, 1] + w1[f] * grad[n, 0, 1]
        g10 = w[f] * grad[o, 1, 0] + w1[f] * grad[n, 1, 0]
        g11 = w[f] * grad[o, 1, 1] + w1[f] * grad[n, 1, 1]
        t0, t1, s0, s1 = t[f, 0], t[f, 1], sf[f, 0], sf[f, 1]
        out[f, 0] = mu[f] * ((g00 * t0 + g01 * t1) + (g00 * s0 + g10 * s1))
        out[f, 1] = mu[f] * ((g10 * t0 + g11 * t1) + (g01 * s0 + g11 * s1))
    return out


class CompiledCSR:
    """A fixed CSR matrix (an interpolation or gradient operator built once per mesh) whose products go
    through :func:`csr_matmat` when ``X`` has several columns (the vector and gradient operands of the
    solver, ``(n, 2..6)``): unsigned index arrays (numba checks signed indices for wrap-around) and one
    running sum per entry, ~1.5x faster than scipy's ``csr_matvecs``, with the same sums in the same order
    (bitwise). One column goes to scipy's matvec, as fast. ``matrix``: the scipy original."""

    def __init__(self, matrix):
        matrix = matrix.tocsr()
        self.matrix = matrix
        self.shape = matrix.shape
        self.indptr = unsigned(matrix.indptr)
        self.indices = unsigned(matrix.indices)
        self.data = np.ascontiguousarray(matrix.data, dtype=np.float64)

    def __matmul__(self, x: np.ndarray) -> np.ndarray:
        """``A x`` for ``x`` of shape ``(n,)`` or ``(n, m)``."""
        x = np.asarray(x, dtype=np.float64)
        flat = x.reshape(x.shape[0], -1)
        if flat.shape[1] == 1:                       # one column: scipy's matvec is as fast (and bitwise)
            return self.matrix @ x
        product = csr_matmat2 if flat.shape[1] == 2 else csr_matmat
        y = product(self.indptr, self.indices, self.data, np.ascontiguousarray(flat), self.shape[0])
        return y.reshape((self.shape[0],) + x.shape[1:])


@njit(cache=True)
def split_diagonal(indptr, indices, data):
    """The CSR matrix ``A`` as its off-diagonal part ``(indptr, indices, data)`` (unsigned indices, row
    order kept) and the reciprocal of its diagonal (0 where the diagonal is 0 or absent), for
    :func:`gauss_seidel_sweeps`."""
    n = indptr.shape[0] - 1
    off_ptr = np.zeros(n + 1, dtype=np.uint32)
    off_idx = np.empty(indices.shape[0], dtype=np.uint32)
    off_val = np.empty(indices.shape[0])
    inv_diag = np.zeros(n)
    k = 0
    for i in range(n):
        for jj in range(indptr[i], indptr[i + 1]):
            j = indices[jj]
            if j == i:
                if data[jj] != 0.0:
                    inv_diag[i] = 1.0 / data[jj]
            else:
                off_idx[k] = j
                off_val[k] = data[jj]
                k += 1
        off_ptr[i + 1] = k
    return off_ptr, off_idx[:k].copy(), off_val[:k].copy(), inv_diag


@njit(cache=True)
def gauss_seidel_sweeps(indptr, indices, data, inv_diag, x, b, sweeps):
    """``sweeps`` symmetric Gauss–Seidel sweeps (rows ``0..n-1``, then ``n-1..0``) on ``(D + O) x = b``, ``x``
    in place: ``x_i = (b_i - sum_j O_ij x_j) / D_i`` with the off-diagonal part ``O`` (CSR, no diagonal
    entry) and ``1 / D`` given (:func:`split_diagonal`; rows with ``1 / D = 0`` are left unchanged).

    A third faster than pyamg's kernel (a multiplication by ``1 / D`` instead of a division on the
    dependency chain from row to row, and no test for the diagonal inside the row); the same update up to
    the rounding of ``1 / D`` and of the subtractions, done one by one (not bitwise pyamg's)."""
    n = x.shape[0]
    for _ in range(sweeps):
        for step in range(2 * n):
            i = step if step < n else 2 * n - 1 - step
            if inv_diag[i] != 0.0:
                r = b[i]
                for jj in range(indptr[i], indptr[i + 1]):
                    r -= data[jj] * x[indices[jj]]
                x[i] = r * inv_diag[i]


@njit(cache=True)
def _dot_last(a, b):
    """``out[f, k] = a[f, k, 0] b[f, 0] + a[f, k, 1] b[f, 1]`` for ``a (n, m, 2)``, ``b (n, 2)``."""
    out = np.empty((a.shape[0], a.shape[1]))
    for f in range(a.shape[0]):
        b0 = b[f, 0]
        b1 = b[f, 1]
        for k in range(a.shape[1]):
            out[f, k] = a[f, k, 0] * b0 + a[f, k, 1] * b1
    return out


def dot_last(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``sum_d a[f, ..., d] b[f, d]`` ``(n, ...)`` for ``a (n, ..., 2)`` and ``b (n, 2)``: numpy's
    ``einsum("f...d,fd->f...", a, b)`` (the same two products and one sum per entry, bitwise) without its
    per-call parsing and its slow inner loop over a length-2 axis (5-10x faster on the face arrays)."""
    a3 = a.reshape(a.shape[0], -1, 2)
    return _dot_last(a3, b).reshape(a.shape[:-1])


@njit(cache=True)
def velocity_invariants(grad):
    """``(S², Omega²)`` ``(nc,)`` from ``grad (nc, 2, 2)``: ``2 S_ij S_ij`` and ``2 W_ij W_ij`` with ``S, W``
    the symmetric and antisymmetric parts (:func:`solver.turbulence.closures.velocity_invariants`); the four
    squares summed in pairs, as numpy's ``einsum`` over the contiguous 2 x 2 block."""
    n = grad.shape[0]
    s2 = np.empty(n)
    w2 = np.empty(n)
    for c in range(n):
        g00, g01, g10, g11 = grad[c, 0, 0], grad[c, 0, 1], grad[c, 1, 0], grad[c, 1, 1]
        s00, s01, s10, s11 = 0.5 * (g00 + g00), 0.5 * (g01 + g10), 0.5 * (g10 + g01), 0.5 * (g11 + g11)
        w00, w01, w10, w11 = 0.5 * (g00 - g00), 0.5 * (g01 - g10), 0.5 * (g10 - g01), 0.5 * (g11 - g11)
        s2[c] = 2.0 * ((s00 * s00 + s01 * s01) + (s10 * s10 + s11 * s11))
        w2[c] = 2.0 * ((w00 * w00 + w01 * w01) + (w10 * w10 + w11 * w11))
    return s2, w2


@njit(cache=True)
def log_mean_faces(gamma, owner, neighbour):
    """Logarithmic mean ``(b - a) / ln(b / a)`` of ``a = gamma[owner]``, ``b = gamma[neighbour]`` per face
    (the arithmetic mean where ``|b/a - 1| < 1e-6``): :func:`solver.turbulence.closures.log_mean` on the two
    cells of each internal face, without the gathers and temporaries."""
    out = np.empty(owner.shape[0])
    for f in range(owner.shape[0]):
        a = gamma[owner[f]]
        b = gamma[neighbour[f]]
        r = b / a
        out[f] = 0.5 * (a + b) if abs(r - 1.0) < 1e-6 else (b - a) / np.log(r)
    return out


@njit(cache=True)
def upwind_stencil(flux, diffusion, owner, neighbour, n_cells):
    """Upwind-convection + orthogonal-diffusion coefficients of the internal faces
    (:func:`solver.assembly.upwind_stencil`): ``upper = min(F, 0) - D``, ``lower = -max(F, 0) - D`` per face
    and ``diag = sum_{P owner} (max(F, 0) + D) + sum_{P neighbour} (max(-F, 0) + D)`` per cell, the two sums
    accumulated in face order (as two ``np.bincount``) and then added."""
    ni = diffusion.shape[0]
    upper = np.empty(ni)
    lower = np.empty(ni)
    from_owner = np.zeros(n_cells)
    from_neighbour = np.zeros(n_cells)
    for f in range(ni):
        F = flux[f]
        D = diffusion[f]
        upper[f] = min(F, 0.0) - D
        lower[f] = -max(F, 0.0) - D
        from_owner[owner[f]] += max(F, 0.0) + D
        from_neighbour[neighbour[f]] += max(-F, 0.0) + D
    return from_owner + from_neighbour, upper, lower


@njit(cache=True)
def scatter_face_sources(src, face, owner, neighbour):
    """``(src - sum_{f: P owner} face_f) + sum_{f: P neighbour} face_f`` per cell and component, ``src
    (nc, m)``, ``face (ni, m)`` (:func:`solver.assembly.scatter_face_sources`; each sum accumulated in face
    order, as ``np.bincount``)."""
    nc, m = src.shape
    from_owner = np.zeros((nc, m))
    from_neighbour = np.zeros((nc, m))
    for f in range(face.shape[0]):
        for k in range(m):
            from_owner[owner[f], k] += face[f, k]
            from_neighbour[neighbour[f], k] += face[f, k]
    return (src - from_owner) + from_neighbour


@njit(cache=True)
def boundary_velocity(u, grad, owner_b, r_t, normal, kind, u_fixed, fixed, symmetry):
    """Boundary-face velocities ``(nb, 2)`` (:meth:`solver.boundary.BoundaryData.velocity`): the owner value
    ``u_P + grad_u_P·r_t`` (``grad`` ``(nc, 2, 2)``, or an empty array for the plain owner value), its
    tangential part on ``symmetry`` faces, ``u_fixed`` on ``fixed`` faces; ``r_t`` ``(nb, 2)`` the tangential
    part of centroid -> face centre, m."""
    nb = owner_b.shape[0]
    out = np.empty((nb, 2))
    with_grad = grad.shape[0] > 0
    for f in range(nb):
        o = owner_b[f]
        up0 = u[o, 0]
        up1 = u[o, 1]
        if with_grad:
            up0 = up0 + (grad[o, 0, 0] * r_t[f, 0] + grad[o, 0, 1] * r_t[f, 1])
            up1 = up1 + (grad[o, 1, 0] * r_t[f, 0] + grad[o, 1, 1] * r_t[f, 1])
        if kind[f] == fixed:
            out[f, 0] = u_fixed[f, 0]
            out[f, 1] = u_fixed[f, 1]
        elif kind[f] == symmetry:
            n0 = normal[f, 0]
            n1 = normal[f, 1]
            un = up0 * n0 + up1 * n1
            out[f, 0] = up0 - un * n0
            out[f, 1] = up1 - un * n1
        else:
            out[f, 0] = up0
            out[f, 1] = up1
    return out


@njit(cache=True)
def boundary_pressure(p, grad, owner_b, r, r_t, fixed, value):
    """Boundary-face pressures ``(nb,)`` (:meth:`solver.boundary.BoundaryData.pressure`): ``value`` where
    ``fixed``, else ``p_P + grad_p_P·r``; and ``p_P + grad_p_P·r_t`` ``(nb,)``, the owner value reconstructed
    along the face (its mean-pressure groups). ``grad`` ``(nc, 2)``, or an empty array for ``p_P`` in both;
    ``r`` ``(nb, 2)`` centroid -> face centre and ``r_t`` its tangential part, m."""
    nb = owner_b.shape[0]
    out = np.empty(nb)
    along = np.empty(nb)
    with_grad = grad.shape[0] > 0
    for f in range(nb):
        o = owner_b[f]
        if with_grad:
            along[f] = p[o] + (grad[o, 0] * r_t[f, 0] + grad[o, 1] * r_t[f, 1])
            out[f] = value[f] if fixed[f] else p[o] + (grad[o, 0] * r[f, 0] + grad[o, 1] * r[f, 1])
        else:
            along[f] = p[o]
            out[f] = value[f] if fixed[f] else p[o]
    return out, along


@njit(cache=True)
def sst_blending_arguments(k, omega, d, grad_k, grad_w, nu, sigma_w2, beta_star, cd_floor):
    """The arguments of the SST blending functions and ``grad k · grad omega`` per cell ``(nc,)``
    (:mod:`solver.turbulence.closures`, the same operations in the same order; the ``tanh`` and the powers
    stay numpy's, whose SIMD forms differ from libm's in the last bit): ``arg1`` of
    :func:`~solver.turbulence.closures.f1` with ``CD_kw`` of :func:`~solver.turbulence.closures.cross_diffusion`,
    ``arg2`` of :func:`~solver.turbulence.closures.f2`; ``grad_k``, ``grad_w`` ``(nc, 2)``."""
    n = k.shape[0]
    arg1 = np.empty(n)
    arg2 = np.empty(n)
    kw = np.empty(n)
    for c in range(n):
        w = omega[c]
        y = d[c]
        dot = grad_k[c, 0] * grad_w[c, 0] + grad_k[c, 1] * grad_w[c, 1]
        kw[c] = dot
        cd = max(2.0 * sigma_w2 / w * dot, cd_floor)
        root_k = np.sqrt(k[c])
        viscous = 500.0 * nu / (y * y * w)
        arg1[c] = min(max(root_k / (beta_star * w * y), viscous), 4.0 * sigma_w2 * k[c] / (cd * y * y))
        arg2[c] = max(2.0 * root_k / (beta_star * w * y), viscous)
    return arg1, arg2, kw


@njit(cache=True)
def sst_f2_argument(k, omega, d, nu, beta_star):
    """``arg2`` of :func:`~solver.turbulence.closures.f2` per cell ``(nc,)`` (see :func:`sst_blending_arguments`)."""
    n = k.shape[0]
    arg2 = np.empty(n)
    for c in range(n):
        w = omega[c]
        y = d[c]
        arg2[c] = max(2.0 * np.sqrt(k[c]) / (beta_star * w * y), 500.0 * nu / (y * y * w))
    return arg2


@njit(cache=True)
def sst_omega_coefficients(f1, omega, kw, p_w, nu_t, rho, mu, beta1, beta2, gamma1, gamma2, sigma_w1, sigma_w2,
                           sigma_k1, sigma_k2):
    """The coefficients of one SST step blended by ``F1`` per cell ``(nc,)``
    (:func:`solver.turbulence.sst.turbulence_step`, the same operations in the same order): the omega
    equation's sources ``su = rho (gamma p_w + beta omega² + max(CD, 0))`` and ``sp = rho (2 beta omega +
    max(-CD, 0) / omega)`` with the cross diffusion ``CD = 2 (1 - F1) sigma_w2 / omega kw`` (``kw = grad k ·
    grad omega``), and the cell diffusivities ``mu + rho sigma nu_t`` of omega and k."""
    n = omega.shape[0]
    su = np.empty(n)
    sp = np.empty(n)
    gamma_w = np.empty(n)
    gamma_k = np.empty(n)
    for c in range(n):
        f = f1[c]
        w = omega[c]
        beta = f * beta1 + (1.0 - f) * beta2
        gamma = f * gamma1 + (1.0 - f) * gamma2
        sig_w = f * sigma_w1 + (1.0 - f) * sigma_w2
        sig_k = f * sigma_k1 + (1.0 - f) * sigma_k2
        cdw = 2.0 * (1.0 - f) * sigma_w2 / w * kw[c]
        su[c] = rho * (gamma * p_w[c] + beta * (w * w) + max(cdw, 0.0))
        sp[c] = rho * (2.0 * beta * w + max(-cdw, 0.0) / w)
        gamma_w[c] = mu + rho * sig_w * nu_t[c]
        gamma_k[c] = mu + rho * sig_k * nu_t[c]
    return su, sp, gamma_w, gamma_k


@njit(cache=True)
def scalar_boundary_terms(diag, src, phi, phi_b, dirichlet, flux_b, gamma_b, diff_coeff_b, grad, t_vec_b, owner_b):
    """The boundary faces' part of a scalar transport system (:func:`solver.transport.scalar_system`), added
    to ``diag``, ``src`` ``(nc,)`` in place: per face ``D = gamma diff_coeff`` on ``dirichlet`` faces (else 0),
    ``diag_b = D + max(F, 0)`` (outflow implicit), ``src_b = D phi_b + gamma grad_P·T`` (dirichlet; else
    ``+ 0``) ``- F phi_in`` on inflow faces (``phi_in`` = ``phi_b`` on dirichlet faces, else the owner value,
    lagged); the per-cell sums accumulated in face order and then added, as ``np.bincount``."""
    nc = diag.shape[0]
    acc_d = np.zeros(nc)
    acc_s = np.zeros(nc)
    for f in range(owner_b.shape[0]):
        o = owner_b[f]
        F = flux_b[f]
        D = gamma_b[f] * diff_coeff_b[f] if dirichlet[f] else 0.0
        out = F > 0
        acc_d[o] += D + (F if out else 0.0)
        cross = gamma_b[f] * (grad[o, 0] * t_vec_b[f, 0] + grad[o, 1] * t_vec_b[f, 1]) if dirichlet[f] else 0.0
        s = D * phi_b[f] + cross
        s -= 0.0 if out else F * (phi_b[f] if dirichlet[f] else phi[o])
        acc_s[o] += s
    for c in range(nc):
        diag[c] += acc_d[c]
        src[c] += acc_s[c]


@njit(cache=True)
def decouple_fixed_cells(upper, lower, owner, neighbour, is_fixed):
    """Zero, in place, the coefficients of the rows of fixed cells (:func:`solver.transport.scalar_system`):
    ``upper`` (row owner) where the owner is fixed, ``lower`` (row neighbour) where the neighbour is."""
    for f in range(upper.shape[0]):
        if is_fixed[owner[f]]:
            upper[f] = 0.0
        if is_fixed[neighbour[f]]:
            lower[f] = 0.0


@njit(cache=True)
def momentum_boundary_terms(u, u_b, flux_b, grad, mu_b, kind, owner_b, diff_coeff_b, t_vec_b, normal_b, d_b,
                            length_b, n_cells, fixed, zero_gradient, symmetry):
    """The boundary faces' part of the momentum systems (:func:`solver.momentum._boundary`, the same operations
    in the same order): per cell ``(diag (nc,), src (nc, 2), symmetry diagonal (nc, 2))``, each sum accumulated
    in face order (as ``np.bincount``). Per face with ``D = mu_b diff_coeff``: fixed-velocity faces ``diag += D``,
    ``src += (D - F) u_b + mu_b grad_P·T``; zero-gradient faces ``diag += max(F, 0)``, ``src -= F u_b - max(F, 0)
    u_P``; symmetry faces ``D_n = mu_b |S| / (d·n)``, ``src -= D_n n_x n_y (u_P,y, u_P,x)``, symmetry diagonal
    ``D_n n²``."""
    diag = np.zeros(n_cells)
    src = np.zeros((n_cells, 2))
    sym_d = np.zeros((n_cells, 2))
    for f in range(owner_b.shape[0]):
        o = owner_b[f]
        F = flux_b[f]
        m = mu_b[f]
        k = kind[f]
        D = m * diff_coeff_b[f]
        f_pos = F if (F >= 0.0 or F != F) else 0.0
        diag[o] += (D if k == fixed else 0.0) + (f_pos if k == zero_gradient else 0.0)
        t0 = t_vec_b[f, 0]
        t1 = t_vec_b[f, 1]
        if k == fixed:
            s0 = (D - F) * u_b[f, 0] + m * (grad[o, 0, 0] * t0 + grad[o, 0, 1] * t1)
            s1 = (D - F) * u_b[f, 1] + m * (grad[o, 1, 0] * t0 + grad[o, 1, 1] * t1)
        else:
            s0 = 0.0
            s1 = 0.0
        if k == zero_gradient:
            s0 -= F * u_b[f, 0] - f_pos * u[o, 0]
            s1 -= F * u_b[f, 1] - f_pos * u[o, 1]
        else:
            s0 -= 0.0
            s1 -= 0.0
        n0 = normal_b[f, 0]
        n1 = normal_b[f, 1]
        dn = d_b[f, 0] * n0 + d_b[f, 1] * n1
        Dn = m * length_b[f] / dn if k == symmetry else 0.0
        cross = Dn * n0 * n1
        s0 -= cross * u[o, 1]
        s1 -= cross * u[o, 0]
        src[o, 0] += s0
        src[o, 1] += s1
        sym_d[o, 0] += Dn * (n0 * n0)
        sym_d[o, 1] += Dn * (n1 * n1)
    return diag, src, sym_d


@njit(cache=True)
def spd_condition_bound(a, use):
    """An upper bound of the 2-norm condition number of each symmetric matrix ``a[c]`` (``(n, m, m)``) with
    ``use[c]``: ``trace(A) ||L^-1||_F^2`` from its Cholesky factor ``L`` (``λ_max <= trace``, ``1/λ_min =
    ||L^-1||_2^2 <= ||L^-1||_F^2``), at most ``m^2`` times the condition number; ``inf`` where the
    factorisation fails (not positive definite to round-off) or ``use`` is false. A cheap screen before an
    exact ``np.linalg.cond`` (SVD) of the few cells it cannot place far below a limit."""
    n, m = a.shape[0], a.shape[1]
    out = np.full(n, np.inf)
    el = np.zeros((m, m))
    inv = np.zeros((m, m))
    for c in range(n):
        if not use[c]:
            continue
        ok = True
        trace = 0.0
        for i in range(m):
            trace += a[c, i, i]
            for j in range(i + 1):
                s = a[c, i, j]
                for k in range(j):
                    s -= el[i, k] * el[j, k]
                if i == j:
                    if not s > 0.0:
                        ok = False
                        break
                    el[i, i] = np.sqrt(s)
                else:
                    el[i, j] = s / el[j, j]
            if not ok:
                break
        if not ok:
            continue
        frob = 0.0
        for j in range(m):                      # column j of L^-1 by forward substitution
            for i in range(m):
                if i < j:
                    inv[i, j] = 0.0
                    continue
                s = 1.0 if i == j else 0.0
                for k in range(j, i):
                    s -= el[i, k] * inv[k, j]
                inv[i, j] = s / el[i, i]
                frob += inv[i, j] * inv[i, j]
        out[c] = trace * frob
    return out


@njit(cache=True)
def sort_prefix(a, m):
    """Sort ``a[:m]`` in place: an insertion sort, for the tens of mostly sorted column indices of one sparse
    row (no new array per row, as ``np.sort`` would make)."""
    for q in range(1, m):
        x = a[q]
        p = q - 1
        while p >= 0 and a[p] > x:
            a[p + 1] = a[p]
            p -= 1
        a[p + 1] = x


@njit(cache=True)
def quadratic_face_rows(n_all, sides, weights, cells, coefficients, ptrs, idxs, vals):
    """The face-average operator of :func:`solver.gradient.quadratic_operators` as CSR ``(indptr, indices,
    data)``, ``(n_faces, n_all)``: for each face, the sum over both sides ``s`` (owner, neighbour) of ``w_s``
    times the side cell's identity row, then ``c_t w_s op_t[cell]`` for the operators ``t`` (gradient x, y,
    Hessian xx, xy, yy; CSR ``ptrs[t], idxs[t], vals[t]``) with coefficients ``coefficients[s, t]`` — the
    twelve scipy products ``diags(c) @ (sel @ op)`` added in that order: each entry its terms' running sum
    from 0, every term ``c (w v)``, sorted columns, exact zeros dropped (scipy's rules: bitwise its sum)."""
    n = cells.shape[1]
    n_ops = ptrs.shape[0]
    cap = 0
    for s in range(sides):
        for f in range(n):
            cap += 1
            for t in range(n_ops):
                cap += ptrs[t, cells[s, f] + 1] - ptrs[t, cells[s, f]]
    indptr = np.zeros(n + 1, dtype=np.int64)
    indices = np.empty(cap, dtype=np.int64)
    data = np.empty(cap)
    acc = np.zeros(n_all)
    seen = np.zeros(n_all, dtype=np.bool_)
    touched = np.empty(cap, dtype=np.int64)
    k = 0
    for f in range(n):
        m = 0
        for s in range(sides):
            cell = cells[s, f]
            w = weights[s, f]
            if not seen[cell]:
                seen[cell] = True
                touched[m] = cell
                m += 1
            acc[cell] += w * 1.0
            for t in range(n_ops):
                c = coefficients[s, t, f]
                for jj in range(ptrs[t, cell], ptrs[t, cell + 1]):
                    j = idxs[t][jj]
                    if not seen[j]:
                        seen[j] = True
                        touched[m] = j
                        m += 1
                    acc[j] += c * (w * vals[t][jj])
        sort_prefix(touched, m)
        for q in range(m):
            j = touched[q]
            if acc[j] != 0.0:
                indices[k] = j
                data[k] = acc[j]
                k += 1
            acc[j] = 0.0
            seen[j] = False
        indptr[f + 1] = k
    return indptr, indices[:k], data[:k]


@njit(cache=True)
def nearest_segment_distance(pts, a, b):
    """``(n,)`` distance from each point ``pts[i]`` to the nearest segment ``a[s] -> b[s]``: the minimum over
    every segment of :func:`solver.walldistance.segment_distance` (its operations in its order, bitwise per
    pair)."""
    n, m = pts.shape[0], a.shape[0]
    out = np.empty(n)
    for i in range(n):
        best = np.inf
        for s in range(m):
            abx, aby = b[s, 0] - a[s, 0], b[s, 1] - a[s, 1]
            px, py = pts[i, 0] - a[s, 0], pts[i, 1] - a[s, 1]
            t = (px * abx + py * aby) / max(abx * abx + aby * aby, 1e-300)
            t = min(max(t, 0.0), 1.0)
            dx, dy = pts[i, 0] - (a[s, 0] + t * abx), pts[i, 1] - (a[s, 1] + t * aby)
            d = np.sqrt(dx * dx + dy * dy)
            if d < best:
                best = d
        out[i] = best
    return out


@njit(cache=True)
def stencil_operator_rows(indptr, indices, values, row_sum):
    """CSR ``(indptr, indices, data)`` of ``M - diag(row_sum)`` for ``M`` the CSR pattern ``indptr, indices``
    (sorted columns, no diagonal entry) with row ``c``'s values ``values[c, :len]``: scipy's ``csr_matrix
    ((values, (rows, cols))) - csr_matrix((row_sum, (c, c)))`` (each value, ``-row_sum`` inserted at the
    diagonal in column order, exact zeros dropped: bitwise its arrays), without its COO conversion."""
    n = indptr.shape[0] - 1
    out_ptr = np.zeros(n + 1, dtype=np.int64)
    out_idx = np.empty(indices.shape[0] + n, dtype=np.int64)
    out_val = np.empty(indices.shape[0] + n)
    k = 0
    for c in range(n):
        placed = False
        for q in range(indptr[c + 1] - indptr[c]):
            j = indices[indptr[c] + q]
            if not placed and j > c:
                d = 0.0 - row_sum[c]
                if d != 0.0:
                    out_idx[k] = c
                    out_val[k] = d
                    k += 1
                placed = True
            v = values[c, q]
            if v != 0.0:
                out_idx[k] = j
                out_val[k] = v
                k += 1
        if not placed:
            d = 0.0 - row_sum[c]
            if d != 0.0:
                out_idx[k] = c
                out_val[k] = d
                k += 1
        out_ptr[c + 1] = k
    return out_ptr, out_idx[:k].copy(), out_val[:k].copy()


@njit(cache=True)
def merge_row_pairs(indptr, indices, data):
    """Rows ``2 i`` and ``2 i + 1`` of a CSR matrix (sorted columns) merged: ``indptr``, ``indices`` of each
    pair's column union (ascending) and ``values (nnz, 2)``, 0 where only the other row has the column
    (:func:`solver.gradient.paired_rows`; the arrays of its ``np.unique`` form)."""
    n = (indptr.shape[0] - 1) // 2
    cap = indices.shape[0]
    out_ptr = np.zeros(n + 1, dtype=np.int64)
    out_idx = np.empty(cap, dtype=np.int64)
    values = np.zeros((cap, 2))
    k = 0
    for i in range(n):
        a, a_end = indptr[2 * i], indptr[2 * i + 1]
        b, b_end = indptr[2 * i + 1], indptr[2 * i + 2]
        while a < a_end or b < b_end:
            if b >= b_end or (a < a_end and indices[a] < indices[b]):
                out_idx[k] = indices[a]
                values[k, 0] = data[a]
                a += 1
            elif a >= a_end or indices[b] < indices[a]:
                out_idx[k] = indices[b]
                values[k, 1] = data[b]
                b += 1
            else:
                out_idx[k] = indices[a]
                values[k, 0] = data[a]
                values[k, 1] = data[b]
                a += 1
                b += 1
            k += 1
        out_ptr[i + 1] = k
    return out_ptr, out_idx[:k].copy(), values[:k].copy()


@njit(cache=True)
def normal_matrices(aw, a):
    """``(n, m, m)`` normal matrices ``sum_k aw[c, k, i] a[c, k, j]`` of stacked least-squares systems
    ``(n, K, m)``: ``np.einsum("cki,ckj->cij", aw, a)``, one running sum over ``k`` per entry, as einsum's loop
    sums them (bitwise on the quadratic fits of the blade meshes and random stacks of K 12-33), 4-5x faster."""
    n, K, m = a.shape
    out = np.empty((n, m, m))
    for c in range(n):
        for i in range(m):
            for j in range(m):
                s = 0.0
                for k in range(K):
                    s += aw[c, k, i] * a[c, k, j]
                out[c, i, j] = s
    return out


@njit(cache=True)
def quadratic_fit_tables(xall, centroid, h, other, valid):
    """The quadratic fit's padded design matrix ``a (nc, kmax, 5)`` and its weighted copy ``aw``: with ``s`` the
    scaled offsets ``(xall[other] - x_P) / h`` (0 where not ``valid``), ``a = [s_x, s_y, s_x²/2, s_x s_y,
    s_y²/2]``, ``aw = a / |s|²`` (0 where not valid) — :func:`solver.gradient.quadratic_operators`' numpy
    lines, their operations in their order (bitwise), without their seven ``(nc, kmax, ·)`` temporaries."""
    nc, kmax = other.shape
    a = np.zeros((nc, kmax, 5))
    aw = np.zeros((nc, kmax, 5))
    for c in range(nc):
        for k in range(kmax):
            if not valid[c, k]:
                continue
            o = other[c, k]
            sx = (xall[o, 0] - centroid[c, 0]) / h[c]
            sy = (xall[o, 1] - centroid[c, 1]) / h[c]
            a[c, k, 0] = sx
            a[c, k, 1] = sy
            a[c, k, 2] = 0.5 * (sx * sx)
            a[c, k, 3] = sx * sy
            a[c, k, 4] = 0.5 * (sy * sy)
            w = 1.0 / (sx * sx + sy * sy)
            for q in range(5):
                aw[c, k, q] = a[c, k, q] * w
    return a, aw
