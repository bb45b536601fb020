"""Speed of one blade evaluation (k-ω SST) on the benchmark blade, cold and warm started.

The paper's Table 4/5 blades stall (no steady state), so speed is measured on a lifting blade of the
Table 6 space that a steady solver settles on: ``configs/examples/bench_g1_design.yaml``. Prints, for a
cold start (uniform free stream) and a warm start (the solution of another blade of the space — the
paper's mid-range blade, §3.2 — transferred to this mesh):

* cells, iterations, time per iteration (s), total solve time (s), the solver's status;
* time to converged lift: the solve time until F_Y stays within 0.5 % of its final value (iterations to
  that point × time per iteration), and the same for C_max;
* peak resident memory of the process (MB, ``ru_maxrss``).

    OMP_NUM_THREADS=1 python bench/bench_blade.py --level medium
"""

from __future__ import annotations

import argparse
import platform
import resource
import time

import numpy as np

from optimizer.config import load_config
from optimizer.pipeline import evaluate

#: The warm-start donor: the middle of the Table 6 G1 design ranges (the paper's initial solution).
DONOR = ["alpha=10", "beta1=5", "beta1bar=25", "u_s2=0.18", "u_p2=0.18", "d_s1=0.0065", "d_p1=0.0065",
         "d_s2=0.01", "d_p2=0.01", "d_s3=0.035", "d_p3=0.035"]


def settle_iteration(history: np.ndarray, rel: float = 0.005) -> int:
    """First iteration (1-based) from which ``history`` stays within ``rel`` of its last value."""
    final = history[-1]
    outside = np.flatnonzero(np.abs(history - final) > rel * max(abs(final), 1e-300))
    return int(outside[-1] + 2) if outside.size else 1


def run(config, label: str, warm_start=None):
    t0 = time.perf_counter()
    ev = evaluate(config, warm_start=warm_start)
    wall = time.perf_counter() - t0
    flow = ev.artifacts.flow
    if flow is None or not ev.ok:
        print(f"{label}: {ev.status} at {ev.stage}: {ev.message}")
        return ev
    per_it = flow.wall_time / max(flow.iterations, 1)
    it_fy = settle_iteration(flow.monitors["fy:blade"])
    it_c = settle_iteration(flow.monitors["c_max"])
    print(f"{label}: {ev.cells} cells, {flow.iterations} iterations, {per_it * 1e3:.1f} ms/iteration, solve "
          f"{flow.wall_time:.1f} s (evaluation {wall:.1f} s), status {ev.status}")
    print(f"  F_Y {ev.fy:.2f} N/m, C_L {ev.c_l:.4f}, C_max {ev.c_max:.4f} m/s, y+ max {ev.yplus_max}")
    print(f"  lift within 0.5 % of final from iteration {it_fy} ({it_fy * per_it:.1f} s); "
          f"C_max from iteration {it_c} ({it_c * per_it:.1f} s)")
    return ev


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default="configs/examples/bench_g1_design.yaml")
    ap.add_argument("--level", default="medium", choices=["coarse", "medium", "fine"])
    ap.add_argument("--no-warm", action="store_true", help="skip the warm-start run")
    a = ap.parse_args()
    print(f"{platform.node()} {platform.machine()}, level {a.level}, {a.config}")
    config = load_config(a.config, values={"mesh.level": a.level})
    run(config, "cold start")
    if not a.no_warm:
        donor = evaluate(load_config(a.config, DONOR, values={"mesh.level": a.level}))
        print(f"donor (Table 6 mid-range G1 blade): {donor.status}, {donor.iterations} iterations, "
              f"solve {donor.seconds.get('solve', 0):.1f} s")
        if donor.artifacts.flow is not None and donor.ok:
            run(config, "warm start", warm_start=donor.artifacts.flow)
    print(f"peak memory {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")


if __name__ == "__main__":
    main()
