"""CAD exports of a tool-path blade: DXF with true spline entities, CSV of points. Millimetres.

DXF (ezdxf, AutoCAD 2013 format, ``$INSUNITS`` = 4, millimetres), layers:

* ``TOOLPATH``: the cutter-centre path — the two degree-4 sides as ``SPLINE`` entities (clamped knot vector
  [0,0,0,0,0,1,1,1,1,1] over their five control points: the Bezier curves themselves, not an approximation)
  and the trailing-edge pass as three ``LINE`` entities;
* ``CAMBER``: the camber line, a degree-2 ``SPLINE`` (its three Bezier control points);
* ``BLADE``: the machined blade outline of the N-buffer simulation, a closed ``LWPOLYLINE`` within the
  geometry tolerance (1 µm): the envelope of a cutter is not a polynomial curve, so no spline carries it
  exactly;
* ``CUTTER``: the cutter (a ``CIRCLE`` of radius R) at P4, where the cut starts.

CSV: one row per point, ``curve,index,x_mm,y_mm`` with curve one of ``blade`` (machined outline,
counter-clockwise from the pressure-side trailing-edge corner), ``tool_path`` (closed cutter-centre polyline
within 1 µm, first point not repeated), ``control:pressure`` / ``control:suction`` / ``control:camber``
(Bezier control points, leading edge first).
"""

from __future__ import annotations

import csv
import io

import numpy as np

from geometry import BezierCurve, build_profile
from optimizer.export.toolpath import MM, ToolPath


def _clamped_knots(curve: BezierCurve) -> list[float]:
    k = curve.degree + 1
    return [0.0] * k + [1.0] * k


def dxf_document(path: ToolPath, header: list[str]):
    """The ezdxf document of ``path`` (see the module docstring); ``header`` lines are the drawing's custom
    properties ``millfoil.01``, ``millfoil.02``, … (DWGPROPS, shown by CAD programs)."""
    import ezdxf

    doc = ezdxf.new("R2013", setup=False)
    doc.header["$INSUNITS"] = 4      # millimetres
    doc.header["$MEASUREMENT"] = 1   # metric
    for name, colour in (("TOOLPATH", 1), ("CAMBER", 8), ("BLADE", 7), ("CUTTER", 3)):
        doc.layers.add(name, color=colour)
    msp = doc.modelspace()
    for piece in path.pieces:
        if piece.degree == 1:
            msp.add_line(tuple(piece.start), tuple(piece.end), dxfattribs={"layer": "TOOLPATH"})
        else:
            _spline(msp, piece, "TOOLPATH")
    profile = build_profile(path.spec)
    camber = BezierCurve(profile.curves.camber.control_points * MM)
    _spline(msp, camber, "CAMBER")
    msp.add_lwpolyline([tuple(p) for p in profile.points * MM], close=True, dxfattribs={"layer": "BLADE"})
    msp.add_circle(tuple(path.start), path.radius, dxfattribs={"layer": "CUTTER"})
    doc.set_modelspace_vport(height=150.0, center=tuple(np.mean(profile.points * MM, axis=0)))
    for i, line in enumerate(header, 1):
        doc.header.custom_vars.append(f"millfoil.{i:02d}", line)
    return doc


def _spline(msp, curve: BezierCurve, layer: str):
    spline = msp.add_spline(dxfattribs={"layer": layer})
    spline.dxf.degree = curve.degree
    spline.control_points = [tuple(p) + (0.0,) for p in curve.control_points]
    spline.knots = _clamped_knots(curve)
    spline.weights = []
    return spline


def dxf_text(path: ToolPath, header: list[str]) -> str:
    """The DXF file as text."""
    stream = io.StringIO()
    dxf_document(path, header).write(stream)
    return stream.getvalue()


def csv_text(path: ToolPath, header: list[str]) -> str:
    """The CSV file as text (see the module docstring); ``header`` lines as leading ``#`` comments."""
    profile = build_profile(path.spec)
    stream = io.StringIO()
    for line in header:
        stream.write(f"# {line}\n")
    w = csv.writer(stream, lineterminator="\n")
    w.writerow(["curve", "index", "x_mm", "y_mm"])
    rows = [("blade", profile.points * MM), ("tool_path", profile.tool_path * MM),
            ("control:pressure", profile.curves.pressure.control_points * MM),
            ("control:suction", profile.curves.suction.control_points * MM),
            ("control:camber", profile.curves.camber.control_points * MM)]
    for name, points in rows:
        w.writerows((name, i, f"{x:.6f}", f"{y:.6f}") for i, (x, y) in enumerate(points))
    return stream.getvalue()
