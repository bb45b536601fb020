"""Time per SIMPLE outer iteration of the benchmark blade, and where it goes (figures, not assertions).

Builds the benchmark blade's problem (``configs/examples/bench_g1_design.yaml``: geometry, gmsh mesh, SST
at the configured settings) at each ``--levels`` level, runs ``--iterations`` outer iterations from the
free stream, and prints the CPU milliseconds per iteration of this process (``time.process_time``, which
the load of other jobs inflates far less than the wall clock) after ``--skip`` warm-up iterations (the
first ones build the cached sparse operators and compile the kernels), and the breakdown per part:
exclusive CPU time of the solver functions that one iteration calls (a function's time without the timed
functions it calls), linear solves by solver name.

    OMP_NUM_THREADS=1 python bench/bench_iteration.py --levels coarse medium --iterations 150
"""

from __future__ import annotations

import argparse
import functools
import os
import platform
import statistics
import sys
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).parents[1]
sys.path.insert(0, str(ROOT))

BENCHMARK = ROOT / "configs" / "examples" / "bench_g1_design.yaml"


class Timers:
    """Exclusive CPU time per label: a stack of running timers, each charged its own time only."""

    def __init__(self):
        self.reset()

    def reset(self):
        self.total = defaultdict(float)
        self.calls = defaultdict(int)
        self.stack: list[list] = []         # [label, start, time spent in nested timers]
        self.on = False

    def wrap(self, label, fn):
        @functools.wraps(fn)
        def timed(*args, **kwargs):
            if not self.on:
                return fn(*args, **kwargs)
            name = label(*args) if callable(label) else label
            self.stack.append([name, time.process_time(), 0.0])
            try:
                return fn(*args, **kwargs)
            finally:
                name, t0, nested = self.stack.pop()
                spent = time.process_time() - t0
                self.total[name] += spent - nested
                self.calls[name] += 1
                if self.stack:
                    self.stack[-1][2] += spent
        return timed


def instrument(timers: Timers) -> None:
    """Wrap the functions of one outer iteration (in the namespaces that call them) with ``timers``."""
    from solver import linalg, momentum, simple
    from solver.boundary import BoundaryData
    from solver.turbulence import sst

    for name in ("ls_gradient", "convection_gradient", "momentum_viscosity", "momentum_system",
                 "predicted_velocity_flux", "rhie_chow_flux", "mass_imbalance", "pressure_correction_system",
                 "correct_flux", "turbulence_step", "update_monitors", "check_finite"):
        setattr(simple, name, timers.wrap(name, getattr(simple, name)))
    for name in ("ls_gradient", "convection_gradient", "scalar_system", "face_diffusivity"):
        setattr(sst, name, timers.wrap(name, getattr(sst, name)))
    for name in ("velocity", "pressure"):
        setattr(BoundaryData, name, timers.wrap(f"boundary {name}", getattr(BoundaryData, name)))
    if hasattr(momentum.MomentumSystem, "solve"):
        momentum.MomentumSystem.solve = timers.wrap("linear solve: momentum (u, v)", momentum.MomentumSystem.solve)
    linalg.LinearSystem.residual_norms = timers.wrap("residual_norms", linalg.LinearSystem.residual_norms)
    linalg.SolverSettings.solve = timers.wrap(lambda s, *a: f"linear solve: {s.name}", linalg.SolverSettings.solve)
    simple.outer_iteration = timers.wrap("outer_iteration (rest)", simple.outer_iteration)


#: The one set of timers the instrumented functions charge (reset per level).
TIMERS = Timers()


def blade_problem(level: str):
    """The benchmark blade's problem, settings and free-stream state at ``level``."""
    from optimizer import pipeline
    from optimizer.config import load_config
    from solver import Fluid, Problem
    from solver.problem import initial_state

    cfg = load_config(str(BENCHMARK), [f"mesh.level={level}"])
    _, fv = pipeline._meshes(cfg, pipeline.blade_profile(cfg))
    problem = Problem.create(fv, pipeline.boundary_conditions(cfg), Fluid(cfg.flow.density, cfg.flow.viscosity),
                             turbulence=pipeline.turbulence_model(cfg))
    return problem, pipeline.simple_settings(cfg), initial_state(problem, (cfg.flow.speed, 0.0))


def run(level: str, iterations: int, skip: int) -> None:
    import dataclasses

    from solver import solve_steady

    problem, settings, state = blade_problem(level)
    settings = dataclasses.replace(settings, max_iter=iterations, early_classify=False, stall_tol=None)
    timers = TIMERS
    timers.reset()
    marks = {}

    def callback(it, res, s):
        marks[it] = time.process_time()
        timers.on = it >= skip

    c0 = time.process_time()
    res = solve_steady(problem, settings, state, callback=callback)
    n = res.iterations - skip
    per_it = 1e3 * (marks[res.iterations] - marks[skip]) / n
    print(f"\n{level}: {problem.mesh.n_cells} cells, {res.iterations} iterations ({res.status}), "
          f"CPU {time.process_time() - c0:.2f} s; first {skip} iterations {1e3 * (marks[skip] - c0) / skip:.1f} ms"
          " each (set-up, JIT)")
    windows = [(marks[i + 10] - marks[i]) / 10 for i in range(skip, res.iterations - 9, 10)]
    print(f"  CPU per iteration (iterations {skip + 1}..{res.iterations}): {per_it:.1f} ms; over windows of 10"
          f" iterations (one AMG set-up each): min {1e3 * min(windows):.1f}, median"
          f" {1e3 * statistics.median(windows):.1f} ms (the minimum is the least disturbed by other jobs)")
    timed = sum(timers.total.values())
    print(f"  {'part (exclusive)':38s} {'ms/it':>7s} {'share':>6s} {'calls/it':>8s}")
    for name, t in sorted(timers.total.items(), key=lambda kv: -kv[1]):
        print(f"  {name:38s} {1e3 * t / n:7.2f} {100 * t / timed:5.1f}% {timers.calls[name] / n:8.1f}")
    print(f"  {'(timed total)':38s} {1e3 * timed / n:7.2f}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--levels", nargs="+", default=["coarse", "medium"])
    ap.add_argument("--iterations", type=int, default=150)
    ap.add_argument("--skip", type=int, default=10, help="warm-up iterations left out of the figures")
    args = ap.parse_args(argv)
    instrument(TIMERS)
    print(f"bench_iteration: {platform.node()} {platform.processor() or platform.machine()}, "
          f"python {platform.python_version()}, OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS')}, "
          f"load average {os.getloadavg()[0]:.2f}, {time.strftime('%Y-%m-%d %H:%M')}")
    for level in args.levels:
        run(level, args.iterations, args.skip)


if __name__ == "__main__":
    main()
