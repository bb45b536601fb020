"""``millfoil mesh``: the pipeline's geometry and mesh stages for one blade, with the mesh's figures."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from optimizer.cli.common import EXIT_FAILED, EXIT_INFEASIBLE, EXIT_OK, config_arguments, level_argument, load
from optimizer.pipeline import StageFailure, blade_mesh, blade_profile
from optimizer.saving import MESH_SUFFIXES, PLOT_SUFFIXES, check_output_file, write_all


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``mesh`` command."""
    mesh = sub.add_parser(
        "mesh",
        help="mesh the fluid around one blade and report cell counts and quality",
        description="Build the hybrid mesh around one blade: a structured O-layer of quads between the blade "
        "and the convex hull of its offset, triangles from there to the rectangular domain. Prints cell "
        "counts and quality figures; fails (exit 4) if a cell is below the quality thresholds (minimum angle "
        "15°, scaled Jacobian 0.4), naming the worst cells.",
        epilog="Examples:\n"
        "  millfoil mesh --level coarse --plot mesh.png\n"
        "  millfoil mesh configs/examples/table5_g1_toolpath.yaml --out mesh.msh --set mesh.upstream=8\n"
        "Mesh options (the 'mesh:' section): docs/explanation/meshing.md.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    config_arguments(mesh)
    level_argument(mesh)
    mesh.add_argument("--out", type=Path, metavar="FILE",
                      help=f"write the mesh: .msh (gmsh 2.2), or {', '.join(MESH_SUFFIXES[1:])} (meshio)")
    mesh.add_argument("--plot", type=Path, metavar="PNG", help="write a figure: O-layer, leading and trailing edge")
    mesh.add_argument("--json", action="store_true", help="print the summary as JSON")
    mesh.set_defaults(run=run_mesh)


def run_mesh(args: argparse.Namespace) -> int:
    config = load(args)
    outputs = {"file": args.out and check_output_file(args.out, "--out", MESH_SUFFIXES),
               "plot": args.plot and check_output_file(args.plot, "--plot", PLOT_SUFFIXES)}
    try:
        profile = blade_profile(config)
    except StageFailure as failure:
        if failure.status != "infeasible":
            print(f"millfoil: {failure.reason}", file=sys.stderr)
            return EXIT_FAILED
        for violated in failure.details:
            print(f"millfoil: infeasible blade: {violated}", file=sys.stderr)
        return EXIT_INFEASIBLE
    mesh_spec = config.mesh_spec()
    try:
        mesh, report = blade_mesh(config, profile)
    except StageFailure as failure:
        print(f"millfoil: mesh failed: {'; '.join(failure.details) or failure.reason}", file=sys.stderr)
        return EXIT_FAILED
    summary = {"level": mesh_spec.level, "points": mesh.n_points, **mesh.cell_counts(), "cells": mesh.n_cells,
               "first_cell_height_m": mesh.info["first_cell_height"], "layers": mesh.info["layers"],
               "seconds": mesh.info["time_total"], "quality": report.summary()}
    write_all(_mesh_files(mesh, profile, **outputs))
    summary.update({key: str(path) for key, path in outputs.items() if path})
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(_describe_mesh(summary, mesh_spec, profile.chord))
    return EXIT_OK


def _mesh_files(mesh, profile, file: Path | None, plot: Path | None) -> list:
    """The ``(path, write)`` pairs of the asked-for outputs (written together: both or neither)."""
    files = [(file, mesh.write)] if file else []
    if plot:
        from meshing import plot_mesh  # matplotlib is slow to import; only when asked

        files.append((plot, lambda path: plot_mesh(mesh, path, profile)))
    return files


def _describe_mesh(summary: dict, mesh_spec, chord: float) -> str:
    q = summary["quality"]
    lines = [f"{mesh_spec.level} mesh: {summary['cells']} cells ({summary['quad']} quads, {summary['triangle']} "
             f"triangles), {summary['points']} nodes, built in {summary['seconds']:.2f} s",
             f"O-layer: {summary['layers']} layers, first cell {summary['first_cell_height_m'] * 1e6:.2f} µm "
             f"(y+ {mesh_spec.y_plus:g} at Re {mesh_spec.reynolds(chord):.3g})",
             f"quality: min angle {q['min_angle_min']:.1f}° (threshold 15°), scaled Jacobian "
             f"{q['scaled_jacobian_min']:.3f} (threshold 0.4), max aspect ratio {q['aspect_ratio_max']:.3g}, "
             f"max skewness {q['skewness_max']:.3f}, non-orthogonality max {q['non_orthogonality_max']:.1f}° "
             f"mean {q['non_orthogonality_mean']:.1f}°"]
    lines += [f"wrote {summary[key]}" for key in ("file", "plot") if key in summary]
    return "\n".join(lines)
