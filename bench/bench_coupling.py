"""Pressure-velocity coupling and pressure linear solver, compared on DFG 2D-1 (Schäfer–Turek, Re = 20).

Runs the cylinder case at one mesh level with SIMPLEC (alpha_p = 1) and SIMPLE (alpha_u = 0.7, alpha_p = 0.3),
with the pressure correction solved by AMG-preconditioned CG (and SIMPLEC with Gauss-Seidel sweeps); prints outer
iterations, seconds per iteration, time to convergence and the drag error.

    python bench/bench_coupling.py --level medium
"""

from __future__ import annotations

import argparse
import time

from solver.linalg import SolverSettings
from solver.validation.cylinder import coefficients, cylinder_settings, errors, run_cylinder

VARIANTS = {
    "SIMPLEC + AMG-CG": dict(algorithm="simplec", alpha_p=1.0),
    "SIMPLE + AMG-CG": dict(algorithm="simple", alpha_u=0.7, alpha_p=0.3),  # the usual alpha_u + alpha_p = 1
    "SIMPLEC + Gauss-Seidel": dict(algorithm="simplec", alpha_p=1.0,
                                   pressure_solver=SolverSettings("gauss_seidel", 0.05, 50)),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--level", default="medium", choices=["coarse", "medium", "fine"])
    parser.add_argument("--max-iter", type=int, default=3000)
    args = parser.parse_args()
    print(f"{'variant':24s} {'status':14s} {'iterations':>10s} {'ms/iter':>8s} {'seconds':>8s} {'C_D error %':>11s}")
    for name, options in VARIANTS.items():
        start = time.perf_counter()
        res = run_cylinder(args.level, cylinder_settings(max_iter=args.max_iter, **options))
        seconds = time.perf_counter() - start
        results = res[0] if isinstance(res, tuple) else res
        err = 100 * errors(coefficients(results))["C_D"]
        print(f"{name:24s} {results.status:14s} {results.iterations:10d} "
              f"{1e3 * results.wall_time / max(results.iterations, 1):8.1f} {seconds:8.1f} {err:11.3f}")


if __name__ == "__main__":
    main()
