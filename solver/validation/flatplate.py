"""NASA TMR 2D zero-pressure-gradient flat plate (2DZP), SST, Re = 5e6 per unit length.

Geometry (https://turbmodels.larc.nasa.gov/flatplate.html): domain ``x in [-0.33, 2]``, ``y in [0, 1]``;
the plate (no-slip wall, group ``plate``) runs from x = 0 to 2 on y = 0 and is preceded by a symmetry plane
(group ``symmetry``, x < 0). Inlet (``inlet``, x = -0.33): u = (1, 0) with the TMR freestream turbulence
(k = 9e-9 a², nu_t/nu = 0.009 at M = 0.2: intensity 3.873e-4, viscosity ratio 0.009); outlet (``outlet``,
x = 2) and top (``top``, y = 1, the TMR farfield) at static pressure 0 (velocity zero-gradient, so the
displacement flow leaves through the top). Fluid rho = 1, U = 1, mu = 1/5e6 (Re = 5e6 per unit length).

Mesh (:func:`flatplate_mesh`): structured quads, numpy only; geometric stretching from the leading edge
in x (both sides) and from the wall in y, the first wall spacing chosen for a first-cell-centroid y+ < 1.

Compared with the TMR SST results (CFL3D / FUN3D, SST-V, finest 545x385 grid; ``solver/validation/
reference/tmr_2dzp_sst_*.csv``): skin friction ``c_f = tau_w / (0.5 rho U²)`` at x = 0.97 (0.00269) and the plate
drag coefficient ``C_D = D / (0.5 rho U² L)`` with L = 2 (0.00285), per the TMR page.

    millfoil validate flatplate --level medium          # prints the comparison

Wall treatment, first spacing and progress through the API:
``run_flatplate("coarse", "automatic", mesh_overrides={"dy_wall": 1e-4}, callback=...)``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import Fluid, Problem, SimpleSettings, initial_state, solve_steady
from ..fvmesh import FVMesh, build_fvmesh
from ..linalg import SolverSettings
from ..turbulence import SST, TMR_FREESTREAM
from .report import Comparison, ValidationReport, run_summary

REFERENCE_DIR = Path(__file__).resolve().parent / "reference"
RE_PER_LENGTH = 5e6
FLUID = Fluid(rho=1.0, mu=1.0 / RE_PER_LENGTH)
X_UPSTREAM, X_END, HEIGHT = -0.33, 2.0, 1.0
#: TMR station and reference values (finest grid 545x385, CFL3D SST-V; FUN3D agrees to 0.01 % / 0.3 %).
X_CF = 0.97
REFERENCE = {"cf_x0.97": 0.00269, "C_D": 0.00285}
#: Acceptance tolerances (relative): c_f 2 %, C_D 3 %.
TOLERANCE = {"cf_x0.97": 0.02, "C_D": 0.03}

#: Mesh per level: cells upstream (symmetry) / along the plate / normal to the wall, first spacings at the
#: leading edge (x) and at the wall (y), m. dy_wall keeps the first-cell centroid at y+ < 1 along the
#: whole plate (peak c_f ~ 0.0055 just after transition: u_tau ~ 0.052, y+ = 1.3e5 dy_wall).
LEVELS = {
    "coarse": dict(nx_up=12, nx_plate=48, ny=64, dx_le=1e-3, dy_wall=5e-6),
    "medium": dict(nx_up=24, nx_plate=96, ny=96, dx_le=4e-4, dy_wall=2.5e-6),
    "fine": dict(nx_up=32, nx_plate=192, ny=128, dx_le=2e-4, dy_wall=1.5e-6),
}


def geometric(length: float, n: int, first: float) -> np.ndarray:
    """``n + 1`` points from 0 to ``length`` (m) with first spacing ``first`` growing geometrically.

    The growth ratio r solves ``first (r^n - 1)/(r - 1) = length`` (bisection; r < 1 if
    ``first n > length``). Example: ``geometric(1.0, 4, 0.1)`` has spacings 0.1 r^i summing to 1.
    """
    lo, hi = 0.2, 5.0
    for _ in range(200):
        r = 0.5 * (lo + hi)
        s = first * n if abs(r - 1.0) < 1e-12 else first * (r**n - 1.0) / (r - 1.0)
        lo, hi = (r, hi) if s < length else (lo, r)
    h = first * r ** np.arange(n)
    x = np.concatenate([[0.0], np.cumsum(h)])
    return x * (length / x[-1])


def flatplate_mesh(nx_up: int = 12, nx_plate: int = 48, ny: int = 64, dx_le: float = 1e-3,
                   dy_wall: float = 5e-6) -> FVMesh:
    """Structured quad mesh of the TMR 2DZP domain ``[-0.33, 2] x [0, 1]`` (m).

    x: ``nx_up`` cells on [-0.33, 0] and ``nx_plate`` on [0, 2], both growing geometrically away from the
    leading edge x = 0 with first spacing ``dx_le``; y: ``ny`` cells growing from ``dy_wall`` at the wall.
    Groups: ``inlet`` (x = -0.33), ``outlet`` (x = 2), ``top`` (y = 1), ``symmetry`` (y = 0, x < 0),
    ``plate`` (y = 0, 0 < x < 2). Cells are numbered with the wall-normal index fastest (Gauss–Seidel
    sweeps then follow the strong wall-normal coupling).
    """
    xu = -geometric(-X_UPSTREAM, nx_up, dx_le)[::-1]
    xp = geometric(X_END, nx_plate, dx_le)
    x = np.concatenate([xu[:-1], xp])
    y = geometric(HEIGHT, ny, dy_wall)
    nx = x.size - 1
    X, Y = np.meshgrid(x, y, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel()])
    nid = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    i, j = i.ravel(), j.ravel()
    quads = np.column_stack([nid[i, j], nid[i + 1, j], nid[i + 1, j + 1], nid[i, j + 1]])
    b = np.arange(nx)
    c = np.arange(ny)
    up = b < nx_up
    boundary = {
        "inlet": np.column_stack([nid[0, c + 1], nid[0, c]]),
        "outlet": np.column_stack([nid[nx, c], nid[nx, c + 1]]),
        "top": np.column_stack([nid[b + 1, ny], nid[b, ny]]),
        "symmetry": np.column_stack([nid[b[up], 0], nid[b[up] + 1, 0]]),
        "plate": np.column_stack([nid[b[~up], 0], nid[b[~up] + 1, 0]]),
    }
    return build_fvmesh(pts, {"quad": quads}, boundary)


def boundary_conditions(intensity: float = TMR_FREESTREAM["intensity"],
                        viscosity_ratio: float = TMR_FREESTREAM["viscosity_ratio"]) -> dict:
    """TMR 2DZP boundary conditions (freestream turbulence per TMR by default)."""
    return {"inlet": {"type": "velocity_inlet", "velocity": (1.0, 0.0), "intensity": intensity,
                      "viscosity_ratio": viscosity_ratio},
            "outlet": {"type": "pressure_outlet", "p": 0.0}, "top": {"type": "pressure_outlet", "p": 0.0},
            "symmetry": "symmetry", "plate": "wall"}


def flatplate_settings(**overrides) -> SimpleSettings:
    """Solver settings for the flat plate (SIMPLEC, ``alpha_p`` = 1; plate drag monitored for convergence)."""
    base = dict(algorithm="simplec", startup_iterations=0, alpha_p=1.0, stall_tol=None,
                alpha_u=0.85, max_iter=4000, tol=1e-5, monitor_tol=1e-4, monitor_window=50,
                monitor_groups=("plate",), momentum_solver=SolverSettings("gauss_seidel", 0.1, 8),
                pressure_solver=SolverSettings("direct"))
    base.update(overrides)
    return SimpleSettings(**base)


@dataclass(frozen=True)
class FlatPlateCoefficients:
    """c_f at x = 0.97 (linear interpolation between face centres), plate C_D (L = 2), the face
    centres x ``(n,)``, c_f ``(n,)`` and first-cell y+ ``(n,)`` along the plate."""

    cf_097: float
    cd: float
    x: np.ndarray
    cf: np.ndarray
    y_plus: np.ndarray

    def errors(self) -> dict:
        """Relative errors against :data:`REFERENCE`."""
        return {"cf_x0.97": abs(self.cf_097 / REFERENCE["cf_x0.97"] - 1.0),
                "C_D": abs(self.cd / REFERENCE["C_D"] - 1.0)}


def coefficients(res) -> FlatPlateCoefficients:
    """Skin friction and drag of the plate from a :class:`solver.results.FlowResults` (rho = U = 1)."""
    q = 0.5 * res.rho * 1.0**2
    xc = res.wall_faces("plate")[:, 0]
    tau = res.wall_shear("plate")[:, 0]
    order = np.argsort(xc)
    cf = tau[order] / q
    drag = res.forces("plate").fx
    return FlatPlateCoefficients(float(np.interp(X_CF, xc[order], cf)), drag / (q * X_END), xc[order], cf,
                                 res.y_plus("plate")[order])


def load_reference_cf(reference_dir: Path = REFERENCE_DIR) -> tuple[np.ndarray, np.ndarray]:
    """TMR c_f(x) on the plate (CFL3D, finest grid): ``(x, cf)``, x > 0 only."""
    rows = [ln.split(",") for ln in (reference_dir / "tmr_2dzp_sst_cf_plate_finest_545x385.csv").read_text()
            .splitlines() if ln and not ln.startswith("#") and ln.startswith("CFL3D")]
    a = np.array([[float(r[1]), float(r[2])] for r in rows])
    a = a[a[:, 0] > 0]
    return a[:, 0], a[:, 1]


def run_flatplate(level: str = "coarse", wall_treatment: str = "low_re", turbulence: SST | None = None,
                  mesh_overrides: dict | None = None, settings: SimpleSettings | None = None, callback=None,
                  laminar: bool = False):
    """Solve the TMR flat plate at ``level`` (:data:`LEVELS`); returns ``(FlowResults, FlatPlateCoefficients)``.

    ``turbulence`` overrides the model (default ``SST(wall_treatment)``); ``laminar=True`` runs without a
    turbulence model (to show that the comparison catches it).
    """
    mesh = flatplate_mesh(**{**LEVELS[level], **(mesh_overrides or {})})
    model = None if laminar else (turbulence or SST(wall_treatment=wall_treatment))
    problem = Problem.create(mesh, boundary_conditions(), FLUID, turbulence=model)
    state = initial_state(problem, (1.0, 0.0))
    res = solve_steady(problem, settings or flatplate_settings(), state, callback)
    return res, coefficients(res)


# ---------------------------------------------------------------------------------------- validation
#: Flat-plate tolerances per level, % of the TMR value (c_f at x = 0.97, plate C_D). coarse (3 840 cells,
#: y+ < 0.6): measured 2.1 % / 2.2 % low with SST (CFL3D on its 3 264-cell grid: 2.4 % / 2.3 % low); without
#: a turbulence model (laminar) 89 % / 85 % low, and with F1 = 0 (k-epsilon branch everywhere) 22 % / 23 %
#: high, so 5 % catches both. With F1 = 1 everywhere (the k-omega branch) c_f is 0.9 % high: on this case
#: (zero pressure gradient, TMR freestream) the coarse level cannot separate it (the f1 unit tests do).
#: medium (11 520 cells, measured 0.8 % / 0.9 %) and fine (28 672 cells, 0.2 % / 0.3 %): the acceptance's 2 % (c_f)
#: and 3 % (C_D).
FLATPLATE_TOLERANCES = {"coarse": {"cf": 5.0, "C_D": 5.0}, "medium": {"cf": 2.0, "C_D": 3.0},
                        "fine": {"cf": 2.0, "C_D": 3.0}}


def validate_flatplate(level: str) -> ValidationReport:
    """NASA TMR zero-pressure-gradient flat plate (SST, Re = 5e6/m): c_f(0.97) and plate C_D vs TMR.

    SST-2003 with the ``low_re`` wall treatment (y+ < 1); reference: TMR SST results (CFL3D, finest grid).
    """
    t0 = time.perf_counter()
    res, c = run_flatplate(level)
    tol = FLATPLATE_TOLERANCES[level]
    ref, err = REFERENCE, c.errors()
    comparisons = (
        Comparison.of("c_f at x = 0.97 (error: % of reference)", c.cf_097, ref["cf_x0.97"],
                      100 * err["cf_x0.97"], tol["cf"]),
        Comparison.of("plate C_D, L = 2 (error: % of reference)", c.cd, ref["C_D"], 100 * err["C_D"],
                      tol["C_D"]),
    )
    details = dict(run_summary(res), mesh=dict(LEVELS[level]), wall_treatment="low_re",
                   y_plus_max=float(c.y_plus[c.x > 0.05].max()),
                   ms_per_iteration=round(1e3 * res.wall_time / max(res.iterations, 1), 2))
    return ValidationReport("flatplate", level, validate_flatplate.__doc__.split("\n")[0], comparisons,
                            time.perf_counter() - t0, details)
