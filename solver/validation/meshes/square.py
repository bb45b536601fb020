"""Small mesh generators for solver verification (cavity, unit square): numpy only, deterministic."""

from __future__ import annotations

import numpy as np

from ...fvmesh import FVMesh, build_fvmesh


def clustered(n: int, strength: float = 0.0) -> np.ndarray:
    """``n + 1`` points on [0, 1] clustered towards both ends.

    ``x = s - strength sin(2 pi s) / (2 pi)`` with ``s`` uniform; ``strength`` in [0, 1) (0: uniform,
    0.5: end cells about half the mean size).
    """
    s = np.linspace(0.0, 1.0, n + 1)
    return s - strength * np.sin(2.0 * np.pi * s) / (2.0 * np.pi)


def square_mesh(nx: int, ny: int | None = None, *, triangles: str = "right_half", strength: float = 0.0,
                distort: float = 0.0, seed: int = 0, size: float = 1.0) -> FVMesh:
    """A mixed quad/triangle mesh of the square ``[0, size]²`` with groups ``bottom, right, top, left``.

    ``triangles``: which quads are split into two triangles: ``"none"``, ``"all"``, ``"right_half"``
    (x > size/2) or ``"checker"``; diagonals alternate so that the mesh has no preferred direction.
    ``strength``: wall clustering (see :func:`clustered`). ``distort``: random displacement of interior
    nodes as a fraction of the local spacing (0.2 gives visibly skewed, non-orthogonal cells).
    """
    ny = nx if ny is None else ny
    x = clustered(nx, strength) * size
    y = clustered(ny, strength) * size
    X, Y = np.meshgrid(x, y, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel()])
    if distort > 0:
        rng = np.random.default_rng(seed)
        hx = np.gradient(x)[:, None] * np.ones((1, ny + 1))
        hy = np.ones((nx + 1, 1)) * np.gradient(y)[None, :]
        shift = distort * rng.uniform(-0.5, 0.5, (nx + 1, ny + 1, 2)) * np.stack([hx, hy], -1)
        inner = np.zeros((nx + 1, ny + 1), bool)
        inner[1:-1, 1:-1] = True
        pts[inner.ravel()] += shift[inner].reshape(-1, 2)
    nid = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    i, j = i.ravel(), j.ravel()
    quads = np.column_stack([nid[i, j], nid[i + 1, j], nid[i + 1, j + 1], nid[i, j + 1]])
    xc = 0.5 * (x[i] + x[i + 1])
    split = {"none": np.zeros(i.size, bool), "all": np.ones(i.size, bool),
             "right_half": xc > 0.5 * size, "checker": (i // 4 + j // 4) % 2 == 1}[triangles]
    alt = (i + j) % 2 == 0
    q = quads[split]
    a = alt[split]
    t1 = np.where(a[:, None], q[:, [0, 1, 2]], q[:, [0, 1, 3]])
    t2 = np.where(a[:, None], q[:, [0, 2, 3]], q[:, [1, 2, 3]])
    cells = {"quad": quads[~split], "triangle": np.concatenate([t1, t2])}
    b = np.arange(nx)
    c = np.arange(ny)
    boundary = {
        "bottom": np.column_stack([nid[b, 0], nid[b + 1, 0]]),
        "right": np.column_stack([nid[nx, c], nid[nx, c + 1]]),
        "top": np.column_stack([nid[b + 1, ny], nid[b, ny]]),
        "left": np.column_stack([nid[0, c + 1], nid[0, c]]),
    }
    return build_fvmesh(pts, cells, boundary)
