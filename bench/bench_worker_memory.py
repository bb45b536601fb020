"""One evaluation as a campaign's dask worker runs it, with and without the worker's malloc settings.

dask's nanny starts every worker process with ``MALLOC_TRIM_THRESHOLD_=65536``. Each run here is a fresh
process started with that variable, which evaluates the benchmark blade of
``configs/examples/bench_g1_design.yaml`` (``--level``, default medium) as ``millfoil evaluate`` does,
either as it is (``dask default``) or after :func:`optimizer.campaign.record.keep_freed_memory`, which a
campaign's worker function calls before its first evaluation (``millfoil worker``); a third run has no
variable at all (``glibc default``: ``millfoil evaluate`` started from a shell). Printed per run: wall
seconds, user and system CPU seconds, and minor page faults (each a page the kernel mapped and zeroed).
The runs alternate, so a load on the machine meets each alike.

    python bench/bench_worker_memory.py                  # medium, 2 repeats
    python bench/bench_worker_memory.py --level coarse --repeats 3
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
from datetime import UTC, datetime
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "examples" / "bench_g1_design.yaml"
VARIANTS = {
    "dask default": ({"MALLOC_TRIM_THRESHOLD_": "65536"}, False),
    "millfoil worker": ({"MALLOC_TRIM_THRESHOLD_": "65536"}, True),
    "glibc default": ({}, False),
}
CHILD = """
import contextlib, io, json, resource, sys, time
from optimizer.campaign.record import keep_freed_memory
from optimizer.cli import main
if {prepare}:
    assert keep_freed_memory(), "no glibc mallopt here"
t0, r0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_SELF)
with contextlib.redirect_stdout(io.StringIO()):
    assert main(["evaluate", {config!r}, "--level", {level!r}, "--json", "--quiet"]) == 0
r1 = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({{"wall": time.perf_counter() - t0, "user": r1.ru_utime - r0.ru_utime,
                  "system": r1.ru_stime - r0.ru_stime, "faults": r1.ru_minflt - r0.ru_minflt}}))
"""


def run(level: str, env: dict[str, str], prepare: bool) -> dict[str, float]:
    base = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    proc = subprocess.run([sys.executable, "-c", CHILD.format(prepare=prepare, config=str(CONFIG), level=level)],
                          env={**base, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1", **env},
                          capture_output=True, text=True, check=True)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--level", choices=["coarse", "medium", "fine"], default="medium")
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    results: dict[str, list[dict[str, float]]] = {name: [] for name in VARIANTS}
    for _ in range(args.repeats):
        for name, (env, prepare) in VARIANTS.items():
            results[name].append(run(args.level, env, prepare))
    print(f"# one {args.level} evaluation of the benchmark blade; machine {platform.node()}, {os.cpu_count()} "
          f"cores, load {os.getloadavg()[0]:.1f}, {datetime.now(UTC):%Y-%m-%d}; medians of {args.repeats}")
    print("| process | wall s | user CPU s | system CPU s | minor page faults |")
    print("|---|---|---|---|---|")
    for name, rows in results.items():
        m = {k: statistics.median(r[k] for r in rows) for k in rows[0]}
        print(f"| {name} | {m['wall']:.1f} | {m['user']:.1f} | {m['system']:.1f} | {m['faults']:,.0f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
