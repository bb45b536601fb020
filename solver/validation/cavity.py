"""Lid-driven cavity validation against Ghia, Ghia & Shin (1982).

Unit square, lid ``top`` moving at U = 1 m/s in +x, the other sides no-slip walls, rho = 1,
mu = 1/Re. Compared: u on the vertical centreline x = 0.5 and v on the horizontal centreline y = 0.5 at
Ghia's tabulated interior points (the wall points, where the values are boundary conditions, are left
out); error measure: RMS over the points of ``computed - reference``, as a fraction of the lid speed.

    millfoil validate cavity --level fine      # Re 100 and 1000 on the n = 100 gmsh mesh

Other meshes and Reynolds numbers through the API:
``res, cmp = run_cavity(1000, 128, "structured", "checker", 0.2)``; ``table(cmp, 1000)`` gives the per-point
records.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import Fluid, Problem, SimpleSettings, solve_steady
from ..linalg import SolverSettings
from .meshes import gmsh_square, square_mesh
from .report import Comparison, ValidationReport, run_summary

#: Location of the published reference tables.
# Published reference tables shipped with the package (copied verbatim from the project's shared/reference).
REFERENCE_DIR = Path(__file__).resolve().parent / "reference"
#: Acceptance (docs/explanation/validation.md): RMS centreline error as a fraction of the lid speed.
TOLERANCE = {100: 0.01, 1000: 0.02}

BOUNDARY_CONDITIONS = {"top": {"type": "moving_wall", "velocity": (1.0, 0.0)},
                       "left": "wall", "right": "wall", "bottom": "wall"}


def load_ghia(re: int, reference_dir: Path = REFERENCE_DIR) -> tuple[np.ndarray, np.ndarray]:
    """Ghia's centreline tables as ``(17, 2)`` arrays: ``(y, u)`` at x = 0.5 and ``(x, v)`` at y = 0.5."""
    u = np.loadtxt(reference_dir / f"ghia_re{re}_u.csv", delimiter=",", comments="#", skiprows=4)
    v = np.loadtxt(reference_dir / f"ghia_re{re}_v.csv", delimiter=",", comments="#", skiprows=4)
    return u, v


def cavity_mesh(n: int, kind: str = "gmsh_mixed", triangles: str = "right_half", strength: float = 0.5,
                distort: float = 0.0):
    """Cavity mesh with about ``n`` cells per side.

    kind: ``"gmsh_mixed"`` (unstructured gmsh mesh: recombined quads for x < 0.5, triangles for
    x > 0.5, ~1.6 n² cells), ``"gmsh_tri"`` (unstructured triangles, ~2.3 n² cells), or ``"structured"``: ``n x n``
    wall-clustered quads with the ``triangles`` selection split into two triangles each
    (``1.5 n²`` cells for ``right_half``).
    """
    if kind.startswith("gmsh"):
        return gmsh_square(1.0 / n, quads="left_half" if kind == "gmsh_mixed" else "none")
    return square_mesh(n, strength=strength, triangles=triangles, distort=distort)


def cavity_settings(re: float, **overrides) -> SimpleSettings:
    """Default solver settings for the cavity at Reynolds number ``re`` (SIMPLEC, ``alpha_p`` = 1).

    Measured (11 078-cell mixed mesh, Re 100): alpha_u 0.95 / 8 Gauss–Seidel sweeps 705 iterations;
    0.98 / 16 sweeps 386. Re 1000 (7 137 cells): 0.9 / 8 461 iterations; 0.95 / 16 254."""
    # startup_iterations=0: the laminar reference cases were validated without the blades' start-up
    base = dict(algorithm="simplec", startup_iterations=0, alpha_u=0.98 if re <= 200 else 0.95, alpha_p=1.0,
                stall_tol=None,
                max_iter=4000, tol=1e-6, monitor_tol=1e-6,
                momentum_solver=SolverSettings("gauss_seidel", 0.1, 16))
    base.update(overrides)
    return SimpleSettings(**base)


@dataclass(frozen=True)
class CentrelineComparison:
    """Computed vs reference centreline values; ``rms_u``, ``rms_v`` as fractions of the lid speed."""

    coord_u: np.ndarray
    u: np.ndarray
    u_ref: np.ndarray
    coord_v: np.ndarray
    v: np.ndarray
    v_ref: np.ndarray

    @property
    def rms_u(self) -> float:
        return float(np.sqrt(np.mean((self.u - self.u_ref) ** 2)))

    @property
    def rms_v(self) -> float:
        return float(np.sqrt(np.mean((self.v - self.v_ref) ** 2)))

    @property
    def rms(self) -> float:
        """RMS over both centrelines together."""
        return float(np.sqrt(np.mean(np.concatenate([self.u - self.u_ref, self.v - self.v_ref]) ** 2)))


def compare(results, re: int) -> CentrelineComparison:
    """Sample the solution at Ghia's interior centreline points."""
    gu, gv = load_ghia(re)
    gu = gu[(gu[:, 0] > 0) & (gu[:, 0] < 1)]
    gv = gv[(gv[:, 0] > 0) & (gv[:, 0] < 1)]
    u = results.sample(np.column_stack([np.full(len(gu), 0.5), gu[:, 0]]))[:, 0]
    v = results.sample(np.column_stack([gv[:, 0], np.full(len(gv), 0.5)]))[:, 1]
    return CentrelineComparison(gu[:, 0], u, gu[:, 1], gv[:, 0], v, gv[:, 1])


def run_cavity(re: int = 100, n: int = 100, kind: str = "gmsh_mixed", triangles: str = "right_half",
               distort: float = 0.0, settings: SimpleSettings | None = None, callback=None):
    """Solve the cavity on :func:`cavity_mesh` ``(n, kind, triangles, distort)``; returns
    ``(results, comparison)``."""
    mesh = cavity_mesh(n, kind, triangles=triangles, distort=distort)
    problem = Problem.create(mesh, BOUNDARY_CONDITIONS, Fluid(rho=1.0, mu=1.0 / re))
    res = solve_steady(problem, settings or cavity_settings(re), callback=callback)
    return res, compare(res, re)


def table(cmp: CentrelineComparison, re: int) -> list[dict]:
    """One record per compared quantity: name, computed, reference, error, tolerance, pass (tolerance
    and pass are None for the individual points; the criterion is the RMS over all of them)."""
    tol = TOLERANCE.get(re, 0.02)
    point = dict(tolerance=None, **{"pass": None})      # the acceptance criterion is on the RMS
    rows = [dict(name=f"u(x=0.5, y={y:.4f})", computed=float(c), reference=float(r), error=float(c - r), **point)
            for y, c, r in zip(cmp.coord_u, cmp.u, cmp.u_ref, strict=True)]
    rows += [dict(name=f"v(x={x:.4f}, y=0.5)", computed=float(c), reference=float(r), error=float(c - r), **point)
             for x, c, r in zip(cmp.coord_v, cmp.v, cmp.v_ref, strict=True)]
    rows.append(dict(name="rms centreline error / U_lid", computed=cmp.rms, reference=0.0, error=cmp.rms,
                     tolerance=tol, **{"pass": cmp.rms <= tol}))
    return rows


# ---------------------------------------------------------------------------------------- validation
#: Cavity runs per level: ``{Re: (n, RMS tolerance as a fraction of the lid speed)}`` on the mixed gmsh
#: mesh (quads for x < 0.5, triangles for x > 0.5). coarse: n = 32 (1 813 cells); measured RMS 0.32 %
#: with linear upwind, 0.63 % with first-order upwind, so 0.45 % fails a first-order convection scheme.
#: medium: n = 64 (~7 100 cells), fine: n = 100 (17 415 cells, <= 20 000 as the acceptance asks), both with the
#: acceptance tolerances (1 % at Re 100, 2 % at Re 1000).
CAVITY_LEVELS = {"coarse": {100: (32, 0.0045)},
                 "medium": {100: (64, TOLERANCE[100]), 1000: (64, TOLERANCE[1000])},
                 "fine": {100: (100, TOLERANCE[100]), 1000: (100, TOLERANCE[1000])}}


def validate_cavity(level: str) -> ValidationReport:
    """Lid-driven cavity vs Ghia, Ghia & Shin (1982): RMS of the centreline velocity errors (u on x = 0.5,
    v on y = 0.5, Ghia's interior points) in % of the lid speed."""
    t0 = time.perf_counter()
    comparisons, details = [], {}
    for re, (n, tol) in CAVITY_LEVELS[level].items():
        res, cmp = run_cavity(re, n, "gmsh_mixed")
        comparisons.append(Comparison.of(f"Re {re}: centreline u, v RMS error vs Ghia (% of lid speed)",
                                         100 * cmp.rms, 0.0, 100 * cmp.rms, 100 * tol))
        details[f"re{re}"] = dict(run_summary(res), rms_u_percent=100 * cmp.rms_u,
                                  rms_v_percent=100 * cmp.rms_v, u_min=float(cmp.u.min()),
                                  v_max=float(cmp.v.max()), v_min=float(cmp.v.min()))
    return ValidationReport("cavity", level, validate_cavity.__doc__.split("\n")[0], tuple(comparisons),
                            time.perf_counter() - t0, details)
