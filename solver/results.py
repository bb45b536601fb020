"""Results of a steady solve: fields, convergence history, forces, C_max, sampling and .vtu output."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .boundary import FIXED, BoundaryData
from .convergence import ConvergenceClass
from .fvmesh import CELL_TYPES, FVMesh
from .gradient import ls_gradient


@dataclass(frozen=True)
class Forces:
    """Force per unit span (N/m) exerted by the fluid on a boundary group, split in parts."""

    pressure: np.ndarray
    viscous: np.ndarray

    @property
    def total(self) -> np.ndarray:
        return self.pressure + self.viscous

    @property
    def fx(self) -> float:
        return float(self.total[0])

    @property
    def fy(self) -> float:
        return float(self.total[1])


@dataclass(eq=False)
class FlowResults:
    """Steady incompressible flow on ``mesh``.

    u: ``(nc, 2)`` cell-centre velocity, m/s. p: ``(nc,)`` cell-centre static pressure, Pa.
    flux: ``(nf,)`` face mass flux owner -> neighbour, kg/(s m).
    residuals: ``{"u", "v", "continuity": (iterations,)}`` scaled residuals per outer iteration.
    status: a :class:`solver.convergence.ConvergenceClass`, never ``stationary`` (monitors stationary at
        the cap make a ``converged`` solve); ``message`` says why (for ``diverged``: iteration and variable).
    rho (kg/m³), mu (Pa s): fluid properties used.
    k (m²/s²), omega (1/s), nu_t (m²/s): ``(nc,)`` turbulence fields (None when laminar).
    mu_wall: ``(nb,)`` effective viscosity of the boundary faces for the wall shear, Pa s: the molecular
        ``mu`` except on walls under the ``automatic`` wall treatment (``rho u_tau² dn / |u_t|``, the
        wall-function shear); None means ``mu`` everywhere. wall_treatment: its name, or None.
    classification: :class:`solver.convergence.Classification` of a solve stopped by ``max_iter``
        (window means, amplitudes and periods of the monitors), else None.
    """

    mesh: FVMesh
    boundary: BoundaryData
    u: np.ndarray
    p: np.ndarray
    flux: np.ndarray
    residuals: dict
    status: ConvergenceClass
    message: str
    iterations: int
    rho: float
    mu: float
    wall_time: float = 0.0
    monitors: dict = field(default_factory=dict)
    k: np.ndarray | None = None
    omega: np.ndarray | None = None
    nu_t: np.ndarray | None = None
    mu_wall: np.ndarray | None = None
    wall_treatment: str | None = None
    classification: object = None

    def __post_init__(self) -> None:
        self.status = ConvergenceClass(self.status)      # ValueError names a status outside the classes

    @property
    def converged(self) -> bool:
        return self.status == ConvergenceClass.CONVERGED

    @property
    def c_max(self) -> float:
        """C_max: the largest velocity magnitude ``max_c sqrt(u_c² + v_c²)`` over the cell-centre values
        (cell averages, m/s); boundary-face values are not included."""
        return float(np.sqrt((self.u**2).sum(axis=1)).max())

    def grad_u(self) -> np.ndarray:
        """Velocity gradient ``(nc, 2, 2)`` ``[cell, component, direction]``, 1/s."""
        g = ls_gradient(self.mesh, self.u, self.boundary.velocity(self.mesh, self.u))
        return ls_gradient(self.mesh, self.u, self.boundary.velocity(self.mesh, self.u, g))

    def grad_p(self) -> np.ndarray:
        """Pressure gradient ``(nc, 2)``, Pa/m (boundary pressure extrapolated with zero normal gradient
        on walls, then re-extrapolated with the gradient)."""
        g = ls_gradient(self.mesh, self.p, self.boundary.pressure(self.mesh, self.p, None))
        return ls_gradient(self.mesh, self.p, self.boundary.pressure(self.mesh, self.p, g))

    def boundary_pressure(self) -> np.ndarray:
        """Static pressure at the boundary-face centres ``(nb,)``, Pa (linear extrapolation)."""
        return self.boundary.pressure(self.mesh, self.p, self.grad_p())

    def forces(self, group: str) -> Forces:
        """Force of the fluid on the boundary ``group`` per unit span (N/m).

        Pressure part ``sum p_f S_f`` (S outward from the fluid, p extrapolated to the face centre);
        viscous part ``sum |S| tau_w`` with the wall shear of :meth:`wall_shear` (laminar and ``low_re``:
        ``mu (u_P - u_b)_t / dn``, a one-sided difference; ``automatic``: the wall-function shear).
        """
        m = self.mesh
        j = m.boundary_local(group)
        f = m.n_internal + j
        pb = self.boundary_pressure()[j]
        pressure = (pb[:, None] * m.sf[f]).sum(axis=0)
        mu_w, dn, du_t = self._shear_parts(group)
        viscous = (mu_w * m.length[f] / dn)[:, None] * du_t
        return Forces(pressure, viscous.sum(axis=0))

    def wall_faces(self, group: str) -> np.ndarray:
        """Face centres ``(nfaces, 2)`` of boundary ``group`` in the group's face order, m."""
        return self.mesh.face_centre[self.mesh.boundary[group]]

    def wall_shear(self, group: str) -> np.ndarray:
        """Wall shear stress vector ``(nfaces, 2)`` exerted by the fluid on each face of ``group``, Pa:
        ``mu_w (u_P - u_b)_t / dn`` (tangential velocity of the owner cell relative to the wall over the
        normal distance of its centroid); ``mu_w`` is ``mu`` (laminar, ``low_re``, where nu_t = 0 at the
        wall) or the wall-function viscosity ``rho u_tau² dn/|u_t|`` (``automatic``: ``|tau| = rho
        u_tau²``)."""
        mu_w, dn, du_t = self._shear_parts(group)
        return (mu_w / dn)[:, None] * du_t

    def _shear_parts(self, group: str):
        """``(mu_w, dn, du_t)`` of the faces of ``group``: wall viscosity (scalar or ``(k,)``), owner
        centroid normal distance ``(k,)`` and tangential velocity difference owner - face ``(k, 2)``."""
        m = self.mesh
        j = m.boundary_local(group)
        f = m.n_internal + j
        # fixed-velocity faces (walls) take their prescribed value: no velocity gradient needed
        fixed = np.all(self.boundary.velocity_kind[j] == FIXED)
        du = self.u[m.owner[f]] - self.boundary.velocity(m, self.u, None if fixed else self.grad_u())[j]
        n = m.normal[f]
        du_t = du - np.einsum("ij,ij->i", du, n)[:, None] * n
        dn = np.einsum("ij,ij->i", m.d[f], n)
        mu_w = self.mu if self.mu_wall is None else self.mu_wall[j]
        return mu_w, dn, du_t

    def y_plus(self, group: str) -> np.ndarray:
        """``y+ = dn u_tau / nu`` of the owner-cell centroid of each face of ``group`` ``(nfaces,)``, with
        ``u_tau = sqrt(|tau_w| / rho)`` from :meth:`wall_shear` and ``dn`` the centroid's normal distance."""
        m = self.mesh
        f = m.boundary[group]
        dn = np.einsum("ij,ij->i", m.d[f], m.normal[f])
        u_tau = np.sqrt(np.linalg.norm(self.wall_shear(group), axis=1) / self.rho)
        return dn * u_tau * self.rho / self.mu

    def sample(self, xy, which: str = "u") -> np.ndarray:
        """Linear reconstruction of ``u`` ``(k, 2)`` or ``p`` ``(k,)`` at points ``xy (k, 2)`` from the
        nearest cell centroid: ``phi_c + grad phi_c·(x - x_c)`` (second-order accurate inside cells)."""
        from scipy.spatial import cKDTree

        xy = np.asarray(xy, float)
        _, c = cKDTree(self.mesh.centroid).query(xy)
        r = xy - self.mesh.centroid[c]
        if which == "u":
            return self.u[c] + np.einsum("kcd,kd->kc", self.grad_u()[c], r)
        if which == "p":
            return self.p[c] + np.einsum("kd,kd->k", self.grad_p()[c], r)
        raise ValueError(f"unknown field {which!r}: 'u' or 'p'")

    def write_vtu(self, path: str | Path) -> None:
        """Write cell fields ``U`` (3-vector), ``p`` and ``mag_U`` (and ``k``, ``omega``, ``nu_t`` when
        turbulent) to a VTK unstructured-grid file."""
        import meshio

        m = self.mesh
        pts = np.column_stack([m.points, np.zeros(len(m.points))])
        blocks = [(k, m.cells[k]) for k in CELL_TYPES if k in m.cells]
        sizes = np.cumsum([0] + [len(c) for _, c in blocks])

        def split(a):
            return [a[sizes[i]:sizes[i + 1]] for i in range(len(blocks))]

        u3 = np.column_stack([self.u, np.zeros(m.n_cells)])
        data = {"U": split(u3), "p": split(self.p), "mag_U": split(np.linalg.norm(self.u, axis=1))}
        for name in ("k", "omega", "nu_t"):
            if getattr(self, name) is not None:
                data[name] = split(getattr(self, name))
        meshio.Mesh(pts, blocks, cell_data=data).write(Path(path))

    def summary(self) -> str:
        r = {k: f"{v[-1]:.2e}" for k, v in self.residuals.items() if len(v)}
        return (f"{self.status} after {self.iterations} iterations ({self.wall_time:.1f} s); residuals {r}; "
                f"C_max = {self.c_max:.5f} m/s; {self.message}")
