"""Blade parameters: names, units, validity domains and the optimisation space of Table 6.

A blade is chosen by a *mode* and a leading-edge *continuity* class:

* ``design``: the Bezier curves are the blade surface.
* ``toolpath``: the Bezier curves are the path of the centre of a cylindrical cutter of radius R; the
  blade is what the cutter leaves (see :mod:`geometry.nbuffer`).

and by the parameters of Table 3 of Vessaz et al. (2013), which differ per continuity class:

========== ================================================================ ======
continuity free side parameters (besides L, α, β1, β̄1)                    total
========== ================================================================ ======
G0         u_s1 u_s2 d_s1..d_s4, u_p1 u_p2 d_p1..d_p4                       16
G1         u_s2 d_s1..d_s4, u_p2 d_p1..d_p4 (u_s1 = u_p1 = 0)               14
C1         as G1 with d_p1 = d_s1                                          13
G2         u_s2 d_s1..d_s4, d_p1 k2 d_p3 d_p4 (P2 from curvature continuity) 13
C2         u_s2 d_s1..d_s4, d_p3 d_p4 (P1, P2 from C2 continuity)           11
========== ================================================================ ======

Tool-path mode adds the cutter radius R. Units in configuration files: metres for lengths, degrees for
angles, none for u and k2. :class:`BladeSpec` stores values in these configuration units; code that
builds geometry converts angles with :func:`numpy.radians`.

Every parameter has a *domain* (values outside it are input errors) and, for the optimiser, either
*bounds* (a design variable) or a *fixed* value. The defaults are Table 6 of the paper (with its two
d_s1/d_p1 ranges: 5–8 mm for design, 8–11 mm for tool paths). Table 6 has no range for u_s1/u_p1 (G0
was not studied in the paper) nor for k2 (G2): millfoil uses [0, 0.1] and [0.25, 4], see the docs.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np


class Mode(StrEnum):
    """What the Bezier curves describe."""

    DESIGN = "design"
    TOOLPATH = "toolpath"


class Continuity(StrEnum):
    """Continuity class of the suction/pressure junction at the leading edge (Table 3)."""

    G0 = "G0"
    G1 = "G1"
    C1 = "C1"
    G2 = "G2"
    C2 = "C2"


class ParameterError(ValueError):
    """A blade specification names an unknown parameter, misses one, or has a value out of its domain."""


@dataclass(frozen=True)
class Parameter:
    """One named blade parameter.

    ``domain`` is the closed/open interval of values that define a blade at all; ``bounds`` the default
    optimisation range (Table 6) or ``None`` when the parameter is ``fixed`` at a default value.
    """

    name: str
    unit: str
    description: str
    domain: tuple[float, float]
    open_low: bool = False
    bounds: tuple[float, float] | None = None
    fixed: float | None = None

    @property
    def domain_text(self) -> str:
        """The domain as an interval, ``(0, 0.5]`` or ``[-90, 90]``, in the parameter's unit."""
        lo, hi = self.domain
        return f"{'(' if self.open_low else '['}{lo:g}, {hi:g}]"

    def check(self, value: float) -> None:
        domain = self.domain_text
        lo, hi = self.domain
        if not math.isfinite(value):
            raise ParameterError(f"parameter '{self.name}' must be a finite number in {domain} {self.unit}, "
                                 f"got {value} ({self.description})")
        below = value <= lo if self.open_low else value < lo
        if below or value > hi:
            raise ParameterError(
                f"parameter '{self.name}' = {value!r} {self.unit} is out of its domain {domain} ({self.description})"
            )


#: Largest length parameter (chord, offsets, cutter radius), m. Profiles are sampled at least every
#: millimetre (``geometry.profile.DEFAULT_MAX_SPACING``), so the cost grows with the lengths: 10 m gives
#: about 20 000 points; larger lengths would ask for millions.
MAX_LENGTH = 10.0
#: Smallest chord L, m: below it the default 1 µm tolerance is no longer small against the blade.
MIN_CHORD = 1e-3

_ANGLE = (-90.0, 90.0)
_LENGTH = (0.0, MAX_LENGTH)
_RATIO = (0.0, 100.0)   # k2: 25 times millfoil's range (0.25 … 4); finite, so that no k2 overflows P2
_UNIT = (0.0, 1.0)
_MM = 1e-3


def _catalogue(mode: Mode) -> dict[str, Parameter]:
    """Every parameter that exists in ``mode``, with Table 6 defaults."""
    d1 = (5 * _MM, 8 * _MM) if mode is Mode.DESIGN else (8 * _MM, 11 * _MM)
    side = "tool-centre offset" if mode is Mode.TOOLPATH else "offset"
    p = [
        Parameter("L", "m", "chord length", (MIN_CHORD, MAX_LENGTH), fixed=0.1),
        Parameter("alpha", "deg", "chord angle α", _ANGLE, bounds=(-5.0, 25.0)),
        Parameter("beta1", "deg", "inlet angle β1", _ANGLE, bounds=(-20.0, 30.0)),
        Parameter("beta1bar", "deg", "outlet angle β̄1", _ANGLE, bounds=(0.0, 50.0)),
        Parameter("u_s1", "-", "camber abscissa of S1 (G0 only)", _UNIT, bounds=(0.0, 0.1)),
        Parameter("u_s2", "-", "camber abscissa of S2", _UNIT, bounds=(0.01, 0.35)),
        Parameter("d_s1", "m", f"suction {side} of S1", _LENGTH, open_low=True, bounds=d1),
        Parameter("d_s2", "m", f"suction {side} of S2", _LENGTH, bounds=(5 * _MM, 15 * _MM)),
        Parameter("d_s3", "m", "distance S3-S4 along the outlet tangent", _LENGTH, open_low=True,
                  bounds=(20 * _MM, 50 * _MM)),
        Parameter("d_s4", "m", "suction trailing-edge half-thickness", _LENGTH, fixed=2 * _MM),
        Parameter("u_p1", "-", "camber abscissa of P1 (G0 only)", _UNIT, bounds=(0.0, 0.1)),
        Parameter("u_p2", "-", "camber abscissa of P2", _UNIT, bounds=(0.01, 0.35)),
        Parameter("d_p1", "m", f"pressure {side} of P1", _LENGTH, open_low=True, bounds=d1),
        Parameter("d_p2", "m", f"pressure {side} of P2", _LENGTH, bounds=(5 * _MM, 15 * _MM)),
        Parameter("d_p3", "m", "distance P3-P4 along the outlet tangent", _LENGTH, open_low=True,
                  bounds=(20 * _MM, 50 * _MM)),
        Parameter("d_p4", "m", "pressure trailing-edge half-thickness", _LENGTH, fixed=2 * _MM),
        Parameter("k2", "-", "G2 ratio of tangential second derivatives at the leading edge",
                  _RATIO, open_low=True, bounds=(0.25, 4.0)),
    ]
    if mode is Mode.TOOLPATH:
        p.append(Parameter("R", "m", "cutter radius", _LENGTH, open_low=True, fixed=5 * _MM))
    return {q.name: q for q in p}


# Parameters that a continuity class does not have (Table 3).
_ABSENT: dict[Continuity, frozenset[str]] = {
    Continuity.G0: frozenset({"k2"}),
    Continuity.G1: frozenset({"u_s1", "u_p1", "k2"}),
    Continuity.C1: frozenset({"u_s1", "u_p1", "k2", "d_p1"}),
    Continuity.G2: frozenset({"u_s1", "u_p1", "u_p2", "d_p2"}),
    Continuity.C2: frozenset({"u_s1", "u_p1", "u_p2", "d_p2", "d_p1", "k2"}),
}


def _some(names: list[str], shown: int = 5) -> str:
    """The first ``shown`` names quoted (each cut to 40 characters), then how many more: a message stays short."""
    quoted = [repr(n if len(n) <= 40 else n[:39] + "…") for n in map(str, names[:shown])]
    return ", ".join(quoted) + (f" and {len(names) - shown} more" if len(names) > shown else "")


def parse_mode(value: str) -> Mode:
    return _parse_choice(Mode, "mode", str(value).lower())


def parse_continuity(value: str) -> Continuity:
    return _parse_choice(Continuity, "continuity", str(value).upper())


def _parse_choice(kind, what: str, value: str):
    try:
        return kind(value)
    except ValueError:
        raise ParameterError(f"unknown {what} {value!r}; allowed: {', '.join(k.value for k in kind)}") from None


def parameters_of(mode: Mode | str, continuity: Continuity | str) -> dict[str, Parameter]:
    """The parameters of one (mode, continuity) combination, in Table 3 order."""
    mode, continuity = parse_mode(mode), parse_continuity(continuity)
    return {n: p for n, p in _catalogue(mode).items() if n not in _ABSENT[continuity]}


@dataclass(frozen=True)
class BladeSpec:
    """A complete, validated blade: mode, continuity and every parameter value (configuration units).

    Build it with :meth:`from_values`, which fills fixed defaults and rejects unknown, missing or
    out-of-domain values with an error naming the parameter.
    """

    mode: Mode
    continuity: Continuity
    values: Mapping[str, float]

    @classmethod
    def from_values(
        cls, mode: Mode | str, continuity: Continuity | str, values: Mapping[str, float]
    ) -> BladeSpec:
        mode, continuity = parse_mode(mode), parse_continuity(continuity)
        known = parameters_of(mode, continuity)
        unknown = sorted(set(values) - set(known))
        if unknown:
            raise ParameterError(
                f"unknown parameter{'s' if len(unknown) > 1 else ''} {_some(unknown)} for a "
                f"{continuity.value} {mode.value} blade; allowed: {', '.join(known)}"
            )
        resolved: dict[str, float] = {}
        for name, param in known.items():
            if name in values:
                try:
                    value = float(values[name])
                except (TypeError, ValueError):
                    raise ParameterError(
                        f"parameter '{name}' must be a number in {param.unit}, got {values[name]!r}"
                    ) from None
            elif param.fixed is not None:
                value = param.fixed
            else:
                missing = [n for n, q in known.items() if n not in values and q.fixed is None]
                raise ParameterError(
                    f"missing parameter{'s' if len(missing) > 1 else ''} {', '.join(map(repr, missing))} for a "
                    f"{continuity.value} {mode.value} blade (required: "
                    f"{', '.join(n for n, q in known.items() if q.fixed is None)}; defaults exist for "
                    f"{', '.join(n for n, q in known.items() if q.fixed is not None)})"
                )
            param.check(value)
            resolved[name] = value
        return cls(mode, continuity, resolved)

    def __getitem__(self, name: str) -> float:
        return self.values[name]

    def get(self, name: str, default: float | None = None) -> float | None:
        return self.values.get(name, default)

    def radians(self, name: str) -> float:
        """An angle parameter converted to radians."""
        return math.radians(self.values[name])

    def with_values(self, **changes: float) -> BladeSpec:
        """A copy with some values changed (validated again)."""
        return BladeSpec.from_values(self.mode, self.continuity, {**self.values, **changes})

    def outside_bounds(self) -> list[str]:
        """Names of design variables whose value lies outside their default (Table 6) bounds."""
        known = parameters_of(self.mode, self.continuity)
        return [
            n for n, p in known.items()
            if p.bounds is not None and not p.bounds[0] <= self.values[n] <= p.bounds[1]
        ]


@dataclass(frozen=True)
class ParameterSpace:
    """The optimisation space of one (mode, continuity): design variables with bounds, the rest fixed.

    ``x`` vectors handed to and from the optimiser are ordered as :attr:`names`, in configuration units.
    """

    mode: Mode
    continuity: Continuity
    names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    fixed: Mapping[str, float] = field(default_factory=dict)

    @classmethod
    def default(
        cls,
        mode: Mode | str,
        continuity: Continuity | str,
        bounds: Mapping[str, tuple[float, float]] | None = None,
        fixed: Mapping[str, float] | None = None,
    ) -> ParameterSpace:
        """Table 6 space, with ``bounds`` overriding ranges (or freeing a fixed parameter) and ``fixed``
        pinning parameters to values."""
        mode, continuity = parse_mode(mode), parse_continuity(continuity)
        known = parameters_of(mode, continuity)
        bounds, fixed = dict(bounds or {}), dict(fixed or {})
        for name in [*bounds, *fixed]:
            if name not in known:
                raise ParameterError(
                    f"unknown parameter {name!r} for a {continuity.value} {mode.value} blade; "
                    f"allowed: {', '.join(known)}"
                )
        both = sorted(set(bounds) & set(fixed))
        if both:
            raise ParameterError(f"parameter(s) {', '.join(both)} given both bounds and a fixed value")
        names, lower, upper, pinned = [], [], [], {}
        for name, param in known.items():
            if name in fixed:
                param.check(float(fixed[name]))
                pinned[name] = float(fixed[name])
                continue
            rng = bounds.get(name, param.bounds)
            if rng is None:
                pinned[name] = float(param.fixed)
                continue
            lo, hi = (float(v) for v in rng)
            if not lo <= hi:
                raise ParameterError(f"bounds of {name!r} must satisfy lower <= upper, got [{lo}, {hi}]")
            param.check(lo)
            param.check(hi)
            names.append(name)
            lower.append(lo)
            upper.append(hi)
        return cls(mode, continuity, tuple(names), np.array(lower), np.array(upper), pinned)

    def role(self, name: str) -> str:
        """What parameter ``name`` is in this space: ``fixed 0.005`` or its optimisation range ``[lo, hi]``."""
        if name in self.fixed:
            return f"fixed {self.fixed[name]:g}"
        i = self.names.index(name)
        return f"[{self.lower[i]:g}, {self.upper[i]:g}]"

    def spec(self, x: np.ndarray) -> BladeSpec:
        """The blade of one design vector."""
        values = dict(self.fixed)
        values.update(zip(self.names, (float(v) for v in x), strict=True))
        return BladeSpec.from_values(self.mode, self.continuity, values)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` uniform random design vectors, shape ``(n, len(names))``."""
        return self.lower + (self.upper - self.lower) * rng.random((n, len(self.names)))
