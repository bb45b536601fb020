"""Export of an optimal tool path to the machine and to CAD (``millfoil export``).

The point of the tool-path approach (Vessaz et al. 2013, §1, Table 1) is that the optimiser's curves go to
the machine unchanged: the degree-4 Bezier sides of the cutter-centre path become Sinumerik ``POLY`` blocks
or LinuxCNC order-5 NURBS blocks, exactly (:mod:`optimizer.export.nc`), or DXF ``SPLINE`` entities
(:mod:`optimizer.export.cad`); :mod:`optimizer.export.verify` reads a program back with the controller's
definition of its blocks and measures the distance to the optimiser's path. ``docs/how-to/export-nc-programs.md``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from optimizer.export.cad import csv_text, dxf_text
from optimizer.export.nc import DIALECTS, NcSettings, nc_program
from optimizer.export.toolpath import ExportError, ToolPath, power_form, tool_path_of


@dataclass(frozen=True)
class Format:
    """One export format: ``write(path, header, settings) -> text`` and the file name suffix."""

    write: Callable[[ToolPath, list[str], NcSettings], str]
    extension: str
    nc: bool


def _nc_writer(name: str):
    return lambda path, header, settings: nc_program(path, name, settings, header)


#: Export formats by name (``millfoil export --format``).
FORMATS: dict[str, Format] = {
    **{name: Format(_nc_writer(name), d.extension, True) for name, d in DIALECTS.items()},
    "dxf": Format(lambda path, header, _s: dxf_text(path, header), ".dxf", False),
    "csv": Format(lambda path, header, _s: csv_text(path, header), ".csv", False),
}

__all__ = ["DIALECTS", "FORMATS", "ExportError", "Format", "NcSettings", "ToolPath", "nc_program", "power_form",
           "tool_path_of"]
