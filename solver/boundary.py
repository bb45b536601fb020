"""Boundary conditions by name, resolved once per mesh into per-boundary-face arrays.

Configure with ``{group: {"type": name, **parameters}}`` (or ``{group: name}``), e.g.::

    {"inlet": {"type": "velocity_inlet", "velocity": (1.0, 0.0)},
     "outlet": {"type": "pressure_outlet", "p": 0.0},
     "top": "symmetry", "bottom": "symmetry", "blade": "wall"}

Types (see :data:`BOUNDARY_CONDITIONS`): ``velocity_inlet``, ``pressure_outlet``, ``wall`` (no slip),
``moving_wall``, ``symmetry``. Every boundary group of the mesh needs a condition.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from . import kernels
from .fvmesh import FVMesh

#: Velocity treatment codes per boundary face.
FIXED, ZERO_GRADIENT, SYMMETRY = 0, 1, 2


#: Stand-ins for "no gradient" in the compiled boundary values (:func:`solver.kernels.boundary_velocity`,
#: :func:`solver.kernels.boundary_pressure`), by the gradient's number of dimensions.
_EMPTY_GRADIENT = {2: np.zeros((0, 2)), 3: np.zeros((0, 2, 2))}


def _boundary_offsets(mesh: FVMesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(owner (nb,), r (nb, 2), r_t (nb, 2))`` of the boundary faces: owner cells, centroid -> face centre and
    its tangential part ``r - (r·n) n``, m (cached in ``mesh.info``: geometry, fixed per mesh)."""
    cached = mesh.info.get("boundary_offsets")
    if cached is None:
        ni = mesh.n_internal
        o = mesh.owner[ni:]
        r = np.ascontiguousarray(mesh.face_centre[ni:] - mesh.centroid[o])
        n = mesh.normal[ni:]
        r_t = np.ascontiguousarray(r - np.einsum("ij,ij->i", r, n)[:, None] * n)
        cached = mesh.info["boundary_offsets"] = (o, r, r_t)
    return cached


@dataclass(frozen=True, eq=False)
class BoundaryData:
    """Per-boundary-face arrays (``nb`` faces, local index ``face - n_internal``).

    velocity_kind: ``(nb,)`` FIXED / ZERO_GRADIENT / SYMMETRY.
    u_fixed: ``(nb, 2)`` prescribed velocity on FIXED faces (m/s), 0 elsewhere.
    p_fixed: ``(nb,)`` True where the static pressure is prescribed (outlets; ``p' = 0`` there).
    p_value: ``(nb,)`` prescribed pressure there, Pa.
    p_mean: ``((local faces, target Pa), ...)``: groups whose face pressures follow the interior
        (zero normal gradient) shifted so that their length-weighted mean is the target.
    types: ``{group: condition type}`` for reports.
    turb_intensity, turb_ratio, turb_length: ``(nb,)`` inlet turbulence intensity, eddy-viscosity ratio
        nu_t/nu and length scale (m) of ``velocity_inlet`` faces (NaN elsewhere; length NaN unless given),
        read by :mod:`solver.turbulence` only.
    """

    velocity_kind: np.ndarray
    u_fixed: np.ndarray
    p_fixed: np.ndarray
    p_value: np.ndarray
    p_mean: tuple
    types: dict
    turb_intensity: np.ndarray | None = None
    turb_ratio: np.ndarray | None = None
    turb_length: np.ndarray | None = None

    @property
    def has_fixed_pressure(self) -> bool:
        return bool(self.p_fixed.any())

    def velocity(self, mesh: FVMesh, u: np.ndarray, grad_u: np.ndarray | None = None) -> np.ndarray:
        """Velocity at the boundary-face centres ``(nb, 2)`` given cell velocities ``u (nc, 2)``.

        Zero-gradient and symmetry faces take the owner value reconstructed along the face
        (``u_P + grad_u_P·r_t``, ``r_t`` the tangential part of centroid -> face centre) when the
        gradient ``grad_u (nc, 2, 2)`` is given: exact for fields with zero normal derivative.
        """
        ni = mesh.n_internal
        o, r, r_t = _boundary_offsets(mesh)
        g = _EMPTY_GRADIENT[3] if grad_u is None else np.ascontiguousarray(grad_u, dtype=float)
        return kernels.boundary_velocity(np.ascontiguousarray(u, dtype=float), g, o, r_t, mesh.normal[ni:],
                                         self.velocity_kind, self.u_fixed, FIXED, SYMMETRY)

    def pressure(self, mesh: FVMesh, p: np.ndarray, grad_p: np.ndarray | None) -> np.ndarray:
        """Pressure at the boundary-face centres ``(nb,)``: prescribed, else extrapolated from the owner
        cell with its gradient (zero normal gradient if ``grad_p`` is None)."""
        ni = mesh.n_internal
        o, r, r_t = _boundary_offsets(mesh)
        g = _EMPTY_GRADIENT[2] if grad_p is None else np.ascontiguousarray(grad_p, dtype=float)
        out, along = kernels.boundary_pressure(np.ascontiguousarray(p, dtype=float), g, o, r, r_t, self.p_fixed,
                                               self.p_value)
        for j, target in self.p_mean:   # zero normal gradient: the owner value along the face, shifted
            w = mesh.length[ni + j]
            prof = along[j]
            out[j] = prof - np.dot(w, prof) / w.sum() + target
        return out


# ----------------------------------------------------------------------------------------- conditions
@dataclass
class _Arrays:
    """Mutable arrays filled by the conditions while :func:`resolve_boundaries` runs."""

    velocity_kind: np.ndarray
    u_fixed: np.ndarray
    p_fixed: np.ndarray
    p_value: np.ndarray
    p_mean: list
    turb_intensity: np.ndarray
    turb_ratio: np.ndarray
    turb_length: np.ndarray


def _tangential(mesh, j, vel):
    n = mesh.normal[mesh.n_internal + j]
    return vel - np.einsum("ij,ij->i", vel, n)[:, None] * n


def velocity_inlet(mesh: FVMesh, j: np.ndarray, arr: _Arrays, velocity=(1.0, 0.0), profile=None,
                   intensity=0.05, viscosity_ratio=10.0, length_scale=None):
    """Prescribed velocity (m/s): uniform ``velocity`` or ``profile(xy (k, 2)) -> (k, 2)`` at face centres;
    pressure zero-gradient (extrapolated).

    Turbulence (used only with a turbulence model, :mod:`solver.turbulence`): intensity I (default 5 %)
    and eddy-to-molecular viscosity ratio nu_t/nu (default 10), or a length scale (m) instead of the
    ratio: ``k = 1.5 (I |U|)²``, ``omega = k/(nu ratio)`` (or ``sqrt(k)/(beta*^0.25 L)``).
    """
    xy = mesh.face_centre[mesh.n_internal + j]
    vel = np.asarray(profile(xy), float) if profile is not None else np.broadcast_to(velocity, xy.shape)
    arr.velocity_kind[j] = FIXED
    arr.u_fixed[j] = vel
    if not (intensity >= 0 and viscosity_ratio > 0):
        raise ValueError(f"velocity_inlet: intensity {intensity!r} must be >= 0 and viscosity_ratio "
                         f"{viscosity_ratio!r} > 0")
    arr.turb_intensity[j] = intensity
    arr.turb_ratio[j] = viscosity_ratio
    if length_scale is not None:
        arr.turb_length[j] = length_scale


def pressure_outlet(mesh: FVMesh, j: np.ndarray, arr: _Arrays, p=0.0, mode="fixed"):
    """Outlet at static pressure ``p`` (Pa); velocity zero-gradient (backflow lagged).

    mode ``"fixed"``: ``p`` on every face. ``"mean"``: the face pressures follow the interior (zero
    normal gradient) and are shifted so that their length-weighted mean is ``p`` (Schäfer–Turek's
    zero-average outflow pressure).
    """
    if mode not in ("fixed", "mean"):
        raise ValueError(f"pressure_outlet mode {mode!r}: 'fixed' or 'mean'")
    arr.velocity_kind[j] = ZERO_GRADIENT
    arr.p_fixed[j] = True
    arr.p_value[j] = p
    if mode == "mean":
        arr.p_mean.append((j, float(p)))


def wall(mesh: FVMesh, j: np.ndarray, arr: _Arrays):
    """No-slip stationary wall: u = 0; pressure zero-gradient."""
    arr.velocity_kind[j] = FIXED
    arr.u_fixed[j] = 0.0


def moving_wall(mesh: FVMesh, j: np.ndarray, arr: _Arrays, velocity=(1.0, 0.0)):
    """Wall sliding in its own plane: the tangential part of ``velocity`` (m/s) is imposed."""
    arr.velocity_kind[j] = FIXED
    arr.u_fixed[j] = _tangential(mesh, j, np.broadcast_to(np.asarray(velocity, float), (j.size, 2)))


def symmetry(mesh: FVMesh, j: np.ndarray, arr: _Arrays):
    """Symmetry plane: zero normal velocity and flux, zero normal gradient of the tangential velocity."""
    arr.velocity_kind[j] = SYMMETRY


#: Boundary conditions by type name: ``f(mesh, local_faces, arrays, **parameters)``.
BOUNDARY_CONDITIONS: dict[str, Callable] = {
    "velocity_inlet": velocity_inlet,
    "pressure_outlet": pressure_outlet,
    "wall": wall,
    "no_slip_wall": wall,
    "moving_wall": moving_wall,
    "symmetry": symmetry,
}


def resolve_boundaries(mesh: FVMesh, config: dict) -> BoundaryData:
    """Apply ``{group: {"type": ..., **params}}`` to the mesh's boundary groups (once per mesh)."""
    nb = mesh.n_boundary
    arr = _Arrays(np.full(nb, -1), np.zeros((nb, 2)), np.zeros(nb, bool), np.zeros(nb), [],
                  np.full(nb, np.nan), np.full(nb, np.nan), np.full(nb, np.nan))
    missing = [g for g in mesh.group_names if g not in config]
    if missing:
        raise ValueError(f"no boundary condition for groups {missing}")
    extra = [g for g in config if g not in mesh.group_names]
    if extra:
        raise ValueError(f"boundary conditions for groups not in the mesh: {extra} "
                         f"(mesh groups: {list(mesh.group_names)})")
    types = {}
    for group, spec in config.items():
        spec = {"type": spec} if isinstance(spec, str) else dict(spec)
        kind = spec.pop("type")
        try:
            fn = BOUNDARY_CONDITIONS[kind]
        except KeyError:
            raise ValueError(f"group {group!r}: unknown boundary condition {kind!r}; choose from "
                             f"{sorted(BOUNDARY_CONDITIONS)}") from None
        fn(mesh, mesh.boundary_local(group), arr, **spec)
        types[group] = kind
    return BoundaryData(arr.velocity_kind, arr.u_fixed, arr.p_fixed, arr.p_value, tuple(arr.p_mean), types,
                        arr.turb_intensity, arr.turb_ratio, arr.turb_length)
