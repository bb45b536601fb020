"""The NACA 0012 side-by-side harness: millfoil and OpenFOAM simpleFoam + kOmegaSST on the same C-mesh.

The case files, runners, records, report and criteria of ``bench/bench_naca_openfoam.py`` and the total-pressure
and Richardson analysis of ``bench/naca_drag_study.py`` (the conditions: the script's docstring and
docs/explanation/validation.md, "Matching the conditions"). The OpenFOAM side needs Debian's ``openfoam`` package
(:mod:`solver.validation.openfoam`); everything else here runs without it.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import shutil
import time
from itertools import pairwise
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

from solver.turbulence import SSTConstants
from solver.validation.meshes.naca_mesh import CMesh, naca0012_cmesh
from solver.validation.naca0012 import REYNOLDS, freestream, load_clcd, tmr_freestream
from solver.validation.openfoam import (
    DEPTH,
    control_head,
    execution_times,
    field_body,
    latest_time,
    openfoam_state,
    read_dat,
    read_field,
    run_utility,
    write_file,
    write_polymesh,
)

#: Default angles of attack, deg: steps of 2 up to 12, then 1 through C_L,max (SST: about 16-18 deg).
ALPHAS = (0, 2, 4, 6, 8, 10, 12, 13, 14, 15, 16, 17, 18, 19, 20)
#: millfoil's stop test here: C_L may change by 1e-4 of itself over the 500-iteration window (the validation
#: case's absolute 5e-4 stops the low-incidence runs while C_L still drifts: 0.1-0.5 % high at 2-8 deg;
#: docs/decisions/0008-naca0012-stop-test.md).
CL_REL = 1e-4
LADSON_FILE = Path(__file__).resolve().parent / "reference" / "ladson_naca0012_clcd.csv"
PATCH_TYPES = {"wall": "wall", "farfield_in": "patch", "farfield_out": "patch"}
#: Iterations over which the lift spread is reported (stationary or not).
WINDOW = 200


# ------------------------------------------------------------------------------------------- conditions
def freestream_turbulence(reynolds: float = REYNOLDS) -> tuple[float, float, float]:
    """``(nu, k, omega)`` of the TMR freestream at U = 1, chord 1: ``k = 1.5 (I U)²``, ``omega = k / (nu r)``
    (millfoil's :func:`solver.turbulence.inlet_turbulence` of the inlet intensity I and ratio r)."""
    nu = 1.0 / reynolds
    t = tmr_freestream()
    k = 1.5 * t["intensity"] ** 2
    return nu, k, k / (nu * t["viscosity_ratio"])


def wall_tangent(mesh) -> np.ndarray:
    """Unit tangent ``(nw, 2)`` of each wall face pointing downstream (positive x component), so that
    ``c_f = tau_w · t / q`` is positive for attached flow from the leading to the trailing edge."""
    f = mesh.boundary["wall"]
    n = mesh.normal[f]
    t = np.column_stack([-n[:, 1], n[:, 0]])
    return t * np.where(t[:, 0] < 0, -1.0, 1.0)[:, None]


def separation_point(x: np.ndarray, y: np.ndarray, cf: np.ndarray) -> float | None:
    """x/c of the first face of the upper (suction) surface, from the leading edge, where c_f < 0; None
    when c_f stays positive."""
    up = np.where(y > 0)[0]
    up = up[np.argsort(x[up])]
    neg = up[cf[up] < 0]
    return float(x[neg[0]]) if len(neg) else None


def window_stats(cl_history: np.ndarray, every: int) -> dict:
    """Mean and spread (max - min) of C_L over the last :data:`WINDOW` iterations of a history sampled
    every ``every`` iterations."""
    w = cl_history[-(WINDOW // every + 1):]
    if not len(w):                                   # diverged in its first chunk
        return {"cl_mean_window": None, "cl_spread_window": None}
    return {"cl_mean_window": float(np.mean(w)), "cl_spread_window": float(np.ptp(w))}


def wall_record(mesh, cp: np.ndarray, tau: np.ndarray) -> dict:
    """Per wall face (group order): x, y, C_p and c_f = tau_w·t / (½ρU²) (ρ = U = 1)."""
    xc = mesh.face_centre[mesh.boundary["wall"]]
    cf = np.einsum("ij,ij->i", tau, wall_tangent(mesh)) / 0.5
    return {"x": xc[:, 0].tolist(), "y": xc[:, 1].tolist(), "cp": (cp / 0.5).tolist(), "cf": cf.tolist(),
            "x_sep": separation_point(xc[:, 0], xc[:, 1], cf)}


def wall_force_parts(mesh, wall: dict, alpha_deg: float) -> dict:
    """C_D and C_L split into pressure and viscous parts from a :func:`wall_record` (per face:
    ``C_p S_f`` and ``c_f |S_f| t``, S_f outward from the fluid); with OpenFOAM's wall-cell pressure these
    add up to its ``forceCoeffs`` C_D and C_L."""
    f = mesh.boundary["wall"]
    d = np.asarray(freestream(alpha_deg), dtype=float)
    e_l = np.array([-d[1], d[0]])
    cp, cf = np.asarray(wall["cp"]), np.asarray(wall["cf"])
    s, t = mesh.sf[f], wall_tangent(mesh) * mesh.length[f][:, None]
    return {"c_d_pressure": float(cp @ (s @ d)), "c_d_viscous": float(cf @ (t @ d)),
            "c_l_pressure": float(cp @ (s @ e_l)), "c_l_viscous": float(cf @ (t @ e_l))}


# ---------------------------------------------------------------------------------------------- OpenFOAM
def fv_schemes(u_gradient: str = "Gauss linear", gradient: str = "Gauss linear",
               interpolation: str = "linear") -> str:
    """Linear-upwind U on the gradient ``u_gradient`` (``--u-gradient``), first-order upwind k and omega
    (millfoil's SST default), ``interpolation`` (``--interpolation``: the ``interpolationSchemes`` default, i.e.
    the face values of ``HbyA`` and ``rAU`` that make the face flux; ``skewCorrected linear`` is the counterpart of
    millfoil's skewness-corrected face velocity), ``gradient`` (``--gradient``: the ``gradSchemes`` default, i.e.
    grad(U) of the
    stresses and production, grad(p), grad(k), grad(omega)) elsewhere, corrected Laplacians. OpenFOAM's
    ``leastSquares`` gradient (millfoil's kind) made every run on this mesh diverge within 30 iterations
    (from a uniform or the potential start), so the gradients are Green-Gauss (docs/explanation/validation.md)."""
    return """ddtSchemes { default steadyState; }
gradSchemes
{
    default DEFAULT;
    gradU GRADIENT;
}
divSchemes
{
    default none;
    div(phi,U) bounded Gauss linearUpwind gradU;
    div(phi,k) bounded Gauss upwind;
    div(phi,omega) bounded Gauss upwind;
    div((nuEff*dev2(T(grad(U))))) Gauss linear;
}
laplacianSchemes { default Gauss linear corrected; }
interpolationSchemes { default INTERPOLATION; }
snGradSchemes { default corrected; }
wallDist { method meshWave; correctWalls true; }
""".replace("GRADIENT", u_gradient).replace("DEFAULT", gradient).replace("INTERPOLATION", interpolation)


def fv_solution(alpha_u: float, alpha_turb: float, non_orthogonal: int = 0) -> str:
    """SIMPLEC (``consistent``), GAMG pressure; the residual controls stop a converged run.

    ``non_orthogonal``: pressure non-orthogonal correctors per iteration. They change the iteration path, not the
    converged solution; the fine C-mesh (non-orthogonality up to 53° where its lines turn, 0.1–0.3 c from the
    wall) needs 2: with 0 simpleFoam diverges there within ~150 iterations from every start
    (docs/explanation/validation.md)."""
    return f"""solvers
{{
    p {{ solver GAMG; smoother GaussSeidel; tolerance 1e-9; relTol 0.01; }}
    "(U|k|omega)" {{ solver smoothSolver; smoother GaussSeidel; nSweeps 2; tolerance 1e-12; relTol 0.05; }}
    Phi {{ solver PCG; preconditioner DIC; tolerance 1e-10; relTol 0; maxIter 5000; }}
}}
potentialFlow {{ nNonOrthogonalCorrectors 3; }}
SIMPLE
{{
    nNonOrthogonalCorrectors {non_orthogonal};
    consistent yes;
    residualControl {{ p 1e-7; U 1e-8; "(k|omega)" 1e-8; }}
}}
relaxationFactors {{ equations {{ U {alpha_u}; "(k|omega)" {alpha_turb}; }} }}
"""


def control_dict(alpha_deg: float, iterations: int) -> str:
    """simpleFoam for at most ``iterations``; force coefficients every iteration (ρ = U = c = 1, span
    :data:`DEPTH`), wall shear stress at the end."""
    d = freestream(alpha_deg)
    return control_head(iterations, "writePrecision 10;\n") + f"""functions
{{
    forceCoeffs
    {{
        type forceCoeffs;
        libs ("libforces.so");
        patches (wall);
        rho rhoInf;
        rhoInf 1;
        CofR (0.25 0 0);
        liftDir ({-d[1]:.15g} {d[0]:.15g} 0);
        dragDir ({d[0]:.15g} {d[1]:.15g} 0);
        pitchAxis (0 0 1);
        magUInf 1;
        lRef 1;
        Aref {DEPTH};
        writeControl timeStep;
        writeInterval 1;
    }}
    wallShearStress
    {{
        type wallShearStress;
        libs ("libfieldFunctionObjects.so");
        patches (wall);
        writeControl writeTime;
    }}
}}
"""


def write_controls(directory: Path, alpha_deg: float, iterations: int, alpha_u: float = 0.9, alpha_turb: float = 0.8,
                   u_gradient: str = "Gauss linear", gradient: str = "Gauss linear", interpolation: str = "linear",
                   non_orthogonal: int = 0, resume: bool = False) -> None:
    """``system/``: controlDict, fvSchemes, fvSolution. ``resume``: start from the case's latest written time and
    stop at iteration ``iterations`` counted from 0 (``--of-resume``)."""
    control = control_dict(alpha_deg, iterations)
    if resume:
        control = control.replace("startFrom startTime;", "startFrom latestTime;")
    write_file(directory, "system/controlDict", "dictionary", control)
    write_file(directory, "system/fvSchemes", "dictionary", fv_schemes(u_gradient, gradient, interpolation))
    write_file(directory, "system/fvSolution", "dictionary", fv_solution(alpha_u, alpha_turb, non_orthogonal))


def write_openfoam_case(directory: Path, mesh, alpha_deg: float, iterations: int, reynolds: float = REYNOLDS,
                        alpha_u: float = 0.9, alpha_turb: float = 0.8, u_gradient: str = "Gauss linear",
                        gradient: str = "Gauss linear", interpolation: str = "linear",
                        non_orthogonal: int = 0) -> None:
    """The whole simpleFoam case of the NACA 0012 at ``alpha_deg`` on ``mesh`` (conditions: module docstring)."""
    nu, k, omega = freestream_turbulence(reynolds)
    beta1 = SSTConstants().beta1
    d = freestream(alpha_deg)
    u = f"({d[0]:.15g} {d[1]:.15g} 0)"
    write_polymesh(mesh, directory, PATCH_TYPES)
    write_file(directory, "constant/transportProperties", "dictionary", f"transportModel Newtonian;\nnu {nu:.10g};\n")
    write_file(directory, "constant/turbulenceProperties", "dictionary",
               "simulationType RAS;\nRAS\n{\n    RASModel kOmegaSST;\n    turbulence on;\n    printCoeffs on;\n}\n")
    write_controls(directory, alpha_deg, iterations, alpha_u, alpha_turb, u_gradient, gradient, interpolation,
                   non_orthogonal)
    fields = {
        "U": ("volVectorField", "[0 1 -1 0 0 0 0]", u, {
            "farfield_in": f"type fixedValue; value uniform {u};", "farfield_out": "type zeroGradient;",
            "wall": "type noSlip;"}),
        "p": ("volScalarField", "[0 2 -2 0 0 0 0]", "0", {
            "farfield_in": "type zeroGradient;", "farfield_out": "type fixedValue; value uniform 0;",
            "wall": "type zeroGradient;"}),
        "k": ("volScalarField", "[0 2 -2 0 0 0 0]", f"{k:.10g}", {
            "farfield_in": f"type fixedValue; value uniform {k:.10g};", "farfield_out": "type zeroGradient;",
            "wall": "type fixedValue; value uniform 0;"}),
        "omega": ("volScalarField", "[0 0 -1 0 0 0 0]", f"{omega:.10g}", {
            "farfield_in": f"type fixedValue; value uniform {omega:.10g};", "farfield_out": "type zeroGradient;",
            "wall": f"type omegaWallFunction; beta1 {beta1}; blended false; value uniform {omega:.10g};"}),
        "nut": ("volScalarField", "[0 2 -1 0 0 0 0]", "0", {
            "farfield_in": "type calculated; value uniform 0;", "farfield_out": "type calculated; value uniform 0;",
            "wall": "type nutLowReWallFunction; value uniform 0;"}),
    }
    for name, (cls, dims, internal, patches) in fields.items():
        write_file(directory, f"0/{name}", cls, field_body(dims, internal, patches))


def check_mesh(directory: Path) -> dict:
    """Run ``checkMesh``; ``{"ok": bool, "summary": the failed-check lines or "Mesh OK."}``."""
    run_utility(directory, "checkMesh")
    text = (directory / "log.checkMesh").read_text()
    bad = [ln.strip() for ln in text.splitlines() if "***" in ln]
    return {"ok": "Mesh OK." in text, "summary": "; ".join(bad) or "Mesh OK."}


def run_openfoam(directory: Path, level: str, alpha_deg: float, iterations: int,
                 u_gradient: str = "Gauss linear", alpha_u: float = 0.9, gradient: str = "Gauss linear",
                 interpolation: str = "linear", non_orthogonal: int = 0, resume: bool = False) -> dict:
    """Write, check and run one OpenFOAM case; the record of :func:`openfoam_record`.

    ``resume`` (``--of-resume``): where ``directory`` holds a run with a written time, continue it from there up to
    ``iterations`` in all, with the settings given now (the earlier log is kept as ``log.simpleFoam.<time>``);
    otherwise start afresh."""
    cm = naca0012_cmesh(level, alpha_deg=alpha_deg)
    start = latest_time(directory) if resume and directory.is_dir() else None
    if start is None:
        shutil.rmtree(directory, ignore_errors=True)
        write_openfoam_case(directory, cm.mesh, alpha_deg, iterations, alpha_u=alpha_u, u_gradient=u_gradient,
                            gradient=gradient, interpolation=interpolation, non_orthogonal=non_orthogonal)
    else:
        write_controls(directory, alpha_deg, iterations, alpha_u=alpha_u, u_gradient=u_gradient, gradient=gradient,
                       interpolation=interpolation, non_orthogonal=non_orthogonal, resume=True)
        if (directory / "log.simpleFoam").exists():
            (directory / "log.simpleFoam").rename(directory / f"log.simpleFoam.{start.name}")
    mesh_check = check_mesh(directory)
    rc, wall = run_utility(directory, "simpleFoam")
    rec = openfoam_record(directory, cm.mesh)
    if "wall" in rec:
        rec.update(wall_force_parts(cm.mesh, rec["wall"], alpha_deg))
    rec.update(mesh_check=mesh_check["summary"], exit_status=rc, seconds=round(wall, 1), u_gradient=u_gradient,
               alpha_u=alpha_u, gradient=gradient, interpolation=interpolation, non_orthogonal=non_orthogonal,
               **({"resumed_from": int(float(start.name))} if start is not None else {}))
    return rec


def openfoam_record(directory: Path, mesh) -> dict:
    """Coefficients, C_max, wall C_p / c_f and convergence data of a finished simpleFoam case (over every
    stretch of a resumed run: its coefficient files joined, the CPU seconds of its logs added)."""
    log = (directory / "log.simpleFoam").read_text()
    last = latest_time(directory)
    coefficients = read_coefficients(directory)
    if coefficients is None or last is None:
        return {"error": f"no coefficients or no written time (see {directory / 'log.simpleFoam'})"}
    cl, cd = coefficients["Cl"], coefficients["Cd"]
    u, _ = read_field(last / "U", mesh.n_cells)
    p, _ = read_field(last / "p", mesh.n_cells)
    _, shear = read_field(last / "wallShearStress", mesh.n_cells)
    wall = mesh.boundary["wall"]
    # OpenFOAM's wallShearStress is the stress of the wall on the fluid (-n·R_eff): the fluid's on the wall is -it;
    # the wall pressure is the wall cell's (zeroGradient), as in OpenFOAM's own forces
    rec = {"c_l": float(cl[-1]), "c_d": float(cd[-1]), "c_max": float(np.linalg.norm(u[:, :2], axis=1).max()),
           "iterations": int(coefficients["Time"][-1]), "converged": "SIMPLE solution converged" in log,
           "cpu_seconds": cpu_seconds(directory)}
    rec["status"] = "converged" if rec["converged"] else "iteration cap"
    rec.update(window_stats(cl, 1))
    rec["wall"] = wall_record(mesh, p[mesh.owner[wall]], -shear["wall"][:, :2])
    return rec


def read_coefficients(directory: Path) -> dict[str, np.ndarray] | None:
    """``forceCoeffs`` columns by name (``Time``, ``Cl``, ``Cd``, ...) over every start of the case: the
    ``postProcessing/forceCoeffs/<start time>/coefficient.dat`` files joined in time order; None when there is none."""
    files = sorted((directory / "postProcessing" / "forceCoeffs").glob("*/coefficient.dat"),
                   key=lambda f: float(f.parent.name))
    if not files:
        return None
    header = [ln for ln in files[0].read_text().splitlines() if ln.startswith("#")][-1][1:].split()
    data = np.vstack([read_dat(f) for f in files])
    return {name: data[:, i] for i, name in enumerate(header)}


def cpu_seconds(directory: Path) -> float | None:
    """CPU seconds of all simpleFoam logs of the case (a resumed run has one per stretch)."""
    ends = [execution_times(f.read_text()) for f in directory.glob("log.simpleFoam*")]
    return float(sum(e[-1] for e in ends if e.size)) if any(e.size for e in ends) else None


# ---------------------------------------------------------------------------------------------- millfoil
def run_millfoil(level: str, alpha_deg: float, max_iter: int, state_file: Path | None = None,
                 max_seconds: float | None = None, variant: dict | None = None,
                 start_from: Path | None = None, cl_rel: float | None = CL_REL) -> dict:
    """The validation case's own settings (:func:`run_naca0012`) without the point-vortex correction, to the
    case's stop test with the C_L window relative (``cl_rel``, :class:`Convergence`; None: the case's absolute
    one). The record's ``cl_change_1000`` is the C_L change over the last 1 000 iterations (the drift left).

    ``start_from``: a finished OpenFOAM case of the same mesh; its fields (:func:`openfoam_state`) are
    written to ``state_file`` (required then) and the run starts from them instead of potential flow.

    ``variant`` (experiments, ``--mf-variant key=value``): :class:`solver.SimpleSettings` fields
    (``limiter``, ``limiter_k``, ``pressure_gradient``, ..., through :func:`naca_settings`) and
    :class:`solver.SST` fields (``face_interpolation``, ``production_measure``, ...); numbers are parsed."""
    from solver import SimpleSettings
    from solver.validation.naca0012 import Convergence, naca_settings, naca_turbulence, run_naca0012

    def value(v):
        try:
            return float(v)
        except (TypeError, ValueError):
            return v

    variant = {k: value(v) for k, v in (variant or {}).items()}
    simple = {k: v for k, v in variant.items() if k in SimpleSettings.__dataclass_fields__}
    sst = {k: v for k, v in variant.items() if k not in simple}
    conv = Convergence(max_iter=max_iter, cl_rel=cl_rel)
    settings = naca_settings(max_iter=conv.chunk, **simple) if simple else None
    turbulence = dataclasses.replace(naca_turbulence(), **sst) if sst else None
    if start_from is not None:
        write_openfoam_start(start_from, level, alpha_deg, state_file, turbulence or naca_turbulence())
    t0 = time.perf_counter()
    r = run_naca0012(alpha_deg, level, vortex_correction=False, convergence=conv, state_file=state_file,
                     max_seconds=max_seconds, settings=settings, turbulence=turbulence)
    res = r.results
    rec = {"c_l": r.c_l, "c_d": r.c_d, "c_max": float(res.c_max), "iterations": r.iterations, "status": r.status,
           "converged": r.status == "converged", "seconds": round(time.perf_counter() - t0, 1),
           "iterations_this_run": r.history.get("iterations_this_run"), "y_plus_max": r.y_plus_max,
           "c_d_pressure": r.c_d_pressure, "c_d_viscous": r.c_d_viscous, "cl_rel": cl_rel, "max_iter": max_iter}
    cl = np.asarray(r.history["c_l"])
    rec.update(window_stats(cl, r.history["chunk"]))
    back = 1000 // r.history["chunk"]
    rec["cl_change_1000"] = float(cl[-1] - cl[-back - 1]) if len(cl) > back else None
    j = res.mesh.boundary_local("wall")
    rec["wall"] = wall_record(res.mesh, res.boundary_pressure()[j], res.wall_shear("wall"))
    return rec


def write_openfoam_start(case: Path, level: str, alpha_deg: float, state_file: Path, turbulence) -> None:
    """Write OpenFOAM's converged fields of ``case`` as a millfoil restart file (iteration 0, no history)."""
    from solver import Fluid, Problem
    from solver.validation.naca0012 import _save_state, boundary_conditions

    problem = Problem.create(naca0012_cmesh(level, alpha_deg=alpha_deg).mesh, boundary_conditions(alpha_deg, True),
                             Fluid(1.0, 1.0 / REYNOLDS), turbulence=turbulence)
    _save_state(openfoam_state(case, problem), state_file, 0)


def variant_name(variant: dict) -> str:
    """``millfoil`` or ``millfoil[key=value,...]``: the code name of a run in the JSONL and the report."""
    return "millfoil" + (f"[{','.join(f'{k}={v}' for k, v in sorted(variant.items()))}]" if variant else "")


# ------------------------------------------------------------------------------------------------ report
def load_records(paths) -> dict:
    """``{(level, alpha, code): record}`` from JSONL files (the last record of a key wins)."""
    out = {}
    for path in paths:
        for line in Path(path).read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                out[(r["level"], float(r["alpha"]), r["code"])] = r
    return out


def wall_rms(a: dict, b: dict, key: str) -> float:
    """RMS over the wall faces of ``a[key] - b[key]`` (the same faces in both records)."""
    return float(np.sqrt(np.mean((np.asarray(a["wall"][key]) - np.asarray(b["wall"][key])) ** 2)))


#: C_L spread over the last :data:`WINDOW` iterations below which a run that stopped at its cap counts as
#: stationary (millfoil's own C_L test, :class:`solver.validation.naca0012.Convergence` ``cl_tol``).
STATIONARY_SPREAD = 5e-4


def convergence_class(r: dict) -> str:
    """``converged`` (the code's own test met), ``stationary`` (stopped at the cap with C_L spread below
    :data:`STATIONARY_SPREAD` over the last :data:`WINDOW` iterations), ``oscillating`` (larger spread) or
    ``diverged``."""
    if r.get("converged"):
        return "converged"
    if r.get("status") == "diverged" or r.get("cl_spread_window") is None:
        return "diverged"
    return "stationary" if r["cl_spread_window"] < STATIONARY_SPREAD else "oscillating"


def lift(r: dict) -> float:
    """C_L of a record: the last value, or the window mean of an oscillating run."""
    return r["cl_mean_window"] if convergence_class(r) == "oscillating" else r["c_l"]


def fmt(v, spec: str) -> str:
    return "—" if v is None else format(v, spec)


def report(records: dict) -> str:
    """Markdown table per level and angle (both codes, the CFL3D SST reference at 0 and 10 deg) and the angle of
    C_L,max per code."""
    ref = load_clcd()
    lines = ["| level | α | code | C_L | C_D | C_max | x_sep/c | iterations (class) | C_L spread 200 it | s (ms/it) "
             "| ΔC_L % | ΔC_D % | RMS ΔC_p | RMS Δc_f | CFL3D C_L / C_D | Ladson C_L / C_D |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    levels = sorted({k[0] for k in records}, key=["coarse", "medium", "fine"].index)
    notes = []
    for level in levels:
        for a in sorted({k[1] for k in records if k[0] == level}):
            of = records.get((level, a, "openfoam"))
            codes = sorted({c for lv, aa, c in records if lv == level and aa == a and c != "openfoam"})
            for code, r in [("OpenFOAM", of)] + [(c, records[(level, a, c)]) for c in codes]:
                if r is None or "error" in r:
                    continue
                diff = ["", "", "", ""]
                if code != "OpenFOAM" and of is not None and "error" not in of:
                    diff = [f"{100 * (lift(r) / lift(of) - 1):+.2f}" if abs(lift(of)) > 2e-2
                            else f"{lift(r) - lift(of):+.1e} abs", f"{100 * (r['c_d'] / of['c_d'] - 1):+.2f}",
                            f"{wall_rms(r, of, 'cp'):.4f}", f"{wall_rms(r, of, 'cf'):.2e}"]
                refs = f"{ref[a][0]:.4f} / {ref[a][1]:.5f}" if a in ref and code == "OpenFOAM" else ""
                lad = ladson_at(a) if code == "OpenFOAM" else None
                refs += " | " + ("" if lad is None else f"{lad[0]:.4f} / {lad[1]:.5f}")
                lines.append(
                    f"| {level} | {a:g} | {code} | {lift(r):.4f} | {r['c_d']:.5f} | {r['c_max']:.3f} | "
                    f"{fmt(r['wall']['x_sep'], '.3f')} | {r['iterations']} ({convergence_class(r)}) | "
                    f"{fmt(r['cl_spread_window'], '.1e')} | {fmt(r.get('seconds'), '.0f')} "
                    f"({1e3 * r['seconds'] / max(r.get('iterations_this_run') or r['iterations'], 1):.0f}) | "
                    + " | ".join(diff)
                    + f" | {refs} |")
        for code in sorted({c for lv, _, c in records if lv == level}):
            pts = [(a, lift(r)) for (lv, a, c), r in records.items() if lv == level and c == code and "error" not in r]
            if pts:
                a, cl = max(pts, key=lambda t: t[1])
                notes.append(f"{level}, {code}: C_L,max = {cl:.4f} at α = {a:g}° (of {len(pts)} angles)")
    return "\n".join(lines) + "\n\n" + "\n".join(f"- {n}" for n in notes)


#: The same-mesh tolerances (docs/explanation/validation.md): lift (relative), drag (relative), the angle of C_L,max
#: (degrees).
LIFT_TOLERANCE, DRAG_TOLERANCE, ANGLE_TOLERANCE = 0.01, 0.03, 1.0
LEVELS = ("coarse", "medium", "fine")


def criteria(records: dict, code: str = "millfoil", reference: str = "openfoam") -> str:
    """The same-mesh criteria, ``code`` against ``reference``, per level: the angles up to the reference's
    C_L,max (lift from 2°: at 0° C_L is ~0) where ΔC_L exceeds :data:`LIFT_TOLERANCE` or ΔC_D
    :data:`DRAG_TOLERANCE`, the angle of C_L,max of each, and from one level to the next the C_L change of both
    at the angles both levels have. Markdown; oscillating runs count by their window mean (:func:`lift`)."""
    def runs(level, name):
        return {a: r for (lv, a, c), r in records.items() if lv == level and c == name and "error" not in r}

    rows = [f"| level | angles compared | C_L,max at ({code} / {reference}) | ΔC_L outside "
            f"{LIFT_TOLERANCE:.0%} | ΔC_D outside {DRAG_TOLERANCE:.0%} |", "| --- | --- | --- | --- | --- |"]
    trend = []
    levels = [lv for lv in LEVELS if any(k[0] == lv for k in records)]
    for level in levels:
        mine, theirs = runs(level, code), runs(level, reference)
        both = sorted(set(mine) & set(theirs))
        if not both:
            continue
        a_mine = max(mine, key=lambda a: lift(mine[a]))
        a_theirs = max(theirs, key=lambda a: lift(theirs[a]))
        upto = [a for a in both if a <= a_theirs]
        d_lift = {a: lift(mine[a]) / lift(theirs[a]) - 1 for a in upto if a > 0}
        d_drag = {a: mine[a]["c_d"] / theirs[a]["c_d"] - 1 for a in upto}
        outside = [", ".join(f"{a:g}° ({100 * d[a]:+.2f} %)" for a in d if abs(d[a]) > tol) or "none"
                   for d, tol in ((d_lift, LIFT_TOLERANCE), (d_drag, DRAG_TOLERANCE))]
        flag = "" if abs(a_mine - a_theirs) <= ANGLE_TOLERANCE else " (outside 1°)"
        rows.append(f"| {level} | {', '.join(f'{a:g}' for a in both)} | {a_mine:g}° / {a_theirs:g}°{flag} | "
                    f"{outside[0]} | {outside[1]} |")
    for low, high in pairwise(levels):
        by = {(lv, n): runs(lv, n) for lv in (low, high) for n in (code, reference)}
        pairs = []
        for a in sorted(set.intersection(*(set(r) for r in by.values()))):
            if a > 0:
                ratio = [lift(by[high, n][a]) / lift(by[low, n][a]) - 1 for n in (code, reference)]
                pairs.append(f"{a:g}° {100 * ratio[0]:+.2f} / {100 * ratio[1]:+.2f} %")
        if pairs:
            trend.append(f"- C_L {low} → {high} ({code} / {reference}): " + "; ".join(pairs))
    return "\n".join(rows + [""] + trend)


def ladson_at(alpha_deg: float) -> tuple[float, float] | None:
    """Ladson's C_L, C_D at ``alpha_deg``: the mean over the three trip series of each one's linear
    interpolation; None outside the measured range of any series."""
    rows = load_ladson_trips()
    vals = []
    for series in rows.values():
        if not series[0, 0] <= alpha_deg <= series[-1, 0]:
            return None
        vals.append([np.interp(alpha_deg, series[:, 0], series[:, j]) for j in (1, 2)])
    return tuple(np.mean(vals, axis=0))


def load_ladson_trips() -> dict[str, np.ndarray]:
    """Ladson (1988) ``{trip: (alpha, C_L, C_D) rows sorted by alpha}`` (TMR file)."""
    out: dict[str, list] = {}
    for ln in LADSON_FILE.read_text().splitlines():
        if ln and not ln.startswith(("#", "trip")):
            r = ln.split(",")
            out.setdefault(r[0], []).append([float(v) for v in r[1:4]])
    return {k: np.array(sorted(v)) for k, v in out.items()}


#: The code label of the records taken with ``SST(velocity_gradient="green_gauss")`` (then the default); the
#: plain ``millfoil`` records are the present default's.
GREEN_GAUSS_SST = "millfoil-s10"
#: The code label of the records of the least-squares SST gradient (relabelled when ``green_gauss_bounded`` became
#: the default; the plain ``millfoil`` records since are the new default's).
LEAST_SQUARES = "millfoil-ls"
#: The code label of the records with the least-squares pressure gradient and the bounded Green–Gauss SST gradient
#: (relabelled when the bounded Green–Gauss pressure gradient became the default).
LS_PRESSURE_GRADIENT = "millfoil-s11"
#: The code label of the records with the bounded Green–Gauss pressure gradient and the skewness-corrected face
#: velocity (relabelled when the bounded face velocity became the case's default).
CORRECTED_FACE_VELOCITY = "millfoil-s12"
#: The code label of the records with the bounded face velocity and the unlimited omega production (relabelled when
#: OpenFOAM's limited omega production became the case's default).
UNLIMITED_OMEGA = "millfoil-s13"
#: The code label of OpenFOAM's runs with ``--interpolation "skewCorrected linear"``: the face values of
#: HbyA and rAU in its flux skewness-corrected, the counterpart of millfoil's reconstructed face velocity.
OPENFOAM_SKEW = "openfoam[interpolation=skewCorrected linear]"


def plot(records: dict, directory: Path) -> list[Path]:
    """C_L(α) of both codes with the references; C_p and c_f of both codes at the highest incidence where both
    converged (per level)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    directory.mkdir(parents=True, exist_ok=True)
    out = []
    fig, ax = plt.subplots(figsize=(11, 5))
    styles = {"openfoam": ("OpenFOAM kOmegaSST", "s--"),
              OPENFOAM_SKEW: ("OpenFOAM kOmegaSST, skewCorrected linear face flux", "D:"),
              "millfoil": ("millfoil SST (default: limited ω production, bounded face velocity)", "o-"),
              UNLIMITED_OMEGA: ("millfoil SST, unlimited ω production", "^-"),
              CORRECTED_FACE_VELOCITY: ("millfoil SST, corrected face velocity", "v-.")}
    # the records of older defaults (LS_PRESSURE_GRADIENT, LEAST_SQUARES, GREEN_GAUSS_SST) stay in the JSONL and the
    # report's table, not on the figure: with both levels, more curves hide the ones compared
    for level in sorted({k[0] for k in records}):
        for code, (label, style) in styles.items():
            pts = sorted((a, lift(r)) for (lv, a, c), r in records.items() if lv == level and c == code
                         and "error" not in r)
            if pts:
                ax.plot(*zip(*pts, strict=True), style, ms=4, label=f"{label}, {level}")
    lad = np.vstack(list(load_ladson_trips().values()))
    ax.plot(lad[:, 0], lad[:, 1], "k^", ms=4, mfc="none", label="Ladson (1988), experiment")
    ref = load_clcd()
    ax.plot(list(ref), [v[0] for v in ref.values()], "r*", ms=10, label="TMR CFL3D SST (897×257)")
    ax.set(xlabel="α (deg)", ylabel="C_L", title="NACA 0012, Re 6·10⁶, same C-mesh, no point vortex", xlim=(-1, 21),
           ylim=(-0.1, 1.9))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))     # beside the curves, not over them
    fig.tight_layout()
    out.append(directory / "naca0012_cl_alpha.png")
    fig.savefig(out[-1], dpi=120)
    plt.close(fig)
    for level in sorted({k[0] for k in records}):
        both = [a for (lv, a, c), r in records.items() if lv == level and c == "millfoil" and "error" not in r
                and convergence_class(r) != "oscillating" and (lv, a, "openfoam") in records
                and convergence_class(records[(lv, a, "openfoam")]) != "oscillating"]
        for a in sorted({max(both)} | ({10.0} & set(both))) if both else ():
            out.append(_plot_wall(records, level, a, styles, directory, plt))
    return out


def _plot_wall(records: dict, level: str, a: float, styles: dict, directory: Path, plt) -> Path:
    """C_p (whole chord and leading edge) and c_f of both codes at one angle; returns the file."""
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    for code, (label, _) in styles.items():
        if (level, a, code) not in records:
            continue
        w = records[(level, a, code)]["wall"]
        x, y = np.asarray(w["x"]), np.asarray(w["y"])
        for surf, sel, colour in (("upper", y > 0, "C0"), ("lower", y <= 0, "C3")):
            o = np.argsort(x[sel])
            kw = dict(color=colour, ls={"millfoil": "-", "openfoam": "--"}.get(code, ":"), label=f"{label}, {surf}")
            for axis in axes[:2]:
                axis.plot(x[sel][o], -np.asarray(w["cp"])[sel][o], marker="." if axis is axes[1] else None, **kw)
            axes[2].plot(x[sel][o], np.asarray(w["cf"])[sel][o], **kw)
    axes[0].set(xlabel="x/c", ylabel="−C_p", title=f"{level}, α = {a:g}°")
    axes[1].set(xlabel="x/c", ylabel="−C_p", title="leading edge (wall faces marked)", xlim=(-0.001, 0.03))
    axes[2].set(xlabel="x/c", ylabel="c_f", title="c_f along the surface, LE→TE", ylim=(-0.005, 0.02))
    for axis in axes:
        axis.grid(alpha=0.3)
        axis.legend(fontsize=7)
    fig.tight_layout()
    path = directory / f"naca0012_{level}_cp_cf_alpha{a:g}.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


# --------------------------------------------------------------------------------------------------- CLI
def non_negative(kind: type):
    """An argparse type: a ``kind`` (int or float) >= 0 (``--of-non-orthogonal``, ``--mf-cl-rel``); anything else,
    NaN included, exits with 2 and names the value."""
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            value = -1
        if not value >= 0:
            raise argparse.ArgumentTypeError(f"needs {'an integer' if kind is int else 'a number'} >= 0, got {text!r}")
        return value
    return parse


# ------------------------------------------------------------------------------------------ drag study
#: ν_t/ν below which a cell counts as outside the boundary layer (the TMR free stream has 0.009).
INVISCID_NUT = 1.0
#: Wall distance [c] within which the loss flux is summed (beyond it the far-field's own error dominates).
NEAR_FIELD = 0.2


def total_pressure_deficit(f: dict[str, np.ndarray]) -> np.ndarray:
    """(p0∞ − p0)/q∞ per cell (U∞ = 1, p∞ = 0: q∞ = p0∞ = 1/2); p is the modified pressure p + 2/3 k."""
    p0 = f["p"] - 2.0 / 3.0 * f["k"] + 0.5 * np.einsum("ij,ij->i", f["u"], f["u"])
    return (0.5 - p0) / 0.5


def loss_flux(cm: CMesh, f: dict[str, np.ndarray], x_station: float, side: str) -> float:
    """Drag coefficient of the total-pressure flux through the wall-normal node line nearest ``x_station`` on
    ``side`` (``"upper"``/``"lower"``), over the cells outside the boundary layer within :data:`NEAR_FIELD` of the
    wall: the mean of the two cell columns either side of the line, signed positive downstream."""
    n_j = cm.xy.shape[1] - 1
    nw, ns = cm.spec.n_wake, cm.spec.n_side
    lines = np.arange(nw + 1, nw + ns) if side == "lower" else np.arange(nw + ns + 1, nw + 2 * ns)
    i = lines[np.argmin(np.abs(cm.xy[lines, 0, 0] - x_station))]
    seg = np.diff(cm.xy[i], axis=0)                                    # node j -> j + 1 along the line
    normal = np.column_stack([seg[:, 1], -seg[:, 0]])                  # towards increasing i, length-weighted
    cells = np.arange(i - 1, i + 1)[:, None] * n_j + np.arange(n_j)    # the two columns (i, j) -> i n_j + j
    column = {name: f[name][cells] for name in ("u", "p", "k", "nut")}
    deficit = total_pressure_deficit({name: v.reshape(-1, *v.shape[2:]) for name, v in column.items()})
    un = np.einsum("cjk,jk->cj", column["u"], normal)
    wall_xy = 0.5 * (cm.xy[i - 1:i + 1, 0] + cm.xy[i:i + 2, 0])        # wall-face centre of each column
    dist = np.linalg.norm(cm.mesh.centroid[cells] - wall_xy[:, None, :], axis=2)
    keep = (column["nut"] * REYNOLDS < INVISCID_NUT) & (dist < NEAR_FIELD)   # ν_t/ν (U∞ = c = 1)
    # Σ (p0∞ − p0) u·n Δl / (q∞ U∞ c) with U∞ = c = 1: q∞ cancels against the deficit's; mean of the columns
    flux = 0.5 * np.sum((deficit.reshape(2, n_j) * un)[keep])
    downstream = np.sign(np.sum(un[1]))
    return float(downstream * flux)


def richardson(values, cells) -> tuple[float | None, float | None]:
    """Observed order and extrapolated value of three levels ``values`` on meshes of ``cells`` cells (h ∝
    cells^-1/2, unequal ratios): solves (f1 − f2)(r32^p − 1) = (f2 − f3) r32^p (r21^p − 1) for p in (0.05, 6).
    (None, None) when the three are not monotone in a way that order can explain."""
    f1, f2, f3 = values
    h = 1.0 / np.sqrt(np.asarray(cells, float))
    r21, r32 = h[0] / h[1], h[1] / h[2]

    def residual(p):
        return (f1 - f2) * (r32 ** p - 1) - (f2 - f3) * r32 ** p * (r21 ** p - 1)

    try:
        p = brentq(residual, 0.05, 6.0)
    except ValueError:
        return None, None
    return p, f3 + (f3 - f2) / (r32 ** p - 1)
