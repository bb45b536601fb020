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
import shutil
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_performance import cases, iterations_within  # noqa: E402

from optimizer.peers import BLADE_PATCH_TYPES, run_openfoam, write_case  # noqa: E402
from solver.validation.openfoam import ensure_openfoam, write_polymesh  # noqa: E402


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
