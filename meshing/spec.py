"""Mesh specification: domain size, resolution level, near-wall resolution from a target y+.

All lengths that scale with the blade are given in chords (the chord ``L`` of the profile, m); physical
quantities are SI: flow speed in m/s, kinematic viscosity in m²/s, lengths in m.

Resolution levels (:data:`LEVELS`) set the number of wall nodes, the largest growth ratio of the O-layer,
the far-field cell size and the angular resolution of curved walls. Measured on the paper's blades
(Table 4 design C2 / Table 5 tool-path G1) with the default domain and y+ = 1:

=========  ======  ======  =========  ===========  ===============
level      layers  rays    quads      triangles    cells
=========  ======  ======  =========  ===========  ===============
coarse     42      84      3 524      ~1 950       ~5 500
medium     53      224     11 868     ~7 650       ~19 500
fine       88      484     42 588     ~27 800      ~70 400
=========  ======  ======  =========  ===========  ===============

Random feasible blades stay within a few per cent of these counts. A narrower channel has fewer
triangles (half_height = 1: ~1 450 / ~5 000 / ~18 600).

Limits: every field lies in the range of :data:`BOUNDS`, the
chord Reynolds number in :data:`REYNOLDS_RANGE` and the first cell within the O-layer, and the cell count
that :meth:`MeshSpec.estimate_cells` predicts stays within :data:`CELL_BUDGET`. A spec outside them raises
:class:`MeshSpecError` naming the field, its value, the allowed range and why, before any meshing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import NamedTuple

#: Resolution presets (cell counts in the module docstring). ``wall_nodes``: target number of nodes on
#: the blade wall; ``growth``: largest ratio of consecutive cell heights in the O-layer (≤ 1.2);
#: ``far_size``: largest triangle size, chords (capped at a quarter of the channel height, see
#: :func:`meshing.hybrid.far_field_size`); ``size_gradient``: increase of the triangle size per unit
#: distance from the O-layer; ``max_turn``: largest turning of the wall between
#: two wall nodes, degrees.
LEVELS: dict[str, dict[str, float | int]] = {
    "coarse": {"wall_nodes": 80, "growth": 1.2, "far_size": 1.0, "size_gradient": 0.25, "max_turn": 12.0},
    "medium": {"wall_nodes": 220, "growth": 1.15, "far_size": 0.5, "size_gradient": 0.15, "max_turn": 8.0},
    "fine": {"wall_nodes": 480, "growth": 1.08, "far_size": 0.25, "size_gradient": 0.08, "max_turn": 5.0},
}


class MeshSpecError(ValueError):
    """A mesh specification outside its limits; ``field``: the :class:`MeshSpec` field at fault (None for
    the cell budget, which many fields drive)."""

    def __init__(self, field: str | None, message: str):
        super().__init__(message)
        self.field = field


class Bound(NamedTuple):
    """The allowed range of a :class:`MeshSpec` field: ``lower`` (excluded when ``open_lower``) to
    ``upper``, in ``unit``; ``why``: the reason, shown in the error."""

    lower: float
    upper: float
    unit: str
    why: str
    open_lower: bool = False

    def contains(self, value: float) -> bool:
        return (self.lower < value if self.open_lower else self.lower <= value) and value <= self.upper

    def text(self) -> str:
        """The range as ``(0, 100] chords``."""
        upper = f"{self.upper:g}]" if math.isfinite(self.upper) else "inf)"
        return f"{'(' if self.open_lower else '['}{self.lower:g}, {upper}{' ' + self.unit if self.unit else ''}"


_DOMAIN = ("a larger domain only adds far-field cells; the default is 5 / 10 / 5 chords (the paper's Fig. 8 is "
           "not dimensioned)")
#: Ranges of the :class:`MeshSpec` fields (docs/reference/errors.md shows this table). Lower bounds of the domain
#: extents are only ``> 0``: whether a domain holds the O-layer depends on the blade, and the mesher says so.
BOUNDS: dict[str, Bound] = {
    "upstream": Bound(0.0, 100.0, "chords", _DOMAIN, open_lower=True),
    "downstream": Bound(0.0, 100.0, "chords", _DOMAIN, open_lower=True),
    "half_height": Bound(0.0, 50.0, "chords", _DOMAIN, open_lower=True),
    "side_offset": Bound(0.0, 1.0, "chords", "the O-layer holds the boundary layer, a few per cent of a chord "
                         "thick; a thicker one has longer rays and more layers", open_lower=True),
    "te_offset": Bound(0.0, 2.0, "chords", "idem, around the trailing edge and the start of the wake",
                       open_lower=True),
    "y_plus": Bound(0.01, 300.0, "", "below 0.01 the first cell is far thinner than any wall treatment needs; "
                    "above 300 it lies beyond the log layer, where wall functions no longer hold"),
    "flow_speed": Bound(0.0, math.inf, "m/s", "a speed; its range is the flow: section's, the chord Reynolds "
                        "number it gives is bounded", open_lower=True),
    "viscosity": Bound(0.0, math.inf, "m²/s", "a kinematic viscosity; the chord Reynolds number it gives is "
                       "bounded", open_lower=True),
    "wall_nodes": Bound(16, 4000, "", "fewer cannot follow the leading edge; the fine level has 480 and "
                        "4000 resolves any blade wall"),
    "growth": Bound(1.01, 1.2, "", "the O-layer's layer count grows as 1 / ln(growth); above 1.2 the "
                    "boundary layer is under-resolved (Vessaz et al. 2013 use 1.2 at most)"),
    "far_size": Bound(0.01, 10.0, "chords", "far-field triangles are at most a quarter of the channel height "
                      "anyway; smaller than 0.01 chord the far field alone exceeds the cell budget"),
    "size_gradient": Bound(0.01, 1.0, "", "the triangles of the graded zone grow as 1 / size_gradient²; above 1 "
                           "a triangle is larger than its distance to the O-layer"),
    "max_turn": Bound(2.0, 45.0, "deg", "the wall turns by 360° at least, so its curvature alone asks for "
                      "360° / max_turn wall nodes whatever wall_nodes says; above 45° a leading edge is a corner"),
    "corner_ratio": Bound(0.01, 1.0, "", "the spacing at sharp corners relative to the largest wall spacing"),
    "wall_gradient": Bound(0.01, 1.0, "", "the wall spacing's growth per unit wall length: 0 would make every "
                           "spacing the smallest, above 1 neighbouring spacings differ by more than the spacing"),
}
#: Chord Reynolds numbers ``flow_speed * chord / viscosity`` the mesh is placed for: the first-cell height
#: comes from Schlichting's skin-friction correlation, undefined below Re ≈ 2 and fitted up to 1e9.
REYNOLDS_RANGE = (10.0, 1.0e9)
#: The first cell is at most this fraction of the O-layer's side thickness (``side_offset`` chords), so that
#: the O-layer has several layers.
FIRST_CELL_FRACTION = 0.1
#: Largest number of cells a spec may ask for (estimated by :meth:`MeshSpec.estimate_cells`): about 15
#: times the ``fine`` level. Measured on the 2-core development machine, the solver takes ~6 µs per cell and
#: iteration and ~10 kB per cell: 2 000 iterations on a million cells are ~3 h and ~10 GB.
CELL_BUDGET = 1_000_000
#: Effective area of one far-field triangle in units of its target size squared (an equilateral one is
#: 0.433): fitted to the three levels' triangle counts in the module docstring (both channel heights).
TRIANGLE_AREA = 0.35


#: What each :class:`MeshSpec` field means (its unit and range are in :data:`BOUNDS`): the one description
#: that the configuration's ``mesh:`` section carries.
FIELD_DOCS: dict[str, str] = {
    "level": "resolution preset (LEVELS: coarse, medium, fine) that sets wall_nodes, growth, far_size, "
             "size_gradient and max_turn",
    "upstream": "distance from the most upstream blade point to the inlet, chords",
    "downstream": "distance from the most downstream blade point to the outlet, chords",
    "half_height": "distance from the middle of the blade's y extent to the top and bottom walls, chords",
    "side_offset": "thickness of the O-layer of quads on the blade's sides (offset of the profile), chords",
    "te_offset": "thickness of the O-layer around the trailing edge, chords",
    "y_plus": "target y+ of the first wall node, from a flat-plate skin-friction correlation at the chord "
              "Reynolds number",
    "flow_speed": "flow speed that places the first cell, m/s (default: flow.speed)",
    "viscosity": "kinematic viscosity that places the first cell, m²/s (default: flow.viscosity / flow.density)",
    "wall_nodes": "target number of nodes on the blade wall",
    "growth": "largest ratio of consecutive cell heights in the O-layer",
    "far_size": "largest far-field triangle size, chords (at most a quarter of the channel height)",
    "size_gradient": "increase of the triangle size per unit distance from the O-layer",
    "max_turn": "largest turning of the wall between two wall nodes, degrees",
    "corner_ratio": "wall spacing at sharp corners as a fraction of the largest wall spacing",
    "wall_gradient": "largest increase of the wall spacing per unit wall length",
}


@dataclass(frozen=True)
class MeshSpec:
    """What :func:`meshing.build_mesh` builds.

    Domain (rectangle aligned with the x axis, the inflow direction; distances in chords):

    * ``upstream`` = 5: from the most upstream blade point to the inlet (x = min).
    * ``downstream`` = 10: from the most downstream blade point to the outlet (x = max).
    * ``half_height`` = 5: from the middle of the blade's y extent to the top and bottom walls; the
      Table 4 blade (y extent ≈ 0.55 chord) then blocks ≈ 5.5 % of the height.

    O-layer (structured quads between the wall and the convex hull of the offset profile):

    * ``side_offset`` = 0.10, ``te_offset`` = 0.20: offset of the profile on the sides and around the
      trailing edge, chords (Vessaz et al. 2013, §3.2).
    * ``y_plus`` = 1: target y+ of the first wall node, from a flat-plate skin-friction correlation at the
      chord Reynolds number ``flow_speed * L / viscosity`` (:meth:`first_cell_height`).
    * ``growth``: largest ratio of consecutive layer heights (≤ 1.2).

    Resolution: ``level`` is a label; ``wall_nodes``, ``growth``, ``far_size``, ``size_gradient`` and
    ``max_turn`` default to the ``medium`` preset; use :meth:`for_level` for another level.
    ``corner_ratio``: wall spacing at sharp corners (trailing-edge corners, sharp leading edges) as a
    fraction of the largest wall spacing; ``wall_gradient``: largest increase of wall spacing per unit
    wall length.
    """

    level: str = "medium"
    upstream: float = 5.0
    downstream: float = 10.0
    half_height: float = 5.0
    side_offset: float = 0.10
    te_offset: float = 0.20
    y_plus: float = 1.0
    flow_speed: float = 10.0
    viscosity: float = 1.0e-6
    wall_nodes: int = int(LEVELS["medium"]["wall_nodes"])
    growth: float = float(LEVELS["medium"]["growth"])
    far_size: float = float(LEVELS["medium"]["far_size"])
    size_gradient: float = float(LEVELS["medium"]["size_gradient"])
    max_turn: float = float(LEVELS["medium"]["max_turn"])
    corner_ratio: float = 0.08
    wall_gradient: float = 0.15

    def __post_init__(self) -> None:
        for name, bound in BOUNDS.items():
            value = getattr(self, name)
            if not bound.contains(value):   # NaN too
                unit = f" {bound.unit}" if bound.unit else ""
                raise MeshSpecError(name, f"{name} = {value:g}{unit} is outside {bound.text()}: {bound.why}")

    @classmethod
    def for_level(cls, level: str, **overrides) -> MeshSpec:
        """The preset ``level`` (``coarse``, ``medium``, ``fine``) with ``overrides`` applied."""
        if level not in LEVELS:
            raise ValueError(f"unknown mesh level {level!r}; choose from {sorted(LEVELS)}")
        names = {f.name for f in fields(cls)}
        unknown = set(overrides) - names
        if unknown:
            raise ValueError(f"unknown MeshSpec fields: {sorted(unknown)}")
        return cls(level=level, **{**LEVELS[level], **overrides})

    def with_(self, **changes) -> MeshSpec:
        """A copy with ``changes`` applied."""
        return replace(self, **changes)

    def reynolds(self, chord: float) -> float:
        """Chord Reynolds number ``flow_speed * chord / viscosity`` (chord in m)."""
        return self.flow_speed * chord / self.viscosity

    def check_for(self, chord: float) -> None:
        """Raise :class:`MeshSpecError` unless a blade of ``chord`` (m) can be meshed within the limits: the
        chord Reynolds number in :data:`REYNOLDS_RANGE`, the first cell below :data:`FIRST_CELL_FRACTION` of
        the O-layer's thickness and the estimated cells within :data:`CELL_BUDGET`. Cheap (no meshing)."""
        re = self.reynolds(chord)
        lo, hi = REYNOLDS_RANGE
        if not lo <= re <= hi:
            raise MeshSpecError("flow_speed", f"the chord Reynolds number flow_speed * chord / viscosity = "
                                f"{self.flow_speed:g} m/s x {chord:g} m / {self.viscosity:g} m²/s = {re:.3g} is "
                                f"outside [{lo:g}, {hi:g}]: the first cell is placed by a skin-friction "
                                "correlation fitted in that range")
        h0, thickness = self.first_cell_height(chord), FIRST_CELL_FRACTION * self.side_offset * chord
        if h0 > thickness:
            raise MeshSpecError("y_plus", f"y_plus = {self.y_plus:g} puts the first cell {h0:.3g} m from the wall "
                                f"at Re = {re:.3g}, more than {FIRST_CELL_FRACTION:g} of the O-layer "
                                f"(side_offset {self.side_offset:g} chords = {self.side_offset * chord:.3g} m): "
                                "lower y_plus or raise side_offset")
        estimate = self.estimate_cells(chord)
        if estimate["cells"] > CELL_BUDGET:
            raise MeshSpecError(None, f"this mesh would have about {estimate['cells']:,} cells "
                                f"({estimate['quads']:,} quads in {estimate['layers']} layers of "
                                f"{estimate['rays']} rays, {estimate['triangles']:,} triangles), more than the "
                                f"budget of {CELL_BUDGET:,}: coarsen the level or reduce wall_nodes, the domain, "
                                "or raise growth, far_size or size_gradient")

    def estimate_cells(self, chord: float) -> dict[str, int]:
        """The cell counts this spec gives around a blade of ``chord`` (m), estimated without meshing
        (within ~5 % of the three levels' measured counts in the module docstring, both channel heights):

        * rays ≈ ``wall_nodes`` (or the ≥ 360° of wall turning over ``max_turn`` if more) plus 4 fan rays;
        * layers: the geometric progression from the first-cell height with ratio ``growth`` to the longest
          ray, ≈ 1.25 the larger offset (as in :func:`meshing.hybrid.layer_distances`);
        * triangles: the graded zone, sizes growing linearly with the distance ``d`` from the O-layer's
          ring (perimeter P ≈ 2 (1 + 2 offset) + 2π side_offset chords, spacing h_r = P / rays) up to the
          far-field size h_f, ``∫ (P + 2π d) / (a (h_r + g d)²) dd``, plus the rest of the rectangle at
          h_f (``a`` = :data:`TRIANGLE_AREA`, ``g`` = ``size_gradient``), the graded zone clipped to the
          rectangle.
        """
        rays = max(self.wall_nodes, math.ceil(360.0 / self.max_turn)) + 4
        offset = max(self.side_offset, self.te_offset)
        ray_length = 1.25 * offset * chord
        h0, g = self.first_cell_height(chord), self.growth
        layers = math.ceil(math.log1p(ray_length * (g - 1.0) / h0) / math.log(g))
        perimeter = 2.0 * (1.0 + 2.0 * offset) + 2.0 * math.pi * self.side_offset             # chords
        ring_h = perimeter / rays
        far_h = max(min(self.far_size, 0.5 * self.half_height), ring_h)    # FAR_HEIGHT_FRACTION of 2 half_height
        k = self.size_gradient
        d_max = (far_h - ring_h) / k
        graded = (perimeter / k * (1.0 / ring_h - 1.0 / far_h)
                  + 2.0 * math.pi / k**2 * (math.log(far_h / ring_h) + ring_h / far_h - 1.0)) / TRIANGLE_AREA
        box = (self.upstream + self.downstream + 1.0) * 2.0 * self.half_height
        graded_area = perimeter * d_max + math.pi * d_max**2
        if graded_area > box:
            triangles = graded * box / graded_area
        else:
            triangles = graded + (box - graded_area) / (TRIANGLE_AREA * far_h**2)
        quads = rays * layers
        return {"rays": rays, "layers": layers, "quads": quads, "triangles": round(triangles),
                "cells": quads + round(triangles)}

    def first_cell_height(self, chord: float) -> float:
        """Height of the first O-layer cell at the wall, m, for the target ``y_plus``.

        Schlichting's turbulent flat-plate skin friction at the chord Reynolds number,
        ``Cf = (2 log10(Re) - 0.65)^-2.3``, gives the friction velocity ``u_tau = U sqrt(Cf / 2)`` and
        ``h = y+ nu / u_tau``. For water at 10 m/s over a 0.1 m chord (Re = 1e6): h ≈ 2.3 µm.
        """
        return first_cell_height(self.y_plus, self.flow_speed, chord, self.viscosity)


def skin_friction(reynolds: float) -> float:
    """Turbulent flat-plate skin-friction coefficient (Schlichting), valid for 1e5 < Re < 1e9."""
    return (2.0 * math.log10(reynolds) - 0.65) ** -2.3


def first_cell_height(y_plus: float, flow_speed: float, chord: float, viscosity: float) -> float:
    """Wall distance (m) of y+ = ``y_plus`` for a flat plate of length ``chord`` (m) in a flow of
    ``flow_speed`` (m/s) and kinematic ``viscosity`` (m²/s)."""
    cf = skin_friction(flow_speed * chord / viscosity)
    u_tau = flow_speed * math.sqrt(0.5 * cf)
    return y_plus * viscosity / u_tau
