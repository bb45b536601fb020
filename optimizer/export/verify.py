"""Read an emitted NC program back and measure how far its curves are from the optimiser's tool path.

The reader knows only the controllers' definitions, not how :mod:`optimizer.export.nc` wrote the program:

* Sinumerik ``POLY``: per axis f(p) = a0 + a1 p + … + a5 p⁵ on p ∈ [0, PL]; a0 is the axis position at
  the end of the previous block; ``PO[axis]=(end, a2, a3, …)``; a1 = (end − a0 − Σ_{k≥2} a_k PL^k) / PL;
  an axis without ``PO`` keeps its position; PL defaults to 1.
* LinuxCNC ``G5.2``/``G5.3``: the current position is the first control point with weight 1 (unless the
  ``G5.2`` line has only a ``P``); each further line adds a control point with its weight ``P``; the order is
  3 unless an ``L`` > 3 is given; the knot vector is ``nurbs_G5_knot_vector_creator``'s: k zeros, then
  1 … n − k + 1, then n − k + 2 repeated (n + 1 control points, order k); the curve is the rational
  B-spline Σ N_i,k(u) w_i P_i / Σ N_i,k(u) w_i on u ∈ [0, n − k + 2].

Each motion becomes a :class:`Segment`; :func:`deviation` compares the segments cut at depth with the
pieces of a :class:`optimizer.export.toolpath.ToolPath`, point by point at the same parameter (the same
polynomial in another notation: the distance at equal parameter bounds the geometric distance).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from optimizer.export.toolpath import ToolPath

_WORD = re.compile(r"([A-Z])\s*([-+]?\d*\.?\d+)")
_PO = re.compile(r"PO\[\s*([A-Z])\s*\]\s*=\s*\(([^)]*)\)")


@dataclass(frozen=True)
class Segment:
    """One programmed motion. kind: ``rapid``, ``line``, ``poly``, ``nurbs``. start, end: {axis: mm}.
    evaluate(s) gives {axis: positions} at normalised parameters s ∈ [0, 1] (the block's own parameter
    scaled to [0, 1]); line: the source line number of the block (1-based)."""

    kind: str
    start: dict[str, float]
    end: dict[str, float]
    evaluate: Callable[[np.ndarray], dict[str, np.ndarray]]
    line: int


def read_program(text: str, dialect: str) -> list[Segment]:
    """The motions of a program in ``dialect`` (``sinumerik`` or ``linuxcnc``)."""
    return _READERS[dialect](text)


def _linear(start: dict[str, float], end: dict[str, float]):
    return lambda s: {a: start[a] + (end[a] - start[a]) * s for a in start}


def _read_sinumerik(text: str) -> list[Segment]:
    pos = {"X": 0.0, "Y": 0.0, "Z": 0.0}
    mode, segments = None, []
    for n, raw in enumerate(text.splitlines(), 1):
        code = raw.split(";", 1)[0].upper()
        polys = {axis: [float(v) for v in values.split(",")] for axis, values in _PO.findall(code)}
        pl_match = re.search(r"\bPL\s*=\s*([-+]?\d*\.?\d+)", code)
        rest = _PO.sub(" ", re.sub(r"\bPL\s*=\s*[-+]?\d*\.?\d+", " ", code))
        if "POLY" in rest:
            mode = "poly"
            rest = rest.replace("POLY", " ")
        words = _WORD.findall(rest)
        for letter, value in words:
            if letter == "G" and value in ("0", "00", "1", "01"):
                mode = "rapid" if float(value) == 0 else "line"
        target = {a: float(v) for a, v in words if a in pos}
        if mode == "poly" and polys:
            segments.append(_poly_segment(pos, polys, float(pl_match.group(1)) if pl_match else 1.0, n))
        elif mode in ("rapid", "line") and target:
            end = {**pos, **target}
            segments.append(Segment(mode, dict(pos), end, _linear(dict(pos), end), n))
        else:
            continue
        pos = dict(segments[-1].end)
    return segments


def _poly_segment(pos: dict[str, float], polys: dict[str, list[float]], pl: float, line: int) -> Segment:
    coeffs = {}
    for axis, a0 in pos.items():
        if axis not in polys:
            coeffs[axis] = np.array([a0])
            continue
        end, *higher = polys[axis]
        a1 = (end - a0 - sum(a * pl ** (k + 2) for k, a in enumerate(higher))) / pl
        coeffs[axis] = np.array([a0, a1, *higher])
    end = {a: float(np.polynomial.polynomial.polyval(pl, c)) for a, c in coeffs.items()}

    def evaluate(s: np.ndarray) -> dict[str, np.ndarray]:
        return {a: np.polynomial.polynomial.polyval(np.asarray(s) * pl, c) + 0.0 * np.asarray(s)
                for a, c in coeffs.items()}

    return Segment("poly", dict(pos), end, evaluate, line)


def _read_linuxcnc(text: str) -> list[Segment]:
    pos = {"X": 0.0, "Y": 0.0, "Z": 0.0}
    mode, segments = None, []
    nurbs: list[tuple[float, float, float]] = []
    order, first_line = 3, 0
    for n, raw in enumerate(text.splitlines(), 1):
        code = re.sub(r"\([^)]*\)", " ", raw.split(";", 1)[0]).upper()
        words = _WORD.findall(code)
        gs = [v for letter, v in words if letter == "G"]
        values = {letter: float(v) for letter, v in words if letter != "G"}
        if "5.3" in gs:
            segments.append(_nurbs_segment(pos, nurbs, order, first_line))
            pos = dict(segments[-1].end)
            mode, nurbs = None, []
            continue
        if "5.2" in gs:
            mode, order, first_line = "nurbs", 3, n
            weight = values["P"] if "X" not in values and "Y" not in values and "P" in values else 1.0
            nurbs = [(pos["X"], pos["Y"], weight)]
        elif any(g in ("0", "00") for g in gs):
            mode = "rapid"
        elif any(g in ("1", "01") for g in gs):
            mode = "line"
        if mode == "nurbs":
            if "L" in values and values["L"] > 3:
                order = int(values["L"])
            if "X" in values and "Y" in values:
                nurbs.append((values["X"], values["Y"], values["P"]))
            continue
        target = {a: values[a] for a in pos if a in values}
        if mode in ("rapid", "line") and target:
            end = {**pos, **target}
            segments.append(Segment(mode, dict(pos), end, _linear(dict(pos), end), n))
            pos = end
    return segments


def linuxcnc_knots(n: int, k: int) -> np.ndarray:
    """LinuxCNC's knot vector (``nurbs_G5_knot_vector_creator``) for n + 1 control points of order k."""
    return np.array([0 if i < k else (i - k + 1 if i <= n else n - k + 2) for i in range(n + k + 1)], float)


def bspline_basis(knots: np.ndarray, k: int, u: np.ndarray) -> np.ndarray:
    """Cox–de Boor basis functions N_i,k(u) of order k (degree k − 1), shape ``(len(u), n + 1)``; the last
    non-empty knot span is closed so that the curve reaches its end point at u = u_max."""
    u = np.asarray(u, float)
    m = len(knots) - 1
    last = max(i for i in range(m) if knots[i] < knots[i + 1])
    N = np.zeros((u.size, m))
    for i in range(m):
        if knots[i] < knots[i + 1]:
            N[:, i] = (knots[i] <= u) & ((u < knots[i + 1]) | ((i == last) & (u == knots[i + 1])))
    for order in range(2, k + 1):
        nxt = np.zeros((u.size, m - order + 1))
        for i in range(m - order + 1):
            left = knots[i + order - 1] - knots[i]
            right = knots[i + order] - knots[i + 1]
            if left > 0:
                nxt[:, i] += (u - knots[i]) / left * N[:, i]
            if right > 0:
                nxt[:, i] += (knots[i + order] - u) / right * N[:, i + 1]
        N = nxt
    return N


def _nurbs_segment(pos: dict[str, float], cps: list[tuple[float, float, float]], k: int, line: int) -> Segment:
    P = np.array(cps)
    n = len(cps) - 1
    if n + 1 < k:
        raise ValueError(f"line {line}: a NURBS of order {k} needs at least {k} control points, got {n + 1}")
    knots = linuxcnc_knots(n, k)
    umax = n - k + 2

    def evaluate(s: np.ndarray) -> dict[str, np.ndarray]:
        N = bspline_basis(knots, k, np.atleast_1d(s) * umax) * P[:, 2]
        xy = N @ P[:, :2] / N.sum(axis=1)[:, None]
        return {"X": xy[:, 0], "Y": xy[:, 1], "Z": np.full(xy.shape[0], pos["Z"])}

    end = {"X": P[-1, 0], "Y": P[-1, 1], "Z": pos["Z"]}
    return Segment("nurbs", dict(pos), end, evaluate, line)


_READERS = {"sinumerik": _read_sinumerik, "linuxcnc": _read_linuxcnc}


# -------------------------------------------------------------------------------------------- compare
@dataclass(frozen=True)
class Deviation:
    """Largest distance (mm) between each tool-path piece and the program's block that carries it, at
    ``samples`` equally spaced parameters; ``worst`` is the largest over the pieces. kinds: the block kind
    that carried each piece (``poly``, ``nurbs``, ``line``)."""

    pieces: tuple[float, ...]
    kinds: tuple[str, ...]
    samples: int

    @property
    def worst(self) -> float:
        return max(self.pieces)


def deviation(segments: list[Segment], path: ToolPath, axes: tuple[str, str, str] = ("X", "Y", "Z"),
              depth: float | None = None, samples: int = 2001) -> Deviation:
    """Compare the program's cutting blocks with ``path`` (see the module docstring).

    The cutting blocks are the feed moves at the depth ``depth`` (default: that of the first curve block);
    the five pieces must appear among them in order, starting with the first curve block (the approach,
    if any, precedes it). Raises ValueError if the program does not carry the path's pieces.
    """
    first_curve = next((i for i, s in enumerate(segments) if s.kind in ("poly", "nurbs")), None)
    if first_curve is None:
        raise ValueError("the program has no polynomial or spline block")
    depth = segments[first_curve].start[axes[2]] if depth is None else depth
    cut = [s for s in segments[first_curve:] if s.kind != "rapid" and abs(s.start[axes[2]] - depth) < 1e-9
           and abs(s.end[axes[2]] - depth) < 1e-9]
    if len(cut) < len(path.pieces):
        raise ValueError(f"the program cuts {len(cut)} blocks at depth {depth}, the tool path has "
                         f"{len(path.pieces)} pieces")
    s = np.linspace(0.0, 1.0, samples)
    worst, kinds = [], []
    for seg, piece in zip(cut, path.pieces, strict=False):
        at = seg.evaluate(s)
        programmed = np.column_stack([at[axes[0]], at[axes[1]]])
        depth_error = np.max(np.abs(at[axes[2]] - depth))
        worst.append(float(max(np.max(np.linalg.norm(programmed - piece.points(s), axis=1)), depth_error)))
        kinds.append(seg.kind)
    return Deviation(tuple(worst), tuple(kinds), samples)
