"""NC programs that carry the optimiser's tool path exactly: Sinumerik ``POLY`` and LinuxCNC ``G5.2`` NURBS.

A degree-4 Bezier side of the tool path becomes one block, with no approximation:

* **Siemens Sinumerik 840D sl / ONE** (programming manual, Job planning, "Polynomial interpolation (POLY,
  POLYPATH, PO, PL)"): ``POLY PO[X]=(xe, a2, a3, a4) PO[Y]=(ye, b2, b3, b4) PL=1``: per axis
  f(p) = a0 + a1 p + a2 p² + a3 p³ + a4 p⁴ on p ∈ [0, PL], a0 the position at the end of the previous
  block, a1 derived by the control from the end point: a1 = (xe − a0 − a2 PL² − a3 PL³ − a4 PL⁴) / PL.
  With PL = 1 the coefficients are those of :func:`optimizer.export.toolpath.power_form`, in mm.
* **LinuxCNC** (G-code reference, "G5.2 G5.3 NURBS Block"; interpreter ``convert_nurbs`` in
  ``src/emc/rs274ngc/interp_convert.cc``): the current position is the first control point (weight 1),
  ``G5.2 X Y P1 L5`` the second, ``X Y P1`` the others, ``G5.3`` closes the block; order L = 5 and the
  uniform clamped knot vector of ``nurbs_G5_knot_vector_creator`` ([0,0,0,0,0,1,1,1,1,1] for five control
  points) make the NURBS the degree-4 Bezier itself.

The trailing-edge pass is three ``G1`` lines. Coordinates are the cutter centre (no radius compensation,
``G40``), millimetres, workpiece zero at the camber line's leading-edge point CL0, in the plane chosen by
``NcSettings.plane`` (G17: blade x → X, y → Y, depth along Z). Numbers carry 6 decimals (1 nm): the
written program reproduces the optimiser's curves to far below 1 µm, which
:mod:`optimizer.export.verify` checks by reading the program back.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from geometry import BezierCurve
from optimizer.export.toolpath import ExportError, ToolPath, power_form

#: Axes of the plane selections: (blade x, blade y, depth). G17 XY, G18 ZX, G19 YZ (ISO 6983 / DIN 66025).
PLANES = {"G17": ("X", "Y", "Z"), "G18": ("Z", "X", "Y"), "G19": ("Y", "Z", "X")}


@dataclass(frozen=True)
class NcSettings:
    """How the program moves around the exact curves (millimetres, mm/min, rpm).

    feed: cutting feed along the path (10–100 000 mm/min). plunge_feed: feed of the move down to the cutting
    depth. spindle: spindle speed (M3, clockwise). tool: tool number (``T.. M6``). plane: G17 (default),
    G18 or G19. safe: clearance height above the workpiece zero of the depth axis. depth: cutting depth,
    position on the depth axis (negative: into the stock). approach: length of the straight lead-in to P4
    along the trailing-edge lead-in line (0: plunge at P4). retract: length of the straight move away from
    the blade at the end, along the pressure-side normal at P4 (0: lift at P4).
    """

    feed: float = 600.0
    plunge_feed: float = 150.0
    spindle: float = 8000.0
    tool: int = 1
    plane: str = "G17"
    safe: float = 5.0
    depth: float = -5.0
    approach: float = 5.0
    retract: float = 5.0

    def __post_init__(self) -> None:
        if self.plane not in PLANES:
            raise ExportError(f"plane must be one of {', '.join(PLANES)}, got {self.plane!r}")
        for name in ("feed", "plunge_feed", "spindle"):
            if not 0.0 < getattr(self, name) <= 1e5:
                raise ExportError(f"{name} must be in (0, 100000], got {getattr(self, name)!r}")
        for name in ("approach", "retract"):
            if not 0.0 <= getattr(self, name) <= 1e3:
                raise ExportError(f"{name} must be in [0, 1000] mm, got {getattr(self, name)!r}")
        if not self.safe > self.depth:
            raise ExportError(f"the safe height ({self.safe} mm) must be above the cutting depth ({self.depth} mm)")
        if not 0 <= self.tool <= 99999:
            raise ExportError(f"tool must be a tool number in [0, 99999], got {self.tool!r}")

    @property
    def axes(self) -> tuple[str, str, str]:
        return PLANES[self.plane]


def number(v: float) -> str:
    """A coordinate or coefficient: fixed point, 6 decimals (mm: 1 nm), no negative zero."""
    text = f"{v:.6f}"
    return "0.000000" if text == "-0.000000" else text


def short(v: float) -> str:
    """A feed or spindle speed: at most 3 decimals, no trailing zeros (600, 1500.5)."""
    return f"{v:.3f}".rstrip("0").rstrip(".")


# ---------------------------------------------------------------------------------------------- dialects
@dataclass(frozen=True)
class Dialect:
    """What differs between controllers: comments, preamble, the degree-4 block, the end of program.

    comment(text) -> line; preamble(settings) -> lines; curve(curve, settings) -> lines (the block(s) of
    one degree-4 Bezier starting at the current position); end -> lines; extension: file name suffix.
    """

    name: str
    comment: Callable[[str], str]
    preamble: Callable[[NcSettings], list[str]]
    curve: Callable[[BezierCurve, NcSettings], list[str]]
    end: tuple[str, ...]
    extension: str
    planes: tuple[str, ...] = tuple(PLANES)


def _ascii(text: str, forbidden: str) -> str:
    """Printable ASCII without ``forbidden`` characters: user strings cannot end a comment early."""
    return "".join(c if " " <= c <= "~" and c not in forbidden else "?" for c in text)


def _sinumerik_comment(text: str) -> str:
    return f"; {_ascii(text, '')}".rstrip()


def _sinumerik_preamble(s: NcSettings) -> list[str]:
    # G71: metric input; G90 absolute; G40: no radius compensation (the path is the cutter centre).
    return [f"{s.plane} G71 G90 G40 G94", f"T{s.tool} D1", "M6", f"S{short(s.spindle)} M3"]


def _sinumerik_curve(curve: BezierCurve, s: NcSettings) -> list[str]:
    """One POLY block per degree-4 curve: PO[axis] = (end, a2, a3, a4), PL = 1 (see the module docstring)."""
    a = power_form(curve)
    words = []
    for j, axis in enumerate(s.axes[:2]):
        words.append(f"PO[{axis}]=(" + ", ".join(number(v) for v in [curve.end[j], *a[2:, j]]) + ")")
    return ["POLY " + " ".join(words) + " PL=1"]


#: A LinuxCNC comment ends at the first ')' and cannot nest: parentheses of user text become brackets.
_PARENS = str.maketrans("()", "[]")


def _linuxcnc_comment(text: str) -> str:
    return f"({_ascii(text, '').translate(_PARENS)})"


def _linuxcnc_preamble(s: NcSettings) -> list[str]:
    # G21 mm; G90 absolute; G40 no radius compensation; G94 feed per minute; G64 P0.001 keeps blending within
    # 1 µm of the programmed path.
    return [f"{s.plane} G21 G90 G40 G94 G64 P0.001", f"T{s.tool} M6", f"S{short(s.spindle)} M3"]


def _linuxcnc_curve(curve: BezierCurve, s: NcSettings) -> list[str]:
    """G5.2 … G5.3 of order L = degree + 1; the current position is the first control point (weight 1)."""
    cp = curve.control_points
    first, *rest = cp[1:]
    lines = [f"G5.2 X{number(first[0])} Y{number(first[1])} P1 L{curve.degree + 1}"]
    lines += [f"X{number(x)} Y{number(y)} P1" for x, y in rest]
    return [*lines, "G5.3"]


#: NC dialects by name (``millfoil export --format``).
DIALECTS: dict[str, Dialect] = {
    "sinumerik": Dialect("sinumerik", _sinumerik_comment, _sinumerik_preamble, _sinumerik_curve,
                         ("M5", "M30"), ".mpf"),
    # The interpreter reads X and Y words for NURBS control points: the XY plane only.
    "linuxcnc": Dialect("linuxcnc", _linuxcnc_comment, _linuxcnc_preamble, _linuxcnc_curve,
                        ("M5", "M2", "%"), ".ngc", planes=("G17",)),
}


# ---------------------------------------------------------------------------------------------- program
def nc_program(path: ToolPath, dialect: str, settings: NcSettings = NcSettings(),
               header: Sequence[str] = ()) -> str:
    """The NC program of ``path`` in ``dialect`` (a key of :data:`DIALECTS`): header comments, preamble,
    approach, the five pieces, retract, end of program. Returns the text (lines end with a newline)."""
    d = DIALECTS[dialect]
    if settings.plane not in d.planes:
        raise ExportError(f"{dialect} NURBS blocks are programmed in the XY plane only (G17), not {settings.plane}")
    ax = settings.axes
    lines = ["%"] if dialect == "linuxcnc" else []
    lines += [d.comment(h) for h in header]
    lines += d.preamble(settings)
    start = path.start
    entry = start + settings.approach * path.lead
    exit_ = path.pieces[-1].end + settings.retract * path.exit_normal

    def xy(p: np.ndarray) -> str:
        return f"{ax[0]}{number(p[0])} {ax[1]}{number(p[1])}"

    lines += [f"G0 {ax[2]}{number(settings.safe)}", f"G0 {xy(entry)}",
              f"G1 {ax[2]}{number(settings.depth)} F{short(settings.plunge_feed)}"]
    if settings.approach > 0:
        lines.append(d.comment("approach along the trailing-edge lead-in line"))
    lines.append(f"G1 {xy(start)} F{short(settings.feed)}")
    names = ("pressure side P4 -> P0 (degree-4 Bezier)", "suction side S0 -> S4 (degree-4 Bezier)",
             "trailing-edge pass: lead-out", "trailing-edge pass: cross", "trailing-edge pass: lead-in")
    for name, piece in zip(names, path.pieces, strict=True):
        lines.append(d.comment(name))
        lines += d.curve(piece, settings) if piece.degree > 1 else [f"G1 {xy(piece.end)}"]
    if settings.retract > 0:
        lines += [d.comment("retract along the pressure-side normal"), f"G1 {xy(exit_)}"]
    lines += [f"G0 {ax[2]}{number(settings.safe)}", *d.end]
    return "\n".join(lines) + "\n"
