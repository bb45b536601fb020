"""The blade channel's OpenFOAM peer: the simpleFoam + kOmegaSST case of a blade's finite-volume mesh and its runner.

The same conditions as millfoil's blade evaluation (uniform inlet with the flow's intensity and viscosity ratio,
outlet p = 0, symmetry top and bottom, blade wall with Spalding wall functions as millfoil's ``automatic`` wall
treatment) on the very same cells (:func:`solver.validation.openfoam.write_polymesh` with
:data:`BLADE_PATCH_TYPES`). Used by ``bench/bench_openfoam.py`` (time to converged lift) and
``bench/bench_blades_openfoam.py`` (same-mesh lift and C_max); OpenFOAM is Debian's ``openfoam`` package
(:func:`solver.validation.openfoam.ensure_openfoam`).
"""

from __future__ import annotations

import re
import subprocess
import time
from pathlib import Path

import numpy as np

from solver.validation.openfoam import DEPTH, ENV, HEADER, control_head

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
