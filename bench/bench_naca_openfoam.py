"""NACA 0012 at Re 6e6 through stall: millfoil and OpenFOAM simpleFoam + kOmegaSST on the same C-mesh.

For each ``--levels`` level of the validation C-mesh (:mod:`solver.validation.meshes.naca_mesh`) and each
angle of attack, the mesh (with the far-field in/out split of that angle) is written as an OpenFOAM
``polyMesh`` (:mod:`solver.validation.openfoam`; the very same cells) and solved by both codes with the same
conditions (docs/explanation/validation.md, "Matching the conditions"):

* far field: velocity inlet U∞ = (cos α, sin α) on ``farfield_in`` **without** the point-vortex
  correction (``run_naca0012(..., vortex_correction=False)``), p = 0 with zero-gradient velocity on
  ``farfield_out``; TMR freestream k, ω (:func:`solver.validation.naca0012.tmr_freestream`) on the inlet,
  zero gradient on the outlet;
* wall: no slip, k = 0, ω fixed in the wall cells to 6ν/(β₁ y²) (millfoil ``low_re``; OpenFOAM
  ``omegaWallFunction``, which does exactly this below y+ = 11 in v1912), ν_t = 0 at the wall;
* SST-2003 (millfoil) and ``kOmegaSST`` (OpenFOAM v1912, default coefficients = SST-2003 constants);
* linear-upwind U (limited least-squares gradient), first-order upwind k and ω;
* millfoil runs its validation settings through :func:`solver.validation.naca0012.run_naca0012`, stopped when
  C_L changes by less than :data:`CL_REL` of itself over 500 iterations (``--mf-cl-rel``); OpenFOAM runs SIMPLEC
  (``consistent``) with GAMG; the fine level needs ``--of-non-orthogonal 2`` (pressure non-orthogonal
  correctors: the same converged solution, a path that survives the mesh's 53° cells).

Per angle and code it records C_L, C_D (pressure + viscous, along and normal to U∞), C_max = max |u|/U∞ over
the cells, the suction-side separation point (x/c of the first wall face from the leading edge whose
c_f < 0), iterations, seconds, the spread of C_L over the last 200 iterations and the wall C_p and c_f
(per wall face; both codes have the same faces, so the RMS differences are per face). JSON lines to ``--out``.

    OMP_NUM_THREADS=1 python bench/bench_naca_openfoam.py --codes openfoam --levels coarse --out naca.jsonl
    OMP_NUM_THREADS=1 python bench/bench_naca_openfoam.py --codes millfoil --alphas 0 10 --out naca.jsonl
    python bench/bench_naca_openfoam.py --report naca.jsonl        # table + docs/figures/validation/*.png

The harness (case files, runners, records, report, criteria) is :mod:`solver.validation.naca_openfoam`.

``--of-resume`` continues an OpenFOAM case of ``--work`` from its latest written time up to ``--of-iterations`` in
all (a run still moving at its cap); the record joins the stretches.

Restart test (docs/decisions/0007-limiter-iterations.md): ``--mf-start openfoam`` starts
millfoil from OpenFOAM's converged fields of the same level and angle (the case must exist under ``--work``); the
record's code is then ``millfoil...@openfoam``. A converged millfoil solution that differs from OpenFOAM's is then
a difference of the discrete equations, not of the start (hysteresis), and the drift shows which way.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

from solver.validation.naca_openfoam import (
    ALPHAS,
    CL_REL,
    criteria,
    load_records,
    non_negative,
    plot,
    report,
    run_millfoil,
    run_openfoam,
    variant_name,
)
from solver.validation.openfoam import ensure_openfoam

ROOT = Path(__file__).parents[1]
FIGURES = ROOT / "docs" / "figures" / "validation"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--levels", nargs="+", default=["coarse"])
    parser.add_argument("--alphas", nargs="+", type=float, default=list(ALPHAS))
    parser.add_argument("--codes", nargs="+", default=["openfoam", "millfoil"], choices=["openfoam", "millfoil"])
    parser.add_argument("--of-iterations", type=int, default=8000, help="simpleFoam iteration cap")
    parser.add_argument("--u-gradient", default="Gauss linear", help="OpenFOAM gradient of linearUpwind U "
                        "(e.g. 'cellLimited<Venkatakrishnan> Gauss linear 1')")
    parser.add_argument("--gradient", default="Gauss linear", help="OpenFOAM gradSchemes default: every other "
                        "gradient (e.g. 'pointCellsLeastSquares', 'Gauss pointLinear', 'cellMDLimited Gauss linear 1')")
    parser.add_argument("--interpolation", default="linear", help="OpenFOAM interpolationSchemes default: the face "
                        "values of HbyA and rAU in the flux (e.g. 'skewCorrected linear')")
    parser.add_argument("--of-code", default="openfoam", help="code name of the OpenFOAM records (experiments: "
                        "e.g. openfoam[gradient=leastSquares]; the report's table compares millfoil with 'openfoam')")
    parser.add_argument("--of-alpha-u", type=float, default=0.9, help="simpleFoam U relaxation (SIMPLEC)")
    parser.add_argument("--of-non-orthogonal", type=non_negative(int), default=0, metavar="N",
                        help="simpleFoam pressure non-orthogonal correctors (the fine mesh needs 2)")
    parser.add_argument("--of-resume", action="store_true",
                        help="continue an existing OpenFOAM case under --work from its latest written time up to "
                             "--of-iterations in all (a run that was still moving at its cap)")
    parser.add_argument("--mf-iterations", type=int, default=12000, help="millfoil iteration cap")
    parser.add_argument("--mf-cl-rel", type=non_negative(float), default=CL_REL, metavar="R",
                        help="millfoil stop test: the C_L change over its 500-iteration window relative to C_L "
                             "(0: the validation case's absolute 5e-4)")
    parser.add_argument("--mf-variant", nargs="*", default=[], metavar="KEY=VALUE",
                        help="millfoil experiment: limiter=none, face_interpolation=linear, ... (run_millfoil)")
    parser.add_argument("--mf-start", choices=["potential", "openfoam"], default="potential",
                        help="millfoil start: potential flow (validation) or OpenFOAM's converged fields (restart)")
    parser.add_argument("--mf-seconds", type=float, default=None, help="millfoil wall-time cap per angle")
    parser.add_argument("--work", type=Path, default=ROOT / "runs" / "bench_naca_openfoam",
                        help="cases and states; a millfoil run resumes WORK/LEVEL/alphaA/CODE_state.npz where one "
                        "exists (whatever code version wrote it: the run must meet the convergence test again; "
                        "the record's iterations_this_run says how far it went), delete it to start afresh")
    parser.add_argument("--out", type=Path, default=None, help="JSON lines file (appended)")
    parser.add_argument("--report", nargs="+", type=Path, default=None, help="JSONL files: print table, plot")
    parser.add_argument("--report-codes", nargs="+", default=None, metavar="CODE",
                        help="codes of the --report table (default: every code in the files; the figures take theirs)")
    parser.add_argument("--no-install", action="store_true")
    args = parser.parse_args(argv)
    if args.report:
        records = load_records(args.report)
        codes = set(args.report_codes or {k[2] for k in records})
        print(report({k: r for k, r in records.items() if k[2] in codes}))
        print("\n" + criteria(records))
        for path in plot(records, FIGURES):
            print(f"wrote {path.relative_to(ROOT)}")
        return
    why = ensure_openfoam(not args.no_install) if "openfoam" in args.codes else None
    print(f"# load average {os.getloadavg()[0]:.1f}, OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS')}, "
          f"{time.strftime('%Y-%m-%d %H:%M')}; OpenFOAM: {why or 'ok'}", flush=True)
    for level in args.levels:
        for alpha in args.alphas:
            for code in args.codes:
                case = args.work / level / f"alpha{alpha:g}"
                if code == "openfoam":
                    rec = {"error": why} if why else run_openfoam(case / "openfoam", level, alpha,
                                                                      args.of_iterations, args.u_gradient,
                                                                      args.of_alpha_u, args.gradient,
                                                                      args.interpolation, args.of_non_orthogonal,
                                                                      args.of_resume)
                    code = args.of_code
                else:
                    variant = dict(kv.split("=", 1) for kv in args.mf_variant)
                    from_of = args.mf_start == "openfoam"
                    code = variant_name(variant) + ("@openfoam" if from_of else "")
                    case.mkdir(parents=True, exist_ok=True)
                    rec = run_millfoil(level, alpha, args.mf_iterations, case / f"{code}_state.npz", args.mf_seconds,
                                       variant, case / "openfoam" if from_of else None, args.mf_cl_rel or None)
                rec = {"level": level, "alpha": alpha, "code": code, **rec,
                       "time": time.strftime("%Y-%m-%d %H:%M"), "load": round(os.getloadavg()[0], 1)}
                if args.out:
                    with open(args.out, "a") as fh:
                        fh.write(json.dumps(rec) + "\n")
                print(json.dumps({k: v for k, v in rec.items() if k != "wall"}
                                 | {"x_sep": rec.get("wall", {}).get("x_sep")}), flush=True)


if __name__ == "__main__":
    main()
