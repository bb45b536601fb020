"""Where an exported tool path comes from: a stored design of a campaign, or the blade of a configuration.

A stored design is rebuilt from its stored parameters with :mod:`geometry` (milliseconds); what cannot be
machined is refused with the reason: an analytic (test-problem) campaign, a design-mode campaign (its curves
are the blade surface, not a cutter path), and a design whose evaluation failed or is infeasible.
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Sequence
from pathlib import Path

from geometry import BladeSpec, ParameterError, build_profile
from geometry.profile import GeometryError
from optimizer.export.toolpath import ExportError, ToolPath, tool_path_of
from optimizer.report.run import Design, Run


def run_tool_path(run: Run, design: Design) -> tuple[ToolPath, list[str]]:
    """The tool path of a stored design and the header lines that say where it comes from."""
    if run.analytic:
        raise ExportError(f"{run.directory} is an analytic test campaign ({run.config['analytic'].get('problem')}): "
                          "it has no blades to machine")
    if run.mode != "toolpath":
        raise ExportError(f"{run.directory} is a design-mode campaign: its curves are the blade surface, not the "
                          "path of a cutter, and cannot be sent to a machine unchanged; export a tool-path "
                          "campaign's design (blade.mode: toolpath)")
    row = design.row
    if not row.ok:
        raise ExportError(f"design {design.number} ({row.key[:10]}) has status '{row.status}': {row.reason}; only "
                          "evaluated, feasible designs are exported")
    violated = [name for name, g in row.constraints.items() if g > 0.0]
    if violated:
        raise ExportError(f"design {design.number} ({row.key[:10]}) is infeasible: constraint(s) "
                          f"{', '.join(violated)} violated; only feasible designs are exported")
    try:
        spec = BladeSpec.from_values(run.mode, run.continuity, row.parameters)
        build_profile(spec)           # the stored design must still build with this millfoil
    except (ParameterError, GeometryError) as exc:
        raise ExportError(f"design {design.number} cannot be rebuilt: {exc}") from None
    objectives = ", ".join(f"{k} = {v:.6g}" for k, v in (row.objectives or {}).items())
    header = [f"campaign: {run.directory.resolve()} (started {run.campaign.started}, millfoil "
              f"{run.campaign.version})",
              f"design: number {design.number}, key {row.key}, generation {row.generation}, "
              f"class {row.convergence or '-'}",
              f"objectives: {objectives or '-'}"]
    return tool_path_of(spec), header


def config_tool_path(spec: BladeSpec, source: str) -> tuple[ToolPath, list[str]]:
    """The tool path of a configuration's blade (refused for a design-mode blade)."""
    path = tool_path_of(spec)
    try:
        build_profile(spec)
    except GeometryError as exc:
        raise ExportError(f"the blade of {source} cannot be machined: {exc}") from None
    return path, [f"configuration: {source}"]


def header_lines(path: ToolPath, origin: Sequence[str], version: str) -> list[str]:
    """Every header: what, from where, the tool, the blade's parameters, units and conventions."""
    spec = path.spec
    params = " ".join(f"{k}={v:.6g}" for k, v in spec.values.items())
    now = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
    return [f"millfoil {version} tool path export, {now}",
            *origin,
            f"blade: {spec.mode.value} {spec.continuity.value}; {params} (m, deg)",
            f"tool: cylindrical cutter, radius R = {path.radius:.6f} mm (diameter {2 * path.radius:.6f} mm)",
            "coordinates: cutter centre in mm, no radius compensation; workpiece zero at the camber line's "
            "leading-edge point CL0",
            "path: closed, counter-clockwise: pressure side P4->P0, suction side S0->S4 (degree-4 Bezier), "
            "trailing-edge pass (3 lines)"]


def default_output(directory: Path | None, stem: str, extension: str) -> Path:
    """``RUN/export/STEM.EXT`` for a run, ``STEM.EXT`` in the working directory otherwise."""
    return (directory / "export" if directory is not None else Path(".")) / f"{stem}{extension}"
