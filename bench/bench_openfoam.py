"""millfoil against OpenFOAM's simpleFoam + kOmegaSST on the same mesh, one core each, back to back.

For the benchmark blade (and ``--blades`` random Table 6 blades) at each ``--levels`` level: builds the mesh
once, writes it as an OpenFOAM ``polyMesh`` (the 2D cells extruded one cell, front and back ``empty``;
written directly from the solver's finite-volume mesh, so both codes solve on the very same cells), sets
up the same conditions (uniform inlet C0 with 5 % intensity and nu_t/nu = 10, outlet p = 0, symmetry top
and bottom, blade wall with Spalding wall functions as millfoil's ``automatic``), runs ``simpleFoam``
(SIMPLEC ``consistent``, α_U 0.9, bounded linearUpwind, GAMG) and millfoil (its defaults), and prints per
case: iterations to lift within 0.5 % and 0.1 % of the final value, time per iteration, time to those
points, C_L and the ratio millfoil / OpenFOAM. Times are CPU times of one core, which another job on the
machine inflates far less than the wall clock (printed beside them). The time to a point is each code's CPU
clock at the end of that iteration, its own set-up included: OpenFOAM's ``ExecutionTime`` (from the start of
``simpleFoam``: reading the mesh and fields, building its solvers), millfoil's ``time.process_time`` from the
start of its solve stage (the problem set-up, the reconstruction operators, the AMG set-up) on a fresh copy of
the mesh (the operators it caches on the mesh are rebuilt every run). Neither code's mesh generation or case
writing is counted. Before the first case millfoil runs three iterations once, untimed, so that loading its
compiled kernels (numba's cache, ~0.5 s once per process, as in a campaign's worker) is not charged to the first
case. ``--repeats N`` runs both codes N times on each case, alternating,
and prints each code's median time (the iterations are deterministic); the ratio is that of the medians.

OpenFOAM comes from Debian's ``openfoam`` package; the script runs ``apt-get install -y openfoam`` where
``simpleFoam`` is missing (``--no-install`` to skip; the OpenFOAM columns then say why they are empty).

    OMP_NUM_THREADS=1 python bench/bench_openfoam.py --levels coarse medium --blades 2 --iterations 600 \
        --repeats 3
"""

from __future__ import annotations

import argparse
import copy
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_performance import cases, iterations_within  # noqa: E402

from solver.validation.openfoam import DEPTH, ENV, HEADER, control_head, ensure_openfoam, write_polymesh  # noqa: E402

#: Patch types of the blade channel's boundary groups.
BLADE_PATCH_TYPES = {"inlet": "patch", "outlet": "patch", "top": "symmetry", "bottom": "symmetry", "blade": "wall"}


# --------------------------------------------------------------------------------------------- the case
def write_case(directory: Path, speed: float, rho: float, mu: float, intensity: float, ratio: float,
               iterations: int, functions: str = "") -> None:
    """``0/``, ``constant/`` and ``system/`` of the simpleFoam case (kinematic pressure, p = 0 at the outlet);
    ``functions``: more function-object entries after ``forces`` (e.g. ``bench_blades_openfoam``'s C_max)."""
    nu = mu / rho
    k = 1.5 * (intensity * speed) ** 2
    omega = k / (nu * ratio)
    files = {
        "constant/transportProperties": ("dictionary", f"transportModel Newtonian;\nnu {nu:.8g};\n"),
        "constant/turbulenceProperties": ("dictionary", "simulationType RAS;\nRAS\n{\n    RASModel kOmegaSST;\n"
                                          "    turbulence on;\n    printCoeffs off;\n}\n"),
        "system/controlDict": ("dictionary", control_head(iterations) + f"""functions
{{
    forces
    {{
        type forces;
        libs ("libforces.so");
        patches (blade);
        rho rhoInf;
        rhoInf {rho};
        CofR (0 0 0);
        writeControl timeStep;
        writeInterval 1;
    }}
{functions}}}
"""),
        "system/fvSchemes": ("dictionary", """ddtSchemes { default steadyState; }
gradSchemes { default Gauss linear; }
divSchemes
{
    default none;
    div(phi,U) bounded Gauss linearUpwind grad(U);
    div(phi,k) bounded Gauss upwind;
    div(phi,omega) bounded Gauss upwind;
    div((nuEff*dev2(T(grad(U))))) Gauss linear;
}
laplacianSchemes { default Gauss linear corrected; }
interpolationSchemes { default linear; }
snGradSchemes { default corrected; }
wallDist { method meshWave; }
"""),
        "system/fvSolution": ("dictionary", """solvers
{
    p { solver GAMG; smoother GaussSeidel; tolerance 1e-7; relTol 0.05; }
    "(U|k|omega)" { solver smoothSolver; smoother GaussSeidel; tolerance 1e-8; relTol 0.1; }
}
SIMPLE
{
    nNonOrthogonalCorrectors 0;
    consistent yes;
    residualControl { p 1e-6; U 1e-6; "(k|omega)" 1e-6; }
}
relaxationFactors { equations { U 0.9; ".*" 0.9; } }
"""),
    }

    def field(name, cls, dims, internal, patches):
        body = f"dimensions {dims};\ninternalField uniform {internal};\nboundaryField\n{{\n"
        for patch, spec in patches.items():
            body += f"    {patch}\n    {{\n        {spec}\n    }}\n"
        body += "    frontAndBack { type empty; }\n    \"(top|bottom)\" { type symmetry; }\n}\n"
        files[f"0/{name}"] = (cls, body)

    u = f"({speed} 0 0)"
    field("U", "volVectorField", "[0 1 -1 0 0 0 0]", u, {
        "inlet": f"type fixedValue; value uniform {u};", "outlet": f"type inletOutlet; inletValue uniform (0 0 0); "
        f"value uniform {u};", "blade": "type noSlip;"})
    field("p", "volScalarField", "[0 2 -2 0 0 0 0]", "0", {
        "inlet": "type zeroGradient;", "outlet": "type fixedValue; value uniform 0;", "blade": "type zeroGradient;"})
    field("k", "volScalarField", "[0 2 -2 0 0 0 0]", f"{k:.8g}", {
        "inlet": f"type fixedValue; value uniform {k:.8g};",
        "outlet": f"type inletOutlet; inletValue uniform {k:.8g}; value uniform {k:.8g};",
        "blade": f"type kqRWallFunction; value uniform {k:.8g};"})
    field("omega", "volScalarField", "[0 0 -1 0 0 0 0]", f"{omega:.8g}", {
        "inlet": f"type fixedValue; value uniform {omega:.8g};",
        "outlet": f"type inletOutlet; inletValue uniform {omega:.8g}; value uniform {omega:.8g};",
        "blade": f"type omegaWallFunction; value uniform {omega:.8g};"})
    field("nut", "volScalarField", "[0 2 -1 0 0 0 0]", "0", {
        "inlet": "type calculated; value uniform 0;", "outlet": "type calculated; value uniform 0;",
        "blade": "type nutUSpaldingWallFunction; value uniform 0;"})
    for rel, (cls, body) in files.items():
        path = directory / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(HEADER.format(cls=cls, loc=str(Path(rel).parent), obj=Path(rel).name) + body)


def run_openfoam(directory: Path, half_dynamic: float) -> dict:
    """Run simpleFoam in ``directory``; lift history (C_L per iteration) and timings from its log and forces."""
    t0 = time.perf_counter()
    with open(directory / "log.simpleFoam", "w") as log:
        subprocess.run(["bash", "-c", f'{ENV}simpleFoam -case "{directory}"'], stdout=log,
                       stderr=subprocess.STDOUT, check=False)
    wall = time.perf_counter() - t0
    text = (directory / "log.simpleFoam").read_text()
    exec_times = [float(t) for t in re.findall(r"ExecutionTime = ([0-9.eE+-]+) s", text)]    # CPU time
    clock_times = [float(t) for t in re.findall(r"ClockTime = ([0-9.eE+-]+) s", text)]       # wall clock
    force_files = sorted((directory / "postProcessing" / "forces").glob("*/force.dat"))
    if not force_files or not exec_times:
        return {"error": f"no forces or no iterations (see {directory / 'log.simpleFoam'})"}
    rows = [line.replace("(", " ").replace(")", " ").split() for line in force_files[0].read_text().splitlines()
            if line and not line.startswith("#")]
    fy = np.array([float(r[2]) for r in rows]) / DEPTH            # total force y, N per metre of span
    n = len(fy)
    per_it = (exec_times[-1] - exec_times[0]) / max(len(exec_times) - 1, 1)
    wall_it = (clock_times[-1] - clock_times[0]) / max(len(clock_times) - 1, 1) if clock_times else float("nan")
    # ExecutionTime is printed with 2 decimals (10 ms): fine against seconds to a point, not per iteration
    return {"iterations": n, "ms_per_iteration": 1e3 * per_it, "wall_ms_per_iteration": 1e3 * wall_it,
            "c_l": fy[-1] / half_dynamic, "fy": fy, "cpu": np.array(exec_times[:n]), "wall_s": wall}


def run_millfoil(config, fvmesh) -> dict:
    """millfoil's solve stage; ``cpu``: this process's CPU time at the end of each iteration from the start
    of the stage (problem set-up included), as OpenFOAM's ``ExecutionTime`` counts from its start;
    ``ms_per_iteration``: the whole stage's CPU time per iteration; the wall clock of the iterations beside
    it."""
    from optimizer.pipeline import solve_flow

    clock: list[float] = []
    c0 = time.process_time()
    flow = solve_flow(config, fvmesh, log=lambda _line: clock.append(time.process_time() - c0), every=1)
    cpu = time.process_time() - c0
    fy = np.asarray(flow.monitors["fy:blade"])
    return {"iterations": flow.iterations, "ms_per_iteration": 1e3 * cpu / flow.iterations,
            "wall_ms_per_iteration": 1e3 * flow.wall_time / flow.iterations, "fy": fy, "status": flow.status,
            "cpu": np.array(clock), "wall_s": flow.wall_time}


def summarise(run: dict, half_dynamic: float) -> dict:
    """``run`` with C_L, the iterations to lift within 0.5 % / 0.1 % of its final value and the CPU
    seconds at the end of those iterations (``s_0_5``, ``s_0_1``)."""
    fy, cpu = run["fy"], run["cpu"]
    out = dict(run, c_l=fy[-1] / half_dynamic, lift_0_5=iterations_within(fy, 5e-3),
               lift_0_1=iterations_within(fy, 1e-3))
    out["s_0_5"] = float(cpu[out["lift_0_5"] - 1])
    out["s_0_1"] = float(cpu[out["lift_0_1"] - 1])
    return out


def median_run(runs: list[dict]) -> dict:
    """The first of ``runs`` (the iterations are deterministic) with each time the median over ``runs``."""
    keys = ("ms_per_iteration", "wall_ms_per_iteration", "s_0_5", "s_0_1")
    return dict(runs[0], **{k: float(np.median([r[k] for r in runs])) for k in keys}, repeats=len(runs))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", nargs="+", default=["coarse", "medium"])
    parser.add_argument("--blades", type=int, default=2)
    parser.add_argument("--iterations", type=int, default=600, help="simpleFoam iterations (it never meets 1e-6)")
    parser.add_argument("--work", type=Path, default=ROOT / "runs" / "bench_openfoam")
    parser.add_argument("--no-install", action="store_true")
    parser.add_argument("--repeats", type=int, default=1,
                        help="runs of each code per case, alternating; times are the medians")
    args = parser.parse_args()
    from optimizer.config import Config
    from optimizer.pipeline import _meshes, blade_profile

    why = ensure_openfoam(not args.no_install)
    print(f"# load average {os.getloadavg()[0]:.1f}, OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS')}, "
          f"{time.strftime('%Y-%m-%d %H:%M')}; OpenFOAM: {why or shutil.which('simpleFoam')}; "
          f"{args.repeats} run(s) per code and case, medians")
    print("| case | code | iterations | lift 0.5 % / 0.1 % | CPU ms / iteration (wall) | CPU s to 0.5 % / 0.1 % "
          "| C_L | ratio (0.1 %, CPU) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    warmed = False
    for name, raw in cases(args.blades, args.levels):
        config = Config.from_mapping(raw)
        flow = config.flow
        half_dynamic = 0.5 * flow.density * flow.speed**2 * config.blade.blade_spec().values["L"]
        _, fvmesh = _meshes(config, blade_profile(config))
        case = args.work / name.replace(" ", "_")
        if why is None:
            shutil.rmtree(case, ignore_errors=True)
            write_polymesh(fvmesh, case, BLADE_PATCH_TYPES)
            write_case(case, flow.speed, flow.density, flow.viscosity, flow.intensity, flow.viscosity_ratio,
                       args.iterations)
        if not warmed:
            run_millfoil(Config.from_mapping({**raw, "solver": {**raw.get("solver", {}), "max_iter": 3}}),
                         copy.deepcopy(fvmesh))
            warmed = True
        mf_runs, of_runs = [], []
        for _ in range(max(args.repeats, 1)):
            mf_runs.append(summarise(run_millfoil(config, copy.deepcopy(fvmesh)), half_dynamic))
            if why is None:
                shutil.rmtree(case / "postProcessing", ignore_errors=True)
                res = run_openfoam(case, half_dynamic)
                of_runs.append(summarise(res, half_dynamic) if "error" not in res else res)
        mf = median_run(mf_runs)
        failed = next((r for r in of_runs if "error" in r), None)
        of = failed or (median_run(of_runs) if of_runs else None)
        for code, r in (("millfoil", mf), ("OpenFOAM", of)):
            if r is None or "error" in r:
                print(f"| {name} | {code} | — ({why or r['error']}) | | | | | |")
                continue
            ratio = "" if code == "OpenFOAM" or of is None or "error" in of else f"{r['s_0_1'] / of['s_0_1']:.2f}"
            print(f"| {name} | {code} | {r['iterations']} | {r['lift_0_5']} / {r['lift_0_1']} | "
                  f"{r['ms_per_iteration']:.1f} ({r['wall_ms_per_iteration']:.1f}) | {r['s_0_5']:.2f} / "
                  f"{r['s_0_1']:.2f} | {r['c_l']:.4f} | {ratio} |",
                  flush=True)


if __name__ == "__main__":
    main()
