"""NASA TMR 2D NACA 0012 validation case (turbmodels.larc.nasa.gov, "2D NACA 0012 Airfoil Validation").

TMR airfoil with a closed (sharp) trailing edge, chord 1, on the structured C-mesh of
:mod:`solver.validation.meshes.naca_mesh` (far field >= 100 chords); Re = 6e6: rho = 1, U = 1, mu = 1/6e6; k-omega SST
(:class:`solver.turbulence.SST`, ``low_re`` wall treatment; first cell 2e-6 / 1e-6 / 1e-6 chords, wall y+
of the first centroid <= 0.72). The mesh is fixed and the freestream ``U∞ = (cos α, sin α)`` is rotated;
the force on the airfoil (body axes) is projected on the drag (along U∞) and lift (normal) directions::

    C_D = F·(cos α, sin α) / (½ rho U² c),  C_L = F·(−sin α, cos α) / (½ rho U² c),  C_p = p / (½ rho U²)

(p∞ = 0 at the outflow). Far field: ``farfield_in`` (U∞·n < 0) velocity inlet, U∞ plus the point vortex
of the current C_L (:func:`vortex_velocity`, updated every 100 iterations; TMR's runs have the point-vortex
correction too), with the TMR freestream turbulence (k = 9e-9 a², omega = 1e-6 rho a²/mu at M = 0.15, read
from the CFL3D file header: intensity 5.16e-4, nu_t/nu = 0.009); ``farfield_out`` pressure outlet p = 0.
Start: potential flow (:func:`potential_start`); SIMPLE, alpha_u 0.7, alpha_p 0.3 (:func:`naca_settings`).
``near_stall=True`` runs the case with the near-stall settings (:data:`NEAR_STALL_SETTINGS`,
:data:`NEAR_STALL_SST`), not the default: the weak Venkatakrishnan-Wang limiter (k = 20) throughout, the
Green-Gauss pressure gradient (in the momentum source and Rhie-Chow alike), OpenFOAM's limited omega production
and the two-point wall omega flux. Against OpenFOAM's ``kOmegaSST`` on the same C-meshes they
put C_L,max at OpenFOAM's angle (coarse 16 deg, medium 17 deg) with OpenFOAM's coarse-to-medium trend, and the
lift within 1 % from 13 to 17 deg (coarse) and at 12 and 14-17 deg (medium), but +1.1 to +1.2 % at 10-12 deg
(coarse); against CFL3D at 10 deg: coarse C_L -1.30 %, C_D -6.1 % (2 700 iterations), fine -0.96 % / -1.83 %
(docs/explanation/naca0012.md). The default keeps the
case's TMR figures and loses lift near stall on the coarse mesh (-7 % at 16 deg).

Compared with CFL3D SST on the 897x257 grid (``solver/validation/reference/tmr_naca0012_cfl3d_sst_*.csv``, copied
from the TMR files): C_L, C_D at α = 0° and 10° (agreed tolerances: α = 0: |C_L| <= 0.005, C_D within 8 %;
α = 10: C_L within 2 %, C_D within 8 %), and the RMS difference of C_p along the chord.

    millfoil validate naca0012 --alpha 10 --level medium     # prints the comparison

Laminar harness checks, other Reynolds numbers, iteration caps, progress, restart files and wall-time
limits through the API::

    run_naca0012(0.0, "coarse", turbulent=False, reynolds=2000, convergence=Convergence(max_iter=3000),
                 progress=print, state_file="a0.npz", max_seconds=3600)
"""

from __future__ import annotations

import dataclasses
import os
import re
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import Fluid, Problem, SimpleSettings, solve_steady
from ..linalg import SolverSettings
from ..turbulence import SST
from ..warmstart import potential_start
from .meshes.naca_mesh import naca0012_cmesh, quality
from .report import Comparison, ValidationReport

REFERENCE_DIR = Path(__file__).resolve().parent / "reference"
CLCD_FILE = "tmr_naca0012_cfl3d_sst_clcd_fulldigits.csv"
CP_FILE = "tmr_naca0012_cfl3d_sst_cp.csv"
#: Reynolds number per chord and the Mach number of the TMR runs (for the freestream turbulence).
REYNOLDS = 6e6
MACH = 0.15
#: Angles of attack with reference data, deg.
ALPHAS = (0.0, 10.0)
#: Acceptance tolerances per angle: C_L absolute at 0° and relative at 10°, C_D relative.
TOLERANCE = {0.0: {"C_L_abs": 0.005, "C_D_rel": 0.08}, 10.0: {"C_L_rel": 0.02, "C_D_rel": 0.08}}
#: The acceptance asks only to report the RMS of C_p(computed) - C_p(CFL3D) over the reference points; this
#: project tolerance (about 2 % of the α = 10° suction peak |C_p| ~ 5.5) flags gross errors. Measured
#: (SST, converged, docs/explanation/naca0012.md runs B): α = 0: 0.011 / 0.003 / 0.003 (coarse / medium / fine);
#: α = 10: 0.077 / 0.041 / 0.031.
#: Part of it is compressibility: the CFL3D runs are at M = 0.15 (Prandtl-Glauert factor 1.011).
CP_RMS_TOLERANCE = 0.1


# -------------------------------------------------------------------------------------------- reference
def _rows(name: str, reference_dir: Path = REFERENCE_DIR) -> list[list[str]]:
    """Data rows of a reference CSV (``#`` header lines and the column-name line skipped), split on commas."""
    lines = [ln for ln in (reference_dir / name).read_text().splitlines() if ln and not ln.startswith("#")]
    return [ln.split(",") for ln in lines[1:]]


def load_clcd(reference_dir: Path = REFERENCE_DIR) -> dict[float, tuple[float, float]]:
    """CFL3D SST ``{alpha_deg: (C_L, C_D)}`` (897x257 grid, point-vortex far field)."""
    return {float(a): (float(cl), float(cd)) for a, cl, cd in _rows(CLCD_FILE, reference_dir)}


def load_cp(alpha_deg: float, reference_dir: Path = REFERENCE_DIR) -> dict[str, np.ndarray]:
    """CFL3D SST C_p at ``alpha_deg``: ``{"lower": (n, 2), "upper": (n, 2)}`` rows ``(x, C_p)``. The file lists
    one zone per angle from the trailing edge along the lower surface to the leading edge and back along
    the upper surface (checked: at 10° the second half has the suction peak)."""
    zone = f"alpha={alpha_deg:g}"
    a = np.array([[float(r[1]), float(r[2])] for r in _rows(CP_FILE, reference_dir) if r[0] == zone])
    if a.size == 0:
        raise ValueError(f"no C_p reference for alpha = {alpha_deg:g}; available {ALPHAS}")
    k = int(np.argmin(a[:, 0]))
    return {"lower": a[:k + 1][::-1], "upper": a[k:]}


def tmr_freestream(reference_dir: Path = REFERENCE_DIR, mach: float = MACH) -> dict[str, float]:
    """Inlet turbulence of the TMR runs from the CFL3D file header (``k/a² = 9e-9``,
    ``omega mu/(rho a²) = 1e-6``): ``intensity = sqrt(k / 1.5) / U`` with ``U = M a`` and
    ``viscosity_ratio = nu_t/nu = (k/a²) / (omega mu/(rho a²))``."""
    head = "\n".join(ln for ln in (reference_dir / CLCD_FILE).read_text().splitlines() if ln.startswith("#"))
    k = float(re.search(r"k/a_inf\^2\s*=\s*([0-9.eE+-]+)", head).group(1))
    w = float(re.search(r"omega\*mu_inf/\(rho_inf\*a_inf\^2\)\s*=\s*([0-9.eE+-]+)", head).group(1))
    return {"intensity": float(np.sqrt(k / 1.5) / mach), "viscosity_ratio": k / w}


# ------------------------------------------------------------------------------------------------ setup
def freestream(alpha_deg: float) -> np.ndarray:
    """Unit freestream velocity at angle of attack ``alpha_deg``."""
    a = np.radians(alpha_deg)
    return np.array([np.cos(a), np.sin(a)])


def vortex_velocity(xy: np.ndarray, alpha_deg: float, c_l: float, centre=(0.25, 0.0)) -> np.ndarray:
    """Freestream plus the point vortex of the airfoil's circulation ``Γ = ½ U c C_L`` (clockwise for
    positive lift) at the quarter chord: ``u = U∞ + Γ/(2π r²) (r_y, −r_x)``, m/s, at points ``xy (k, 2)``."""
    r = np.asarray(xy, float) - np.asarray(centre, float)
    gamma = 0.5 * c_l
    r2 = (r**2).sum(axis=1)
    return freestream(alpha_deg)[None, :] + (gamma / (2.0 * np.pi * r2))[:, None] * np.column_stack([r[:, 1], -r[:, 0]])


def boundary_conditions(alpha_deg: float, turbulent: bool = True, c_l: float | None = None) -> dict:
    """Far field: velocity inlet (freestream at α; TMR turbulence when ``turbulent``; plus the point-vortex
    velocity of ``c_l`` when given) on ``farfield_in``, pressure outlet p = 0 on ``farfield_out``; no-slip
    ``wall``."""
    inlet = {"type": "velocity_inlet", "velocity": tuple(freestream(alpha_deg))}
    if c_l is not None and c_l != 0.0:
        inlet["profile"] = lambda xy: vortex_velocity(xy, alpha_deg, c_l)
    if turbulent:
        inlet.update(tmr_freestream())
    return {"wall": "wall", "farfield_in": inlet, "farfield_out": {"type": "pressure_outlet", "p": 0.0}}


#: Iterations of a run (counted from the potential start, restarts included) in which the momentum
#: linear-upwind gradient is limited in the limited-start near-stall variant (``naca_settings(near_stall=True,
#: limiter="venkatakrishnan", limiter_k=5, limiter_iterations=LIMITER_ITERATIONS)``); after them it is
#: unlimited, OpenFOAM's ``linearUpwind``. Unlimited from the start, the potential flow's slip velocity at the
#: no-slip wall diverges within 4 iterations (docs/decisions/0007-limiter-iterations.md).
LIMITER_ITERATIONS = 500

#: The near-stall solver settings: the Venkatakrishnan-Wang limiter with k = 20 throughout (it spares
#: the young leading-edge boundary layer that K = 5 Venkatakrishnan clips; k = 40 left coarse 10 deg's C_D at
#: -9.9 % of CFL3D, outside its 8 %) and the Green-Gauss pressure gradient (OpenFOAM's ``Gauss linear``),
#: which Rhie-Chow uses too (docs/explanation/naca0012.md).
NEAR_STALL_SETTINGS = {"limiter": "venkatakrishnan_wang", "limiter_k": 20.0, "pressure_gradient": "green_gauss"}
#: The near-stall SST options: OpenFOAM's (and Menter 2003's) limited omega production and the two-point omega
#: flux next to the wall cells.
NEAR_STALL_SST = {"omega_production": "limited", "omega_wall_flux": "two_point"}


def naca_turbulence(near_stall: bool = False) -> SST:
    """The case's k-omega SST: SST-2003 with the ``low_re`` wall treatment and OpenFOAM's limited omega
    production (``omega_production="limited"``, the blades' default too,
    docs/decisions/0004-limited-omega-production.md: against OpenFOAM on the same coarse C-mesh the lift at
    16 deg -0.61 % instead of -1.54 %, at 10-15 deg +0.76 ... -0.16 %; the TMR references stay met on every
    level, docs/explanation/validation.md); ``near_stall``: with :data:`NEAR_STALL_SST` (used with
    :data:`NEAR_STALL_SETTINGS`, see the module docstring)."""
    return SST(wall_treatment="low_re", **{"omega_production": "limited", **(NEAR_STALL_SST if near_stall else {})})


def naca_settings(near_stall: bool = False, **overrides) -> SimpleSettings:
    """Settings of one chunk of outer iterations (:func:`run_naca0012` checks convergence between chunks:
    the solver's own stop test is disabled with ``tol = -1``; ``max_iter`` is the chunk length).

    SIMPLE with ``alpha_p = 0.3`` and a pressure-correction solve to 1e-3: with SIMPLEC (``alpha_p = 1``)
    and the default pressure tolerance 0.05 the coarse SST run diverges within 10 iterations. The
    SIMPLEC coefficient ``V / (a_P/alpha_u - sum a_nb)`` of :mod:`solver.simple` turns negative where a
    cell's remaining mass imbalance (net inflow) exceeds ``(1/alpha_u - 1) a_P`` (measured: near the
    leading edge, and in the far-wake cells near the outflow plane); SIMPLE's ``V / a_P`` stays positive.
    The blades' pressure gradient, ``green_gauss_bounded`` (docs/decisions/0001-blade-pressure-gradient.md;
    the solver's default is least squares): against OpenFOAM on the same C-mesh the coarse lift at 16 deg
    -1.6 % instead of -5.4 %, and the TMR references met on every level (docs/explanation/naca0012.md,
    docs/explanation/validation.md). And their face velocity, ``bounded``
    (docs/decisions/0002-bounded-face-velocity.md): the trailing-edge corner keeps OpenFOAM's trailing-edge
    loading, and the coarse lift at 2-8 deg comes within 1 % of OpenFOAM's (+1.1 ... +1.75 % with the
    unbounded face velocity).

    ``near_stall``: with :data:`NEAR_STALL_SETTINGS`. A ``limiter_iterations`` override counts the iterations
    of the whole run (:data:`LIMITER_ITERATIONS`): :func:`run_naca0012` turns it into each chunk's own count.
    """
    base = dict(algorithm="simple", alpha_u=0.7, alpha_p=0.3, pressure_gradient="green_gauss_bounded",
                face_velocity="bounded",
                stall_tol=None, max_iter=100, tol=-1.0,
                monitor_groups=(),
                momentum_solver=SolverSettings("gauss_seidel", 0.1, 8),
                pressure_solver=SolverSettings("amg", 1e-3, 200))
    base.update(NEAR_STALL_SETTINGS if near_stall else {})
    base.update(overrides)
    return SimpleSettings(**base)


#: Impulsive start: at alpha = 0 the free stream runs exactly along the far-wake cells of the C-mesh
#: (aspect ratio up to 2e7), and from the potential start with ``alpha_u`` = 0.7 the velocity there blew up
#: within 11 iterations (coarse level; alpha = 10 deg, whose stream crosses those cells, converged). The
#: first :data:`STARTUP_ITERATIONS` run with this ``alpha_u``; a whole run at 0.5 converges but
#: about twice as slowly.
STARTUP_ALPHA_U = 0.5
STARTUP_ITERATIONS = 200


@dataclass(frozen=True)
class Convergence:
    """Stop test of :func:`run_naca0012`, checked after every chunk of ``chunk`` iterations: all scaled
    residuals below ``tol`` and, over the last ``window`` chunks, C_L varying by less than
    :meth:`cl_tolerance` and C_D by less than ``cd_rel`` (relative); at most ``max_iter``.

    ``cl_tol`` is absolute (C_L is ~0 at α = 0). ``cl_rel`` (None: off) makes it relative instead,
    ``cl_rel * max(|C_L|, CL_SCALE_MIN)``: at low incidence the lift settles by a slow monotone drift (on the
    coarse C-mesh at 2° C_L falls by about 10⁻⁴ per 500 iterations when the absolute test stops it, and by
    another 0.2–0.3 % before it settles), so a window change of 5·10⁻⁴ leaves it 0.15–0.55 % high at 2°–4°
    (docs/decisions/0008-naca0012-stop-test.md). The side-by-side harness uses ``cl_rel``."""

    chunk: int = 100
    max_iter: int = 6000
    tol: float = 1e-5
    cl_tol: float = 5e-4
    cd_rel: float = 2e-3
    window: int = 5
    cl_rel: float | None = None

    def __post_init__(self):
        if self.cl_rel is not None and not self.cl_rel > 0:
            raise ValueError(f"Convergence.cl_rel must be > 0 or None (the absolute cl_tol), got {self.cl_rel!r}")

    def cl_tolerance(self, c_l: float) -> float:
        """The allowed C_L change over the window at lift ``c_l``."""
        return self.cl_tol if self.cl_rel is None else self.cl_rel * max(abs(c_l), CL_SCALE_MIN)


#: The lift below which :attr:`Convergence.cl_rel` is taken relative to this value instead (α ≈ 0).
CL_SCALE_MIN = 0.1


@dataclass
class NacaResult:
    """Coefficients of one run: lift and drag (total, pressure and viscous parts), C_p on each surface
    (``x``, ``cp`` sorted by x at the wall-face centres), mesh and run data; ``results`` is the
    :class:`solver.results.FlowResults` (not serialised)."""

    alpha_deg: float
    level: str
    reynolds: float
    turbulent: bool
    c_l: float
    c_d: float
    c_l_pressure: float
    c_l_viscous: float
    c_d_pressure: float
    c_d_viscous: float
    x_upper: np.ndarray
    cp_upper: np.ndarray
    x_lower: np.ndarray
    cp_lower: np.ndarray
    cells: int
    iterations: int
    status: str
    solve_seconds: float
    y_plus_max: float | None = None
    results: object = field(default=None, repr=False)
    history: dict = field(default_factory=dict, repr=False)

    def summary(self) -> dict:
        """JSON-able scalars."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__
                if k not in ("results", "history") and not isinstance(getattr(self, k), np.ndarray)}


def coefficients(res, alpha_deg: float, level: str = "", reynolds: float = REYNOLDS,
                 turbulent: bool = True) -> NacaResult:
    """Lift, drag and C_p of a solution (rho = U = c = 1)."""
    q = 0.5 * res.rho
    f = res.forces("wall")
    e_d = freestream(alpha_deg)
    e_l = np.array([-e_d[1], e_d[0]])
    m = res.mesh
    j = m.boundary_local("wall")
    xc = m.face_centre[m.boundary["wall"]]
    cp = res.boundary_pressure()[j] / q
    up = xc[:, 1] > 0
    ou, ol = np.argsort(xc[up, 0]), np.argsort(xc[~up, 0])
    y_plus = None
    if hasattr(res, "y_plus"):
        y_plus = float(np.max(res.y_plus("wall")))
    return NacaResult(
        float(alpha_deg), level, float(reynolds), bool(turbulent),
        float(f.total @ e_l / q), float(f.total @ e_d / q), float(f.pressure @ e_l / q),
        float(f.viscous @ e_l / q), float(f.pressure @ e_d / q), float(f.viscous @ e_d / q),
        xc[up, 0][ou], cp[up][ou], xc[~up, 0][ol], cp[~up][ol], m.n_cells, res.iterations, res.status,
        round(res.wall_time, 2), y_plus, res)


def run_naca0012(alpha_deg: float = 0.0, level: str = "coarse", *, reynolds: float = REYNOLDS,
                 turbulent: bool = True, turbulence=None, settings: SimpleSettings | None = None,
                 convergence: Convergence = Convergence(), mesh_spec=None, callback=None,
                 progress=None, state_file=None, max_seconds: float | None = None,
                 vortex_correction: bool = True, startup: int = STARTUP_ITERATIONS,
                 near_stall: bool = False) -> NacaResult:
    """Solve the NACA 0012 at ``alpha_deg`` on the C-mesh of ``level``
    (:data:`solver.validation.meshes.naca_mesh.LEVELS`) or ``mesh_spec``
    (a :class:`solver.validation.meshes.naca_mesh.CMeshSpec`).

    ``turbulent``: k-omega SST (``turbulence`` or :func:`naca_turbulence`) with the TMR freestream
    turbulence; ``False`` runs laminar (harness checks at low ``reynolds``). The SIMPLEC loop runs in chunks
    of ``convergence.chunk`` iterations (``settings``, :func:`naca_settings`) on one state until
    :class:`Convergence` holds; ``callback(iteration, residuals, state)`` as in
    :func:`solver.solve_steady` (chunk-local iteration numbers); ``progress(iterations, residuals,
    c_l, c_d)`` after each chunk. ``state_file`` (``.npz``): start from it when it exists, and write the
    state there after the run (restart of long runs); ``max_seconds``: stop after the chunk that passes
    this wall time (status ``not_converged``). ``vortex_correction``: after every chunk the inflow
    velocity is reset to U∞ plus the point vortex of the current C_L (:func:`vortex_velocity`; the outflow
    pressure stays 0), as in the TMR reference runs. ``startup``: from a fresh (potential) start, the
    first ``startup`` iterations run with ``alpha_u`` = :data:`STARTUP_ALPHA_U` (see there); not on restarts.
    ``near_stall``: the default SST and settings are the near-stall ones (:func:`naca_turbulence`,
    :func:`naca_settings`).
    """
    spec = mesh_spec if mesh_spec is not None else level
    cm = naca0012_cmesh(spec, alpha_deg=alpha_deg)
    fluid = Fluid(1.0, 1.0 / reynolds)
    model = None
    if turbulent:
        model = turbulence or naca_turbulence(near_stall)

    def make_problem(c_l=None):
        bcs = boundary_conditions(alpha_deg, turbulent, c_l if vortex_correction else None)
        if model is None:
            return Problem.create(cm.mesh, bcs, fluid)
        return Problem.create(cm.mesh, bcs, fluid, turbulence=model)

    problem = make_problem()
    cfg = settings or naca_settings(near_stall, max_iter=convergence.chunk)
    gentle = dataclasses.replace(cfg, alpha_u=min(cfg.alpha_u, STARTUP_ALPHA_U))
    state = potential_start(problem, freestream(alpha_deg))
    done, cls, cds = 0, [], []
    if state_file is not None and Path(state_file).exists():
        done, cls, cds = _load_state(state, state_file)
        if cls and vortex_correction:
            problem = make_problem(cls[-1])
    t0 = time.perf_counter()
    total, hist, w = 0, {}, convergence.window
    while True:
        chunk_cfg = gentle if done == 0 and total < startup else cfg
        res = solve_steady(problem, chunk_limiter(chunk_cfg, total + done), state, callback)
        total += res.iterations
        for k, v in res.residuals.items():
            hist.setdefault(k, []).extend(np.asarray(v).tolist())
        if res.status == "diverged":
            status = "diverged"
            break
        r = coefficients(res, alpha_deg, turbulent=turbulent)
        cls.append(r.c_l)
        cds.append(r.c_d)
        last = {k: v[-1] for k, v in res.residuals.items() if len(v)}
        if progress is not None:
            progress(total, last, r.c_l, r.c_d)
        if len(cls) > w and limiter_off_since(cfg, total + done) >= (w + 1) * convergence.chunk \
                and max(last.values()) < convergence.tol \
                and np.ptp(cls[-w - 1:]) < convergence.cl_tolerance(cls[-1]) \
                and np.ptp(cds[-w - 1:]) < convergence.cd_rel * abs(cds[-1]):
            status = "converged"
            break
        if total + done >= convergence.max_iter or (max_seconds and time.perf_counter() - t0 > max_seconds):
            status = "not_converged"
            break
        if vortex_correction and abs(r.c_l) > 1e-3:
            problem = make_problem(r.c_l)
    if state_file is not None and status != "diverged":
        _save_state(state, state_file, total + done, cls, cds)
    run_iterations = total
    total += done
    res.status = status
    res.iterations = total
    res.wall_time = time.perf_counter() - t0
    res.residuals = {k: np.array(v) for k, v in hist.items()}
    res.message = (f"{status} after {total} iterations: last residuals "
                   f"{ {k: float(f'{v[-1]:.2e}') for k, v in hist.items() if v} }; C_L {cls[-w - 1:] if cls else []} "
                   f"C_D {cds[-w - 1:] if cds else []} over the last chunks")
    out = coefficients(res, alpha_deg, level if mesh_spec is None else "custom", reynolds, turbulent)
    out.history = {"c_l": cls, "c_d": cds, "chunk": convergence.chunk, "iterations_this_run": run_iterations}
    return out


def chunk_limiter(cfg: SimpleSettings, iterations_done: int) -> SimpleSettings:
    """``cfg`` for a chunk that starts after ``iterations_done`` iterations of the run: its
    ``limiter_iterations`` (counted over the run) turned into the chunk's own count (0: unlimited
    throughout the chunk); unchanged without a limited start-up."""
    if cfg.limiter_iterations is None:
        return cfg
    return dataclasses.replace(cfg, limiter_iterations=max(cfg.limiter_iterations - iterations_done, 0))


def limiter_off_since(cfg: SimpleSettings, iterations_done: int) -> int:
    """Iterations of the run since the limited start-up ended (all of them without one). The stop test
    of :func:`run_naca0012` waits until its whole C_L / C_D window lies after it: the start-up solution
    is not the answer."""
    return iterations_done - (cfg.limiter_iterations or 0)


_STATE_FIELDS = ("u", "p", "flux", "grad_p", "grad_u", "k", "omega", "nu_t", "mu_wall")


def _save_state(state, path, iterations: int, c_l=(), c_d=()) -> None:
    arrays = {k: getattr(state, k) for k in _STATE_FIELDS if getattr(state, k, None) is not None}
    np.savez(path, iterations=iterations, c_l_history=np.asarray(c_l, float), c_d_history=np.asarray(c_d, float),
             **arrays)


def _load_state(state, path) -> tuple[int, list, list]:
    """Fill ``state`` from a file of :func:`_save_state` (same mesh); returns its iteration count and the
    per-chunk C_L and C_D histories."""
    with np.load(path) as z:
        for k in _STATE_FIELDS:
            if k in z.files:
                if getattr(state, k, None) is not None and getattr(state, k).shape != z[k].shape:
                    raise ValueError(f"{path}: field {k} has shape {z[k].shape}, mesh needs {getattr(state, k).shape}")
                setattr(state, k, z[k].copy())
        return int(z["iterations"]), z["c_l_history"].tolist(), z["c_d_history"].tolist()


def cp_rms(r: NacaResult, reference_dir: Path = REFERENCE_DIR) -> float:
    """RMS over the CFL3D points of both surfaces of ``C_p(computed) - C_p(CFL3D)``, the computed C_p
    interpolated linearly in x between wall-face centres (held constant beyond the first/last face)."""
    ref = load_cp(r.alpha_deg, reference_dir)
    d = np.concatenate([np.interp(ref["upper"][:, 0], r.x_upper, r.cp_upper) - ref["upper"][:, 1],
                        np.interp(ref["lower"][:, 0], r.x_lower, r.cp_lower) - ref["lower"][:, 1]])
    return float(np.sqrt(np.mean(d**2)))


def compare(r: NacaResult, reference_dir: Path = REFERENCE_DIR) -> list:
    """:class:`solver.validation.report.Comparison` records of one run against CFL3D SST."""
    a = float(r.alpha_deg)
    if a not in TOLERANCE:
        raise ValueError(f"no reference data for alpha = {a:g}; available {ALPHAS}")
    cl_ref, cd_ref = load_clcd(reference_dir)[a]
    tol = TOLERANCE[a]
    out = []
    if "C_L_abs" in tol:
        out.append(Comparison.of(f"alpha {a:g}: C_L (error: absolute)", r.c_l, cl_ref, abs(r.c_l - cl_ref),
                                 tol["C_L_abs"]))
    else:
        out.append(Comparison.of(f"alpha {a:g}: C_L (error: % of reference)", r.c_l, cl_ref,
                                 100 * abs(r.c_l / cl_ref - 1), 100 * tol["C_L_rel"]))
    out.append(Comparison.of(f"alpha {a:g}: C_D (error: % of reference)", r.c_d, cd_ref,
                             100 * abs(r.c_d / cd_ref - 1), 100 * tol["C_D_rel"]))
    rms = cp_rms(r, reference_dir)
    out.append(Comparison.of(f"alpha {a:g}: C_p RMS difference vs CFL3D (error: RMS of delta C_p)", rms, 0.0, rms,
                             CP_RMS_TOLERANCE))
    return out


def validate_naca0012(level: str, alpha: float | None = None, workers: int | None = None):
    """NASA TMR NACA 0012, Re = 6e6, k-omega SST: C_L, C_D and C_p vs CFL3D (897x257 grid) at
    alpha = 0 and 10 deg (or only ``alpha``).

    The angles are independent solves: with more than one angle they run in ``workers`` processes (default:
    one per angle, at most the cores this process may use), so the case takes the time of its longest
    angle (alpha = 0 at coarse) rather than the sum."""
    t0 = time.perf_counter()
    alphas = ALPHAS if alpha is None else (float(alpha),)
    for a in alphas:
        if a not in TOLERANCE:
            raise ValueError(f"no reference data for alpha = {a:g}; available {ALPHAS}")
    per_angle = map_in_processes(_validate_angle, [(a, level) for a in alphas], workers)
    comparisons = [c for cs, _ in per_angle for c in cs]
    details = {f"alpha{a:g}": d for a, (_, d) in zip(alphas, per_angle, strict=True)}
    details["mesh"] = {k: (round(v, 6) if isinstance(v, float) else v)
                       for k, v in quality(naca0012_cmesh(level)).items()}
    return ValidationReport("naca0012", level, validate_naca0012.__doc__.split("\n")[0], tuple(comparisons),
                            time.perf_counter() - t0, details)


def _validate_angle(alpha_deg: float, level: str) -> tuple[list, dict]:
    """``(comparisons, summary)`` of one angle of :func:`validate_naca0012` (small and picklable: the
    flow fields stay in the process that solved them)."""
    r = run_naca0012(alpha_deg, level)
    return compare(r), dict(r.summary(), cp_rms=cp_rms(r))


def map_in_processes(fn, args: list[tuple], workers: int | None = None) -> list:
    """``[fn(*a) for a in args]``, in ``workers`` processes (default: one per item, at most the cores this
    process may use; one worker: in this process). ``fn`` and its arguments and results must pickle."""
    workers = min(len(args), _usable_cores()) if workers is None else min(workers, len(args))
    if workers <= 1:
        return [fn(*a) for a in args]
    from concurrent.futures import ProcessPoolExecutor
    from multiprocessing import get_context

    # spawn, not fork: a forked child would inherit the parent's numba and BLAS thread state
    with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
        return list(pool.map(fn, *zip(*args, strict=True)))


def _usable_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:                  # not on Linux
        return os.cpu_count() or 1
