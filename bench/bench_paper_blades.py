"""The paper's worked examples in the paper's flow: mesh convergence and domain-size sensitivity.

Evaluates the Table 4 design blade (C2) and the Table 5 tool-path blade (G1, R = 5 mm) at C0 = 10 m/s,
water, 5 % inlet turbulence, k-ω SST, symmetry top and bottom (the embedded flow and solver defaults),
and prints per run: cells, F_X and F_Y (N/m and N for the 4 mm span), C_L (Eq. 23), C_max, C_p,min,
y+ max, the solver's status (with the lift amplitude for ``oscillating`` runs), iterations and times.

    OMP_NUM_THREADS=1 python bench/bench_paper_blades.py --levels coarse medium fine
    OMP_NUM_THREADS=1 python bench/bench_paper_blades.py --levels coarse --domains 2:5:5 5:10:5 10:20:10
    OMP_NUM_THREADS=1 python bench/bench_paper_blades.py --blades table4 --levels fine --max-iter 6000 \
        --history runs/paper_blades
    OMP_NUM_THREADS=1 python bench/bench_paper_blades.py --blades bench_g1 --domains 1:10:5 \
        --levels coarse medium fine --max-iter 6000

``--max-iter`` overrides ``solver.max_iter`` (the fine mesh needs more outer iterations than the default
2 000); ``--history DIR`` writes each run's monitors (lift, drag, C_max per iteration) as CSV.

A domain ``H:D:U`` sets ``mesh.half_height`` H, ``mesh.downstream`` D and ``mesh.upstream`` U (chords);
the default domain is 5:10:5.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from optimizer.config import load_config
from optimizer.pipeline import evaluate

#: ``bench_g1`` is the attached benchmark blade (its own channel: use ``--domains 1:10:5``), the
#: mesh-convergence check for a flow that settles.
BLADES = {"table4": "configs/examples/table4_c2_design.yaml", "table5": "configs/examples/table5_g1_toolpath.yaml",
          "bench_g1": "configs/examples/bench_g1_design.yaml"}


def one(blade: str, level: str, domain: str, max_iter: int = 0, history: Path | None = None) -> dict:
    h, d, u = domain.split(":")
    overrides = [f"mesh.level={level}", f"mesh.half_height={h}", f"mesh.downstream={d}", f"mesh.upstream={u}"]
    if max_iter:
        overrides.append(f"solver.max_iter={max_iter}")
    config = load_config(BLADES[blade], overrides)
    t0 = time.perf_counter()
    ev = evaluate(config)
    if history is not None and ev.artifacts.flow is not None:
        write_history(ev.artifacts.flow.monitors, history / f"{blade}_{level}_{domain.replace(':', '-')}.csv")
    row = {"blade": blade, "level": level, "domain": domain, "seconds": time.perf_counter() - t0,
           **ev.summary()}
    cls = ev.classification
    amp = None if cls is None else (cls.amplitude or {}).get("fy:blade")
    per = None if cls is None else (cls.period or {}).get("fy:blade")
    fy = ev.fy if ev.fy is not None else float("nan")
    print(f"{blade:6s} {level:6s} {domain:8s} {str(ev.cells):>6s} cells  F_X {ev.fx!s:>10.10s} N/m  "
          f"F_Y {fy:10.1f} N/m ({ev.fy_span!s:.8s} N)  C_L {ev.c_l!s:.7s}  C_max {ev.c_max!s:.7s}  "
          f"Cp_min {ev.cp_min!s:.7s}  y+max {ev.yplus_max!s:.5s}  {ev.status} "
          f"(F_Y amplitude {amp!s:.8s}, period {per!s:.6s})  {ev.iterations} it, solve "
          f"{ev.seconds.get('solve', 0):.0f} s", flush=True)
    return row


def write_history(monitors: dict, path: Path) -> None:
    """The monitors (one column each, one row per outer iteration) as CSV."""
    path.parent.mkdir(parents=True, exist_ok=True)
    names = sorted(monitors)
    columns = np.column_stack([np.asarray(monitors[n], dtype=float) for n in names])
    np.savetxt(path, columns, delimiter=",", header=",".join(names), comments="")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blades", nargs="+", default=["table4", "table5"], choices=list(BLADES))
    ap.add_argument("--levels", nargs="+", default=["coarse", "medium"])
    ap.add_argument("--domains", nargs="+", default=["5:10:5"])
    ap.add_argument("--max-iter", type=int, default=0, help="override solver.max_iter (0: config default)")
    ap.add_argument("--history", type=Path, default=None, help="folder for per-run monitor CSVs")
    ap.add_argument("--out", default=None, help="JSON lines file for the records")
    a = ap.parse_args()
    rows = [one(b, lv, dom, a.max_iter, a.history) for b in a.blades for lv in a.levels for dom in a.domains]
    if a.out:
        with open(a.out, "w") as fh:
            for r in rows:
                fh.write(json.dumps(r, default=str) + "\n")


if __name__ == "__main__":
    main()
