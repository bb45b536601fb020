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
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

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
        if not 1.0 < self.growth <= 1.2 + 1e-12:
            raise ValueError(f"growth must lie in (1, 1.2], got {self.growth}")
        for name in ("upstream", "downstream", "half_height", "side_offset", "te_offset", "y_plus",
                     "flow_speed", "viscosity", "far_size", "size_gradient", "max_turn", "corner_ratio",
                     "wall_gradient"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        if self.wall_nodes < 16:
            raise ValueError(f"wall_nodes must be at least 16, got {self.wall_nodes}")

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
