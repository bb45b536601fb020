"""Benchmark: steady laminar solver on the lid-driven cavity (Re = 100 by default) vs cell count.

Prints, per mesh, the cell count, mesh + setup time, outer iterations to convergence, time per
iteration (``ms/iter``: wall clock of the solve over its iterations, the first ones' operator set-up and
kernel loading included; ``CPU ms``: this process's CPU time per iteration from iteration 6 on, which
other jobs on the machine inflate far less), time to convergence, the process's peak resident memory, and
the Ghia RMS error.
Meshes: unstructured mixed gmsh meshes (quads for x < 0.5, triangles for x > 0.5).

    python bench/bench_solver.py [--n 56 112] [--re 100] [--max-iter 4000]
    python bench/bench_solver.py --case cylinder --n 12 24 48     # DFG 2D-1, n = cells per cylinder quarter

(``--n 56 112`` gives about 5 000 and 20 000 cells.) BLAS is limited to one thread while iterating.
"""

from __future__ import annotations

import argparse
import platform
import resource
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parents[1]))

from solver import Fluid, Problem, solve_steady  # noqa: E402
from solver.validation.cavity import BOUNDARY_CONDITIONS, cavity_mesh, cavity_settings, compare  # noqa: E402


class CpuClock:
    """``solve_steady`` callback recording this process's CPU time after each iteration: the steady CPU
    time per iteration (:meth:`steady_ms`) leaves out the first iterations, which build the per-mesh
    operators and load the compiled kernels, and is less inflated than the wall clock by other jobs."""

    def __init__(self, skip: int = 5):
        self.skip = skip
        self.marks: dict[int, float] = {}

    def __call__(self, it, res, state):
        self.marks[it] = time.process_time()

    def steady_ms(self) -> float:
        last = max(self.marks, default=0)
        if last <= self.skip:
            return float("nan")
        return 1e3 * (self.marks[last] - self.marks[self.skip]) / (last - self.skip)


def bench(n: int, re: int, max_iter: int, kind: str) -> dict:
    t0 = time.perf_counter()
    mesh = cavity_mesh(n, kind)
    t1 = time.perf_counter()
    problem = Problem.create(mesh, BOUNDARY_CONDITIONS, Fluid(1.0, 1.0 / re))
    t2 = time.perf_counter()
    cpu = CpuClock()
    res = solve_steady(problem, cavity_settings(re, max_iter=max_iter), callback=cpu)
    cmp = compare(res, re)
    return dict(cells=mesh.n_cells, mesh_s=t1 - t0, setup_s=t2 - t1, iterations=res.iterations,
                per_iter_ms=1e3 * res.wall_time / max(res.iterations, 1), solve_s=res.wall_time,
                cpu_ms=cpu.steady_ms(),
                status=res.status, peak_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                rms=cmp.rms)


def bench_cylinder(n_quarter: int, max_iter: int) -> dict:
    """DFG 2D-1 on :func:`solver.validation.meshes.dfg_cylinder` with ``n_quarter`` cells per cylinder quarter
    and the far-field size scaled with it (``h_far = 0.3 / n_quarter`` m); ``rms`` is the C_D error."""
    from solver.validation.cylinder import BOUNDARY_CONDITIONS as CYL_BC
    from solver.validation.cylinder import FLUID, coefficients, cylinder_settings, errors
    from solver.validation.meshes import dfg_cylinder

    t0 = time.perf_counter()
    mesh = dfg_cylinder(n_quarter, h_far=0.3 / n_quarter)
    t1 = time.perf_counter()
    problem = Problem.create(mesh, CYL_BC, FLUID)
    t2 = time.perf_counter()
    cpu = CpuClock()
    res = solve_steady(problem, cylinder_settings(max_iter=max_iter), callback=cpu)
    return dict(cells=mesh.n_cells, mesh_s=t1 - t0, setup_s=t2 - t1, iterations=res.iterations,
                per_iter_ms=1e3 * res.wall_time / max(res.iterations, 1), solve_s=res.wall_time,
                cpu_ms=cpu.steady_ms(),
                status=res.status, peak_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                rms=errors(coefficients(res))["C_D"])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="cavity", choices=("cavity", "cylinder"))
    ap.add_argument("--n", type=int, nargs="+", default=[56, 112])
    ap.add_argument("--re", type=int, default=100, choices=(100, 1000))
    ap.add_argument("--max-iter", type=int, default=4000)
    ap.add_argument("--mesh", default="gmsh_mixed", choices=("gmsh_mixed", "gmsh_tri", "structured"))
    a = ap.parse_args(argv)
    title = "DFG 2D-1 cylinder (last column: C_D error)" if a.case == "cylinder" else \
        f"lid-driven cavity Re = {a.re}, {a.mesh}"
    print(f"# {title}; python {platform.python_version()}, "
          f"{platform.processor() or platform.machine()}")
    print(f"{'cells':>8}{'mesh s':>8}{'setup s':>9}{'iters':>7}{'ms/iter':>9}{'CPU ms':>8}{'solve s':>9}"
          f"{'peak MB':>9}{'C_D err' if a.case == 'cylinder' else 'Ghia rms':>10}  status")
    for n in a.n:
        r = bench_cylinder(n, a.max_iter) if a.case == "cylinder" else bench(n, a.re, a.max_iter, a.mesh)
        print(f"{r['cells']:>8}{r['mesh_s']:>8.2f}{r['setup_s']:>9.3f}{r['iterations']:>7}"
              f"{r['per_iter_ms']:>9.1f}{r['cpu_ms']:>8.1f}{r['solve_s']:>9.1f}{r['peak_mb']:>9.0f}{r['rms']:>10.4%}  "
              f"{r['status']}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
