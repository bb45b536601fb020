"""Blades against OpenFOAM on the same mesh: lift, C_max and convergence class of millfoil and simpleFoam.

For the paper's two blades (``table4``: the Table 4 C2 design blade, ``table5``: the Table 5 G1 tool-path
blade) and the first ``--random`` random Table 6 blades of ``bench/bench_robustness.py``'s draw (seed 2013;
``--indices``: those of the draw) at ``--level`` (default medium): builds the mesh once, runs OpenFOAM's
``simpleFoam`` + ``kOmegaSST`` on it
(the case of ``bench/bench_openfoam.py``: same inlet, outlet, symmetry and wall-function conditions, SIMPLEC
0.9, bounded linearUpwind; ``--of-iterations`` iterations) and millfoil (the blade evaluation's solve,
``optimizer.pipeline.solve_flow``, with ``--mf-set`` changes), one core each, back to back, and prints per
blade F_Y (N/m), C_L and C_max (m/s) of each code, the relative differences millfoil / OpenFOAM - 1, each
code's convergence class, iterations and solve time.

Both codes measure the same things:

* F_Y: the total (pressure + viscous) force on the blade along y, N per metre of span (OpenFOAM's
  ``forces`` function object with ``rhoInf`` = the water density, divided by the extrusion depth);
  C_L = F_Y / (0.5 rho C0² c) with the profile's chord c.
* C_max: the largest cell speed |u| (m/s), as millfoil's ``c_max`` monitor (``solver/monitors.py``), one
  value per iteration. OpenFOAM's comes from the ``fieldMinMax`` function object on ``mag(U)``, which also
  looks at the boundary values; these never exceed the cell maximum here (inlet C0, wall 0, symmetry and
  outlet values: the tangential part or copy of the owner cell's velocity), and the record checks its last
  value against the maximum over the cells of the written ``U`` field (``c_max_check``).
* The class: millfoil's own status (converged by its stop tests, or classified at the cap or when
  established). OpenFOAM runs a fixed number of iterations (it does not meet its 1e-6 residual control);
  where it does stop there (``SIMPLE solution converged``) it is ``converged``; else
  its F_X, F_Y and C_max histories are classified like millfoil's at the cap
  (:func:`solver.convergence.classify` over the last ``classify_window`` iterations with ``classify_tol``;
  ``stationary`` counts as ``converged``, as in :func:`solver.monitors.classify_at_cap`).
* The values compared: the last iterate's, or the window means of the monitors where the class is
  ``oscillating`` (as ``optimizer.figures.figures_of_merit`` does).

OpenFOAM's result is cached per blade and level (``--work``/level/blade/openfoam.json, with the mesh's cell
count and the iteration count), so several millfoil variants are compared with one OpenFOAM run.
``--mf-set KEY=VALUE`` (repeatable): a ``solver:`` key (a :class:`solver.SimpleSettings` field, e.g.
``limiter_iterations=300``, ``pressure_gradient=green_gauss``) or an :class:`solver.turbulence.SST` field
(``omega_production=limited``, ``omega_wall_flux=two_point``); values are read as JSON where they parse
(``bench_robustness.overrides``). ``--out`` appends JSON lines (one per blade and variant);
``--report FILE ...`` prints the tables and the summary against the blades' same-mesh criteria (lift within 1.5 %,
C_max within 1 %, same class) of finished records without running anything.

    nice -n 5 env OMP_NUM_THREADS=1 python bench/bench_blades_openfoam.py --random 10 \\
        --out runs/bench_blades_openfoam/medium.jsonl
    nice -n 5 env OMP_NUM_THREADS=1 python bench/bench_blades_openfoam.py --random 10 --mf-set limiter_iterations=300 \\
        --mf-set pressure_gradient=green_gauss --mf-set omega_production=limited --mf-set omega_wall_flux=two_point \\
        --out runs/bench_blades_openfoam/medium.jsonl
    python bench/bench_blades_openfoam.py --report runs/bench_blades_openfoam/medium.jsonl
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_paper_blades import BLADES as PAPER_BLADES  # noqa: E402

from geometry.draws import draw_blades  # noqa: E402
from optimizer.peers import BLADE_PATCH_TYPES, run_openfoam, write_case  # noqa: E402
from solver.validation.openfoam import DEPTH, ensure_openfoam, latest_time, read_dat, read_field, write_polymesh  # noqa: E402

#: The blades' same-mesh criteria (docs/explanation/validation.md): |C_L ratio - 1| and |C_max ratio - 1|.
LIFT_TOL, CMAX_TOL = 0.015, 0.01
#: Classes of a solve whose figures are used (the window means where oscillating).
SETTLED = ("converged", "oscillating")
#: OpenFOAM function object writing min and max of |U| every iteration (C_max; see the module docstring).
CMAX_FUNCTION = """    cmax
    {
        type fieldMinMax;
        libs ("libfieldFunctionObjects.so");
        fields (U);
        mode magnitude;
        location false;
        writeControl timeStep;
        writeInterval 1;
    }
"""


# ---------------------------------------------------------------------------------------------- the blades
def blade_configs(paper: list[str], indices: list[int], level: str, solver: dict,
                  seed: int = 2013) -> list[tuple[str, object]]:
    """``(name, Config)`` of the paper blades ``paper`` and the random Table 6 blades ``indices`` (of the
    seeded draw) at mesh ``level``, with the ``solver:`` keys ``solver`` changed."""
    from optimizer.config import Config, load_config

    sets = [f"solver.{k}={json.dumps(v) if not isinstance(v, str) else v}" for k, v in solver.items()]
    out = [(name, load_config(ROOT / PAPER_BLADES[name], [f"mesh.level={level}", *sets])) for name in paper]
    drawn = draw_blades(max(indices) + 1, seed) if indices else []
    for i in indices:
        mode, cont, params = drawn[i]
        raw = {"blade": {"mode": mode, "continuity": cont, "parameters": params}, "mesh": {"level": level},
               "solver": solver}
        out.append((f"random{i}-{mode}-{cont}", Config.from_mapping(raw)))
    return out


def split_variant(items: list[str]) -> tuple[dict, dict]:
    """``(solver: keys, SST fields)`` of the ``--mf-set`` items (a key of both, e.g. ``omega_production``, is
    taken as the ``solver:`` key); an unknown key is an error."""
    from optimizer.config import SolverConfig, apply_overrides
    from solver.turbulence import SST

    values = apply_overrides({}, [f"solver.{item}" for item in items]).get("solver", {})
    solver_keys = set(SolverConfig.model_fields)
    sst_keys = {f.name for f in dataclasses.fields(SST)} - solver_keys
    unknown = sorted(set(values) - sst_keys - solver_keys)
    if unknown:
        raise SystemExit(f"--mf-set: unknown keys {unknown} (solver: keys or SST fields)")
    return ({k: v for k, v in values.items() if k in solver_keys}, {k: v for k, v in values.items() if k in sst_keys})


def variant_name(items: list[str]) -> str:
    return ",".join(items) if items else "defaults"


# ------------------------------------------------------------------------------------------------ the codes
def classify_run(monitors: dict, window: int, tol: float):
    """Class and values compared (last iterate, window means where oscillating) of a fixed-length run's
    monitor histories (``fx:blade``, ``fy:blade``, ``c_max``), as millfoil's classification at the cap."""
    from solver import SimpleSettings
    from solver.monitors import classify_at_cap

    status, _message, cls = classify_at_cap(monitors, {}, SimpleSettings(classify_window=window, classify_tol=tol))
    values = {k: float(v[-1]) for k, v in monitors.items()}
    if status == "oscillating":
        values = {k: cls.mean[k] for k in monitors}
    return status, values, cls


def openfoam_run(config, fvmesh, case: Path, iterations: int) -> dict:
    """simpleFoam on ``fvmesh`` in ``case`` (or its cached result): histories, class, values, timings."""
    cache = case / "openfoam.json"
    if cache.exists():
        rec = json.loads(cache.read_text())
        if rec.get("cells") == fvmesh.n_cells and rec.get("iterations_asked") == iterations:
            return rec | {"cached": True}
    import shutil

    flow, s = config.flow, config.solver
    shutil.rmtree(case, ignore_errors=True)
    write_polymesh(fvmesh, case, BLADE_PATCH_TYPES)
    write_case(case, flow.speed, flow.density, flow.viscosity, flow.intensity, flow.viscosity_ratio, iterations,
               functions=CMAX_FUNCTION)
    run = run_openfoam(case, 1.0)
    if "error" in run:
        return {"error": run["error"], "cells": fvmesh.n_cells, "iterations_asked": iterations}
    forces = read_dat(next((case / "postProcessing" / "forces").glob("*/force.dat")))
    mag_u = read_dat(next((case / "postProcessing" / "cmax").glob("*/fieldMinMax.dat")))
    n = min(len(forces), len(mag_u))
    monitors = {"fx:blade": forces[:n, 1] / DEPTH, "fy:blade": forces[:n, 2] / DEPTH, "c_max": mag_u[:n, -1]}
    status, values, cls = classify_run(monitors, s.classify_window, s.classify_tol)
    if "SIMPLE solution converged" in (case / "log.simpleFoam").read_text():
        status, values = "converged", {k: float(v[-1]) for k, v in monitors.items()}    # residualControl met
    u_last = read_field(latest_time(case) / "U", fvmesh.n_cells)[0]
    rec = {"cells": fvmesh.n_cells, "iterations_asked": iterations, "iterations": n, "status": status,
           "reason": cls.reason, "monitor_status": cls.monitor_status, "values": values,
           "amplitude": cls.amplitude, "period": cls.period,
           "c_max_check": float(np.sqrt((u_last[:, :2] ** 2).sum(axis=1)).max()) - float(monitors["c_max"][-1]),
           "ms_per_iteration": run["ms_per_iteration"], "solve_s": run["ms_per_iteration"] * n / 1e3,
           "wall_s": run["wall_s"], "history": {k: v.tolist() for k, v in monitors.items()}}
    cache.write_text(json.dumps(rec))
    return rec


def millfoil_run(config, fvmesh, sst: dict) -> dict:
    """millfoil's blade solve (:func:`optimizer.pipeline.solve_flow`; with ``sst`` SST fields changed, the
    same problem with that turbulence model): class, values compared, timings."""
    from optimizer.pipeline import boundary_conditions, simple_settings, solve_flow, turbulence_model
    from solver import Fluid, Problem, initial_state, solve_steady

    s = config.solver
    if not sst:
        flow = solve_flow(config, fvmesh)
    else:
        problem = Problem.create(fvmesh, boundary_conditions(config), Fluid(config.flow.density, config.flow.viscosity),
                                 turbulence=dataclasses.replace(turbulence_model(config), **sst))
        u0 = (config.flow.speed, 0.0) if s.initial == "freestream" else (0.0, 0.0)
        flow = solve_steady(problem, simple_settings(config), initial_state(problem, u0))
    monitors = {k: np.asarray(v, float) for k, v in flow.monitors.items()}
    cls = flow.classification
    values = {k: float(v[-1]) for k, v in monitors.items()}
    if flow.status == "oscillating" and cls is not None:
        values = {k: cls.mean[k] for k in monitors}
    return {"iterations": flow.iterations, "status": flow.status, "reason": flow.message, "values": values,
            "amplitude": None if cls is None else cls.amplitude, "period": None if cls is None else cls.period,
            "ms_per_iteration": 1e3 * flow.wall_time / max(flow.iterations, 1), "solve_s": flow.wall_time}


# ------------------------------------------------------------------------------------------------ one blade
def compare(name: str, config, items: list[str], of_iterations: int, work: Path, run_of: bool) -> dict:
    """Mesh once, OpenFOAM (cached) and millfoil on it; the record of one blade and variant (``config``
    carries the variant's ``solver:`` keys, ``items`` the whole ``--mf-set`` list)."""
    from optimizer.pipeline import StageFailure, _meshes, blade_profile

    level = config.mesh.level
    record = {"blade": name, "level": level, "variant": variant_name(items), "mf_set": items,
              "parameters": config.blade.blade_spec().values if hasattr(config.blade, "blade_spec") else None}
    try:
        profile = blade_profile(config)
        _, fvmesh = _meshes(config, profile)
    except StageFailure as f:
        return record | {"error": f"{f.stage}: {f.status}: {f.reason}"}
    q_c = 0.5 * config.flow.density * config.flow.speed**2 * profile.chord
    record |= {"cells": fvmesh.n_cells, "chord": profile.chord, "q_c": q_c}
    sst = split_variant(items)[1]
    record["openfoam"] = (openfoam_run(config, fvmesh, work / level / name, of_iterations) if run_of
                          else {"error": "OpenFOAM not run"})
    record["openfoam"].pop("history", None)
    record["millfoil"] = millfoil_run(config, fvmesh, sst)
    return record


def differences(rec: dict) -> dict | None:
    """Relative differences millfoil / OpenFOAM - 1 of F_Y and C_max, and whether the classes agree."""
    of, mf = rec.get("openfoam", {}), rec.get("millfoil", {})
    if "values" not in of or "values" not in mf:
        return None
    fy = mf["values"]["fy:blade"] / of["values"]["fy:blade"] - 1.0
    cm = mf["values"]["c_max"] / of["values"]["c_max"] - 1.0
    return {"d_lift": fy, "d_cmax": cm, "same_class": mf["status"] == of["status"],
            "both_settled": mf["status"] in SETTLED and of["status"] in SETTLED}


# ----------------------------------------------------------------------------------------------- reporting
HEAD = ("| blade | cells | C_L OF | C_L mf | ΔC_L | C_max OF (m/s) | C_max mf | ΔC_max | class OF | class mf "
        "| it OF / mf | solve s OF / mf |")


def row(rec: dict) -> str:
    if "error" in rec:
        return f"| {rec['blade']} | — | {rec['error']} |" + " |" * 10
    of, mf, d = rec["openfoam"], rec["millfoil"], differences(rec)
    if d is None:
        return f"| {rec['blade']} | {rec['cells']} | {of.get('error', '')} |" + " |" * 10

    def cls(r):
        amp = (r.get("amplitude") or {}).get("fy:blade")
        extra = f" (±{abs(amp / r['values']['fy:blade']):.1%})" if r["status"] == "oscillating" and amp else ""
        return r["status"] + extra

    return (f"| {rec['blade']} | {rec['cells']} | {of['values']['fy:blade'] / rec['q_c']:.4f} | "
            f"{mf['values']['fy:blade'] / rec['q_c']:.4f} | {d['d_lift']:+.2%} | {of['values']['c_max']:.3f} | "
            f"{mf['values']['c_max']:.3f} | {d['d_cmax']:+.2%} | {cls(of)} | {cls(mf)} | "
            f"{of['iterations']} / {mf['iterations']} | {of['solve_s']:.0f} / {mf['solve_s']:.0f} |")


def summary(records: list[dict]) -> str:
    """Counts against the criteria over the blades that settle (converged or oscillating) under both codes."""
    diffs = [(r, differences(r)) for r in records if "error" not in r]
    both = [(r, d) for r, d in diffs if d is not None and d["both_settled"]]
    lift = sum(abs(d["d_lift"]) <= LIFT_TOL for _, d in both)
    cmax = sum(abs(d["d_cmax"]) <= CMAX_TOL for _, d in both)
    same = sum(d["same_class"] for _, d in both)
    alls = sum(abs(d["d_lift"]) <= LIFT_TOL and abs(d["d_cmax"]) <= CMAX_TOL and d["same_class"] for _, d in both)
    not_both = [f"{r['blade']} (OF {r['openfoam'].get('status')}, mf {r['millfoil'].get('status')})"
                for r, d in diffs if d is not None and not d["both_settled"]]
    dl = [abs(d["d_lift"]) for _, d in both] or [float("nan")]
    dc = [abs(d["d_cmax"]) for _, d in both] or [float("nan")]
    return (f"{len(records)} blades, {len(both)} settle under both codes: lift within {LIFT_TOL:.1%} "
            f"{lift}/{len(both)}, C_max within {CMAX_TOL:.0%} {cmax}/{len(both)}, same class {same}/{len(both)}, "
            f"all three {alls}/{len(both)}; |ΔC_L| median {np.median(dl):.2%} max {max(dl):.2%}, |ΔC_max| median "
            f"{np.median(dc):.2%} max {max(dc):.2%}"
            + (f"; not settled under both: {', '.join(not_both)}" if not_both else ""))


def report(records: list[dict]) -> None:
    by = defaultdict(dict)
    for r in records:
        by[(r["level"], r["variant"])][r["blade"]] = r       # the last record of a blade and variant
    for (level, variant), blades in by.items():
        recs = list(blades.values())
        print(f"\n### {level}, millfoil {variant}\n\n{HEAD}\n|" + " --- |" * 12)
        for r in recs:
            print(row(r))
        for label, group in (("random blades", [r for r in recs if r["blade"].startswith("random")]),
                             ("paper blades", [r for r in recs if not r["blade"].startswith("random")])):
            if group:
                print(f"\n{label}: {summary(group)}")


def read_records(paths: list[Path]) -> list[dict]:
    return [json.loads(line) for p in paths if p.exists() for line in p.read_text().splitlines() if line.strip()]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--paper", nargs="*", default=["table4", "table5"], choices=["table4", "table5"])
    parser.add_argument("--random", type=int, default=10, help="first N random Table 6 blades (seed 2013)")
    parser.add_argument("--indices", nargs="+", type=int, default=None,
                        help="these random blades (indices of the draw) instead of the first --random")
    parser.add_argument("--level", default="medium", choices=["coarse", "medium", "fine"])
    parser.add_argument("--of-iterations", type=int, default=1500, help="simpleFoam iterations")
    parser.add_argument("--mf-set", action="append", default=[], metavar="KEY=VALUE",
                        help="millfoil solver: key or SST field (repeatable), e.g. omega_production=limited")
    parser.add_argument("--work", type=Path, default=ROOT / "runs" / "bench_blades_openfoam")
    parser.add_argument("--out", type=Path, default=None, help="JSON lines file (appended)")
    parser.add_argument("--report", nargs="+", type=Path, default=None, help="summarise these record files")
    parser.add_argument("--no-install", action="store_true")
    args = parser.parse_args()
    if args.report:
        report(read_records(args.report))
        return
    why = ensure_openfoam(not args.no_install)
    print(f"# {platform.node()}, load average {os.getloadavg()[0]:.1f}, "
          f"OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS')}, {time.strftime('%Y-%m-%d %H:%M')}; "
          f"OpenFOAM: {why or 'ok'}; millfoil {variant_name(args.mf_set)}", flush=True)
    print(f"{HEAD}\n|" + " --- |" * 12, flush=True)
    records = []
    indices = args.indices if args.indices is not None else list(range(args.random))
    for name, config in blade_configs(args.paper, indices, args.level, split_variant(args.mf_set)[0]):
        rec = compare(name, config, args.mf_set, args.of_iterations, args.work, why is None)
        rec |= {"time": time.strftime("%Y-%m-%d %H:%M"), "load": round(os.getloadavg()[0], 1),
                "machine": platform.node()}
        records.append(rec)
        if args.out:
            args.out.parent.mkdir(parents=True, exist_ok=True)
            with args.out.open("a") as fh:
                fh.write(json.dumps(rec, default=str) + "\n")
        print(row(rec), flush=True)
    print(f"\n{summary(records)}")


if __name__ == "__main__":
    main()
