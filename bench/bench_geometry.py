"""Benchmark: time to build a blade profile (design curves and N-buffer machining) and its accuracy.

Prints, for the paper's examples and for random feasible blades of each (mode, continuity), the median
and worst build time, point counts, cutter positions, and the Hausdorff distance of the machined profile
to the exact envelope (shapely inward buffer of the densely sampled cutter path, as in the tests).

    python bench/bench_geometry.py [--blades 20] [--seed 1]
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parents[1] / "tests" / "geometry"))

from envelope import exact_machined, hausdorff  # noqa: E402

from geometry import BladeSpec, ParameterSpace, build_profile  # noqa: E402
from geometry.blade import tool_path_pieces  # noqa: E402
from geometry.draws import draw_feasible  # noqa: E402
from geometry.examples import TABLE4_C2_DESIGN, TABLE5_G1_TOOLPATH  # noqa: E402


def timed_build(spec, repeat=5):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        profile = build_profile(spec)
        times.append(time.perf_counter() - start)
    return profile, min(times)


def describe(name, spec):
    profile, seconds = timed_build(spec)
    line = (f"{name:22s} {seconds * 1e3:7.1f} ms  {len(profile.points):4d} pts  area {profile.area * 1e6:8.2f} mm²"
            f"  t_max {profile.max_thickness * 1e3:6.3f} mm")
    if profile.machining is not None:
        error = hausdorff(profile.points, exact_machined(tool_path_pieces(profile.curves), spec["R"]))
        line += f"  cutters {profile.machining.cutter_positions:5d}  deviation {error * 1e6:.3f} µm"
    print(line)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blades", type=int, default=20, help="feasible random blades per combination")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    print(f"# {platform.processor() or platform.machine()}, Python {platform.python_version()}, "
          f"numpy {np.__version__}")
    for name, example in (("table4 C2 design", TABLE4_C2_DESIGN), ("table5 G1 toolpath", TABLE5_G1_TOOLPATH)):
        describe(name, BladeSpec.from_values(example["mode"], example["continuity"], example["parameters"]))
    print(f"\n{'combination':16s} {'feasible':>9s} {'median':>9s} {'worst':>9s} {'worst dev':>10s}")
    rng = np.random.default_rng(args.seed)
    for mode in ("design", "toolpath"):
        for continuity in ("G0", "G1", "C1", "G2", "C2"):
            space = ParameterSpace.default(mode, continuity)
            times, deviation, tried, found = [], 0.0, 0, 0
            while found < args.blades and tried < 200 * args.blades:
                spec, result, draws = draw_feasible(space, rng, 200 * args.blades - tried)
                tried += draws
                if spec is None:
                    break
                found += 1
                _, seconds = timed_build(spec, repeat=1)
                times.append(seconds)
                if mode == "toolpath":
                    exact = exact_machined(tool_path_pieces(result.profile.curves), spec["R"])
                    deviation = max(deviation, hausdorff(result.profile.points, exact))
            timing = (f" {np.median(times) * 1e3:7.1f}ms {max(times) * 1e3:7.1f}ms" if times
                      else f" {'—':>9s} {'—':>9s}")             # no feasible blade within the draws
            print(f"{mode + ' ' + continuity:16s} {found:4d}/{tried:<5d}{timing} {deviation * 1e6:8.3f}µm")


if __name__ == "__main__":
    main()
