"""An AMG hierarchy whose coarse operators follow a changing matrix: interpolation kept, Galerkin products redone.

The pressure-correction matrix of a SIMPLE iteration keeps its sparsity pattern (the mesh's) while its values
change from one outer iteration to the next. A Ruge–Stüben set-up (strength of connection, C/F splitting,
interpolation weights, then the Galerkin products ``A_c = R A P``) costs ~25 ms on a 16 641-cell blade mesh,
half of it pyamg's Python; one V-cycle 1.5 ms. Rebuilding it every 10 solves and using it unchanged in
between left the fine-level smoother
and every coarse operator up to 9 outer iterations old.

:class:`GalerkinHierarchy` keeps the interpolation ``P`` of each level of a pyamg hierarchy and re-forms the
coarse operators from the current fine matrix. ``R A P`` with fixed ``P`` and a fixed pattern of ``A`` is a
fixed linear map of ``A``'s stored values, ``A_c.data = G A.data`` with ``G[(I, J), (i, j)] = P[i, I] P[j, J]``
(:func:`galerkin_map`, built once per set-up), so a refresh is one sparse product per level (0.7 ms in all
at 16 641 cells) instead of a set-up. On the benchmark blade at medium, with the first system's interpolation
kept for the whole solve, the pressure solves took 3.2 CG iterations after the first 10 (at most 4) against
3.3 with the whole hierarchy rebuilt every 10 solves, and 31 set-ups (0.70 s CPU) became one
(docs/decisions/0012-pressure-amg.md).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from numba import njit
from scipy.linalg.lapack import dpotrf, dpotrs

from .kernels import csr_matvec, csr_residual, gauss_seidel_sweeps, sort_prefix, unsigned


def galerkin_map(indptr: np.ndarray, indices: np.ndarray, P: sp.csr_matrix, symmetric: bool = False):
    """The coarse operator ``P^T A P`` as a linear map of ``A``'s stored values, for a fixed pattern of ``A``
    (CSR ``indptr``, ``indices``) and a fixed interpolation ``P`` (n x n_c).

    Returns ``(G, rows, c_indptr, c_indices, mirror)``: ``G`` CSR with ``coarse_data[rows] = G @ A.data``,
    the coarse CSR pattern (sorted columns; every product that can be non-zero is stored, also where values
    cancel, so the pattern does not depend on ``A``'s values), and ``mirror`` ``(2, m)``: the coarse slots
    filled by copying, ``coarse_data[mirror[0]] = coarse_data[mirror[1]]``. ``symmetric``: ``A`` is
    symmetric (values and pattern), so ``G`` forms the entries ``I <= J`` only and the others are mirrored
    (half the products; the coarse matrix exactly symmetric); else ``rows`` is every slot and ``mirror``
    empty.

    Built coarse row by coarse row in one compiled loop (:func:`_galerkin_rows`: each row's columns from a
    marker array, then its products in the order of ``A``'s entries): the arrays of the sort-based numpy
    form (``galerkin_map_numpy`` in tests/solver/test_linalg.py, ``np.unique`` over every product's key) bitwise, 3-4x
    faster (its sort was half of a GalerkinHierarchy's set-up)."""
    P = P.tocsr()
    n_c = P.shape[1]
    p_indptr, p_indices = np.asarray(P.indptr, dtype=np.int64), np.asarray(P.indices, dtype=np.int64)
    a_indptr, a_indices = np.asarray(indptr, dtype=np.int64), np.asarray(indices, dtype=np.int64)
    c_indptr, c_cols, g_indptr, g_indices, g_data, formed = _galerkin_rows(
        a_indptr, a_indices, p_indptr, p_indices, np.asarray(P.data, dtype=float), n_c, symmetric)
    G = sp.csr_matrix((g_data, g_indices, g_indptr), shape=(formed.size, a_indices.size))
    if symmetric:
        c_rows = np.repeat(np.arange(n_c), np.diff(c_indptr))
        coarse = c_rows * n_c + c_cols
        copied = np.flatnonzero(c_rows > c_cols)
        source = np.searchsorted(coarse, c_cols[copied] * n_c + c_rows[copied])
        if not np.array_equal(coarse[np.minimum(source, coarse.size - 1)], c_cols[copied] * n_c + c_rows[copied]):
            raise ValueError("the coarse pattern is not symmetric")
        mirror = np.stack([copied, source])
    else:
        mirror = np.zeros((2, 0), dtype=np.int64)
    return G, formed, c_indptr, c_cols, mirror


@njit(cache=True)
def _galerkin_rows(a_indptr, a_indices, p_indptr, p_indices, p_data, n_c, symmetric):
    """:func:`galerkin_map`'s coarse pattern and map: for each coarse row ``I``, the columns ``J`` reached by
    ``P[i, I] A[i, j] P[j, J]`` (sorted), then for each formed slot (``I <= J`` if ``symmetric``, else all)
    its products ``P[i, I] P[j, J]`` with the index of ``A``'s entry ``(i, j)``, in increasing entry order.
    Returns ``(c_indptr, c_cols, g_indptr, g_indices, g_data, formed)``."""
    n = p_indptr.shape[0] - 1
    # R = P^T with the slot of each entry in P (rows of P in increasing order within each R row)
    r_ptr = np.zeros(n_c + 1, dtype=np.int64)
    for k in range(p_indices.shape[0]):
        r_ptr[p_indices[k] + 1] += 1
    for c in range(n_c):
        r_ptr[c + 1] += r_ptr[c]
    fill = r_ptr[:-1].copy()
    r_row = np.empty(p_indices.shape[0], dtype=np.int64)
    r_slot = np.empty(p_indices.shape[0], dtype=np.int64)
    for i in range(n):
        for k in range(p_indptr[i], p_indptr[i + 1]):
            c = p_indices[k]
            r_row[fill[c]] = i
            r_slot[fill[c]] = k
            fill[c] += 1
    total = 0
    for i in range(n):
        li = p_indptr[i + 1] - p_indptr[i]
        for jj in range(a_indptr[i], a_indptr[i + 1]):
            j = a_indices[jj]
            total += li * (p_indptr[j + 1] - p_indptr[j])
    c_indptr = np.zeros(n_c + 1, dtype=np.int64)
    c_cols = np.empty(total, dtype=np.int64)
    g_indptr = np.zeros(total + 1, dtype=np.int64)
    g_indices = np.empty(total, dtype=np.int64)
    g_data = np.empty(total)
    formed = np.empty(total, dtype=np.int64)
    local = np.full(n_c, -1, dtype=np.int64)        # J -> its slot in the current row
    count = np.zeros(n_c, dtype=np.int64)
    touched = np.empty(n_c, dtype=np.int64)
    nnz, n_formed, n_g = 0, 0, 0
    for big_i in range(n_c):
        m = 0
        for rr in range(r_ptr[big_i], r_ptr[big_i + 1]):
            i = r_row[rr]
            for jj in range(a_indptr[i], a_indptr[i + 1]):
                j = a_indices[jj]
                for kk in range(p_indptr[j], p_indptr[j + 1]):
                    big_j = p_indices[kk]
                    if local[big_j] < 0:
                        local[big_j] = 0
                        touched[m] = big_j
                        m += 1
                    count[big_j] += 1
        sort_prefix(touched, m)
        cols = touched
        for q in range(m):
            big_j = cols[q]
            c_cols[nnz + q] = big_j
            if symmetric and big_j < big_i:
                local[big_j] = -2                     # mirrored, not formed
                continue
            formed[n_formed] = nnz + q
            g_indptr[n_formed + 1] = g_indptr[n_formed] + count[big_j]
            local[big_j] = g_indptr[n_formed]         # next free G entry of this slot
            n_formed += 1
        for rr in range(r_ptr[big_i], r_ptr[big_i + 1]):
            i = r_row[rr]
            vi = p_data[r_slot[rr]]
            for jj in range(a_indptr[i], a_indptr[i + 1]):
                j = a_indices[jj]
                for kk in range(p_indptr[j], p_indptr[j + 1]):
                    big_j = p_indices[kk]
                    at = local[big_j]
                    if at >= 0:
                        g_indices[at] = jj
                        g_data[at] = vi * p_data[kk]
                        local[big_j] = at + 1
        n_g = g_indptr[n_formed]
        for q in range(m):
            local[cols[q]] = -1
            count[cols[q]] = 0
        nnz += m
        c_indptr[big_i + 1] = nnz
    return (c_indptr, c_cols[:nnz].copy(), g_indptr[:n_formed + 1].copy(), g_indices[:n_g].copy(),
            g_data[:n_g].copy(), formed[:n_formed].copy())


@njit(cache=True)
def _refresh_level(data, diag_slots, off_slots, g_ptr, g_idx, g_val, g_rows, mirror, off_val, inv_diag, coarse):
    """One level's refresh in one pass: the reciprocal diagonal and the off-diagonal values for the
    smoother, and the next level's values ``coarse[g_rows] = G data``, ``coarse[mirror[0]] =
    coarse[mirror[1]]`` (:func:`galerkin_map`)."""
    for i in range(diag_slots.shape[0]):
        d = data[diag_slots[i]] if diag_slots[i] >= 0 else 0.0
        inv_diag[i] = 1.0 / d if d != 0.0 else 0.0
    for k in range(off_slots.shape[0]):
        off_val[k] = data[off_slots[k]]
    for r in range(g_rows.shape[0]):
        s = 0.0
        for jj in range(g_ptr[r], g_ptr[r + 1]):
            s += g_val[jj] * data[g_idx[jj]]
        coarse[g_rows[r]] = s
    for m in range(mirror.shape[1]):
        coarse[mirror[0, m]] = coarse[mirror[1, m]]


class _Level:
    """One level above the coarsest: the pattern of its matrix, the split into diagonal and off-diagonal
    slots, its interpolation and restriction, and the Galerkin map to the next level."""

    def __init__(self, indptr: np.ndarray, indices: np.ndarray, P: sp.csr_matrix, symmetric: bool):
        self.n, self.n_coarse = indptr.size - 1, P.shape[1]
        self.indptr, self.indices = unsigned(indptr), unsigned(indices)
        rows = np.repeat(np.arange(self.n), np.diff(indptr))
        is_diag = rows == indices
        self.diag_slots = np.full(self.n, -1, dtype=np.int64)
        self.diag_slots[rows[is_diag]] = np.flatnonzero(is_diag)
        self.off_slots = np.flatnonzero(~is_diag)
        self.off_indptr = unsigned(np.concatenate([[0], np.cumsum(np.bincount(rows[~is_diag], minlength=self.n))]))
        self.off_indices = unsigned(indices[~is_diag])
        P = P.tocsr()
        R = P.T.tocsr()
        self.P = (unsigned(P.indptr), unsigned(P.indices), P.data)
        self.R = (unsigned(R.indptr), unsigned(R.indices), R.data)
        G, g_rows, self.c_indptr, self.c_indices, self.mirror = galerkin_map(indptr, indices, P, symmetric)
        self.G = (unsigned(G.indptr), unsigned(G.indices), G.data, g_rows)
        self.off_val = np.empty(self.off_slots.size)
        self.inv_diag = np.empty(self.n)
        self.coarse = np.empty(self.c_indices.size)
        self.smooth = (self.off_indptr, self.off_indices, self.off_val, self.inv_diag)
        self.data = None

    def refresh(self, data: np.ndarray) -> np.ndarray:
        """Take ``data`` as this level's matrix values; returns the next level's (a buffer of this level,
        overwritten by the next refresh)."""
        self.data = data
        _refresh_level(data, self.diag_slots, self.off_slots, *self.G, self.mirror, self.off_val, self.inv_diag,
                       self.coarse)
        return self.coarse


class GalerkinHierarchy:
    """A V-cycle preconditioner ``z = M r`` (from a zero guess; one symmetric Gauss–Seidel sweep before and
    after the coarse-grid correction on each level, a dense factorisation on the coarsest) on the levels of a
    pyamg hierarchy ``ml`` whose interpolation operators are kept and whose operators are re-formed from
    the matrix given to :meth:`refresh` (the pattern ``indptr``, ``indices`` of the matrix ``ml`` was built
    on). The cycle of :class:`solver.linalg.VCycle`, on refreshed operators. ``symmetric``: the matrices
    are symmetric (the CG case), so each Galerkin map forms half the coarse entries (:func:`galerkin_map`)."""

    def __init__(self, ml, indptr: np.ndarray, indices: np.ndarray, symmetric: bool = False):
        self.indptr, self.indices = indptr, indices
        self.levels: list[_Level] = []
        for lvl in ml.levels[:-1]:
            level = _Level(np.asarray(indptr), np.asarray(indices), lvl.P, symmetric)
            self.levels.append(level)
            indptr, indices = level.c_indptr, level.c_indices
        n = indptr.size - 1
        self.coarse_n = n
        self.coarse_slots = (np.repeat(np.arange(n), np.diff(indptr)), np.asarray(indices, dtype=np.int64))
        self.coarse_factor = None

    def matches(self, A: sp.csr_matrix) -> bool:
        """Whether ``A`` has the pattern this hierarchy was built for."""
        return A.indptr is self.indptr or (A.indptr.size == self.indptr.size and A.indices.size == self.indices.size
                                           and np.array_equal(A.indptr, self.indptr)
                                           and np.array_equal(A.indices, self.indices))

    def refresh(self, data: np.ndarray) -> None:
        """Re-form every level's operator from the fine matrix values ``data`` (the set-up's pattern)."""
        data = np.ascontiguousarray(data, dtype=float)
        for level in self.levels:
            data = level.refresh(data)
        dense = np.zeros((self.coarse_n, self.coarse_n))
        dense[self.coarse_slots] = data
        factor, info = dpotrf(dense, lower=False, clean=False) if np.isfinite(dense).all() else (None, -1)
        if info == 0:
            self.coarse_factor = ("cholesky", factor)
        else:                                   # not SPD (or not finite): pyamg's default, the pseudo-inverse
            self.coarse_factor = ("pinv", sla.pinv(dense))

    def _coarse_solve(self, b: np.ndarray) -> np.ndarray:
        """The coarsest level's solve: LAPACK's Cholesky solve ``dpotrs`` on the factor of :meth:`refresh`
        (``dpotrf``), called directly — what ``scipy.linalg.cho_factor`` / ``cho_solve`` call, bitwise, without
        their per-call validation and batching wrappers (50 µs a V-cycle at 13 unknowns, 1.5 % of a coarse
        blade iteration); a non-finite right-hand side raises ``ValueError`` as ``cho_solve`` does."""
        kind, factor = self.coarse_factor
        if kind != "cholesky":
            return factor @ b
        if not np.isfinite(b).all():
            raise ValueError("array must not contain infs or NaNs")
        return dpotrs(factor, b, lower=False)[0]

    def __call__(self, b: np.ndarray) -> np.ndarray:
        b = np.ascontiguousarray(b, dtype=float)
        if not self.levels:
            return self._coarse_solve(b)
        x = np.zeros_like(b)
        self._cycle(0, x, b)
        return x

    def _cycle(self, k: int, x: np.ndarray, b: np.ndarray) -> None:
        level = self.levels[k]
        gauss_seidel_sweeps(*level.smooth, x, b, 1)
        residual = csr_residual(level.indptr, level.indices, level.data, x, b)
        coarse_b = csr_matvec(*level.R, residual, level.n_coarse)
        if k == len(self.levels) - 1:
            coarse_x = self._coarse_solve(coarse_b)
        else:
            coarse_x = np.zeros_like(coarse_b)
            self._cycle(k + 1, coarse_x, coarse_b)
        x += csr_matvec(*level.P, coarse_x, level.n)
        gauss_seidel_sweeps(*level.smooth, x, b, 1)
