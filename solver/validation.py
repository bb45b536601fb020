"""Validation cases against published data, as called by ``millfoil validate cavity|cylinder|mms|flatplate``.

Every case is a function ``level -> ValidationReport``, registered in :data:`CASES`; :func:`run_case` looks
one up by name. Levels:

* ``coarse``: CI size (seconds), with tolerances loosened to what the coarse mesh allows but still tight
  enough to fail a wrong scheme (each case states why);
* ``medium`` and ``fine``: the acceptance figures of issue 4 with its tolerances, on two resolutions.

A :class:`Comparison` gives ``error`` and ``tolerance`` in the same unit, named in ``name``; it passes when
``error <= tolerance``. Observed orders of accuracy are compared with the formal order 2: ``error`` is the
shortfall ``2 - observed`` and ``tolerance`` the allowed shortfall (0.2 means "order >= 1.8").
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

from . import cavity, cylinder, flatplate, mms

#: Resolution levels accepted by every case.
LEVELS: tuple[str, ...] = ("coarse", "medium", "fine")


@dataclass(frozen=True)
class Comparison:
    """One computed quantity against its reference; ``error`` and ``tolerance`` in the unit named in
    ``name``; ``passed`` is ``error <= tolerance``."""

    name: str
    computed: float
    reference: float
    error: float
    tolerance: float
    passed: bool

    @classmethod
    def of(cls, name: str, computed: float, reference: float, error: float, tolerance: float) -> Comparison:
        """Build with ``passed = error <= tolerance`` (floats coerced, NaN fails)."""
        error = float(error)
        return cls(name, float(computed), float(reference), error, float(tolerance), bool(error <= tolerance))

    def as_json(self) -> dict:
        """``{name, computed, reference, error, tolerance, pass}`` (the CLI's ``--json`` record)."""
        d = asdict(self)
        d["pass"] = d.pop("passed")
        return d


@dataclass(frozen=True)
class ValidationReport:
    """Result of one validation case at one level.

    details: plain JSON-able data about the runs (cells, iterations, status, wall time, ...).
    seconds: wall-clock time of the whole case, s.
    """

    case: str
    level: str
    description: str
    comparisons: tuple[Comparison, ...]
    seconds: float
    details: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        """All comparisons pass."""
        return all(c.passed for c in self.comparisons)


def _run_summary(res) -> dict:
    """Cells, iterations, status and solve time of a :class:`solver.results.FlowResults`."""
    return dict(cells=res.mesh.n_cells, iterations=res.iterations, status=res.status,
                converged=res.converged, solve_seconds=round(res.wall_time, 3))


# ---------------------------------------------------------------------------------------------- cavity
#: Cavity runs per level: ``{Re: (n, RMS tolerance as a fraction of the lid speed)}`` on the mixed gmsh
#: mesh (quads for x < 0.5, triangles for x > 0.5). coarse: n = 32 (1 813 cells); measured RMS 0.32 %
#: with linear upwind, 0.63 % with first-order upwind, so 0.45 % fails a first-order convection scheme.
#: medium: n = 64 (~7 100 cells), fine: n = 100 (17 415 cells, <= 20 000 as issue 4 asks), both with the
#: issue's tolerances (1 % at Re 100, 2 % at Re 1000).
CAVITY_LEVELS = {"coarse": {100: (32, 0.0045)},
                 "medium": {100: (64, cavity.TOLERANCE[100]), 1000: (64, cavity.TOLERANCE[1000])},
                 "fine": {100: (100, cavity.TOLERANCE[100]), 1000: (100, cavity.TOLERANCE[1000])}}


def validate_cavity(level: str) -> ValidationReport:
    """Lid-driven cavity vs Ghia, Ghia & Shin (1982): RMS of the centreline velocity errors (u on x = 0.5,
    v on y = 0.5, Ghia's interior points) in % of the lid speed."""
    t0 = time.perf_counter()
    comparisons, details = [], {}
    for re, (n, tol) in CAVITY_LEVELS[level].items():
        res, cmp = cavity.run_cavity(re, n, "gmsh_mixed")
        comparisons.append(Comparison.of(f"Re {re}: centreline u, v RMS error vs Ghia (% of lid speed)",
                                         100 * cmp.rms, 0.0, 100 * cmp.rms, 100 * tol))
        details[f"re{re}"] = dict(_run_summary(res), rms_u_percent=100 * cmp.rms_u,
                                  rms_v_percent=100 * cmp.rms_v, u_min=float(cmp.u.min()),
                                  v_max=float(cmp.v.max()), v_min=float(cmp.v.min()))
    return ValidationReport("cavity", level, validate_cavity.__doc__.split("\n")[0], tuple(comparisons),
                            time.perf_counter() - t0, details)


# ------------------------------------------------------------------------------------------------- MMS
#: MMS refinement levels (:func:`solver.mms.run_level`: uniform refinements of one 170-cell gmsh triangle
#: mesh) and the allowed shortfall of the observed (velocity, pressure) order from 2. coarse (170 / 680 /
#: 2 720 cells, ~10 s): measured 2.28 / 2.46; medium (680 / 2 720 / 10 880 cells): 1.98 / 1.88; fine: all
#: four. Every level asks the issue's >= 1.8 velocity, >= 1.5 pressure; a first-order scheme gives ~1.
MMS_LEVELS = {"coarse": ((0, 1, 2), (0.2, 0.5)), "medium": ((1, 2, 3), (0.2, 0.5)),
              "fine": ((0, 1, 2, 3), (0.2, 0.5))}


def validate_mms(level: str) -> ValidationReport:
    """Manufactured steady Navier–Stokes solution on successively refined unstructured triangle meshes:
    observed order of the L2 errors of velocity and pressure."""
    t0 = time.perf_counter()
    ns, (tol_u, tol_p) = MMS_LEVELS[level]
    errs = [mms.run_level(r) for r in ns]
    h = [e.h for e in errs]
    order_u = mms.observed_order(h, [e.velocity for e in errs])
    order_p = mms.observed_order(h, [e.pressure for e in errs])
    comparisons = (
        Comparison.of("velocity L2 observed order (error: shortfall from 2)", order_u, 2.0, 2.0 - order_u, tol_u),
        Comparison.of("pressure L2 observed order (error: shortfall from 2)", order_p, 2.0, 2.0 - order_p, tol_p),
    )
    details = dict(meshes=[dict(refinements=n, cells=e.n_cells, h=e.h, velocity_l2=e.velocity, pressure_l2=e.pressure,
                                status=e.status) for n, e in zip(ns, errs, strict=True)])
    return ValidationReport("mms", level, validate_mms.__doc__.split("\n")[0], comparisons,
                            time.perf_counter() - t0, details)


# -------------------------------------------------------------------------------------------- cylinder
#: Cylinder tolerances per level in % of the reference (C_D, Δp) and absolute (C_L). coarse (1 826 cells):
#: measured errors C_D 1.1 %, Δp 1.5 %, C_L 0.0022 with linear upwind; first-order upwind convection on the
#: same mesh gives C_D 13 %, Δp 2.5 %, C_L 0.027, so C_D <= 2 %, Δp <= 2 %, C_L <= 0.004 catch it.
#: medium (7 124 cells) and fine (17 770 cells): the tolerances of issue 4.
CYLINDER_TOLERANCES = {"coarse": {"C_D": 2.0, "dp": 2.0, "C_L": 0.004},
                       "medium": {"C_D": 0.5, "dp": 1.0, "C_L": 0.002},
                       "fine": {"C_D": 0.5, "dp": 1.0, "C_L": 0.002}}


def validate_cylinder(level: str) -> ValidationReport:
    """Schäfer–Turek DFG 2D-1 (Re = 20, steady): drag and lift coefficients of the cylinder and the
    front-rear pressure difference vs the FeatFlow reference values."""
    t0 = time.perf_counter()
    res, c = cylinder.run_cylinder(level)
    tol = CYLINDER_TOLERANCES[level]
    ref, val = cylinder.REFERENCE, c.as_dict()
    comparisons = (
        Comparison.of("C_D (error: % of reference)", val["C_D"], ref["C_D"],
                      100 * abs(val["C_D"] / ref["C_D"] - 1), tol["C_D"]),
        Comparison.of("dp = p(0.15,0.2) - p(0.25,0.2), Pa (error: % of reference)", val["dp"], ref["dp"],
                      100 * abs(val["dp"] / ref["dp"] - 1), tol["dp"]),
        Comparison.of("C_L (error: absolute)", val["C_L"], ref["C_L"], abs(val["C_L"] - ref["C_L"]), tol["C_L"]),
    )
    details = dict(_run_summary(res), cells_by_type={k: len(v) for k, v in res.mesh.cells.items()},
                   mesh=dict(cylinder.LEVELS[level]))
    return ValidationReport("cylinder", level, validate_cylinder.__doc__.split("\n")[0], comparisons,
                            time.perf_counter() - t0, details)


# ------------------------------------------------------------------------------------------ flat plate
#: Flat-plate tolerances per level, % of the TMR value (c_f at x = 0.97, plate C_D). coarse (3 840 cells,
#: y+ < 0.6): measured 2.1 % / 2.2 % low with SST (CFL3D on its 3 264-cell grid: 2.4 % / 2.3 % low); without
#: a turbulence model (laminar) 89 % / 85 % low, and with F1 = 0 (k-epsilon branch everywhere) 22 % / 23 %
#: high, so 5 % catches both. With F1 = 1 everywhere (the k-omega branch) c_f is 0.9 % high: on this case
#: (zero pressure gradient, TMR freestream) the coarse level cannot separate it (the f1 unit tests do).
#: medium (11 520 cells, measured 0.8 % / 0.9 %) and fine (28 672 cells, 0.2 % / 0.3 %): the issue's 2 % (c_f)
#: and 3 % (C_D).
FLATPLATE_TOLERANCES = {"coarse": {"cf": 5.0, "C_D": 5.0}, "medium": {"cf": 2.0, "C_D": 3.0},
                        "fine": {"cf": 2.0, "C_D": 3.0}}


def validate_flatplate(level: str) -> ValidationReport:
    """NASA TMR zero-pressure-gradient flat plate (SST, Re = 5e6/m): c_f(0.97) and plate C_D vs TMR.

    SST-2003 with the ``low_re`` wall treatment (y+ < 1); reference: TMR SST results (CFL3D, finest grid).
    """
    t0 = time.perf_counter()
    res, c = flatplate.run_flatplate(level)
    tol = FLATPLATE_TOLERANCES[level]
    ref, err = flatplate.REFERENCE, c.errors()
    comparisons = (
        Comparison.of("c_f at x = 0.97 (error: % of reference)", c.cf_097, ref["cf_x0.97"],
                      100 * err["cf_x0.97"], tol["cf"]),
        Comparison.of("plate C_D, L = 2 (error: % of reference)", c.cd, ref["C_D"], 100 * err["C_D"],
                      tol["C_D"]),
    )
    details = dict(_run_summary(res), mesh=dict(flatplate.LEVELS[level]), wall_treatment="low_re",
                   y_plus_max=float(c.y_plus[c.x > 0.05].max()),
                   ms_per_iteration=round(1e3 * res.wall_time / max(res.iterations, 1), 2))
    return ValidationReport("flatplate", level, validate_flatplate.__doc__.split("\n")[0], comparisons,
                            time.perf_counter() - t0, details)


#: Validation cases by name: ``f(level) -> ValidationReport``.
CASES: dict[str, Callable[[str], ValidationReport]] = {
    "cavity": validate_cavity,
    "cylinder": validate_cylinder,
    "flatplate": validate_flatplate,
    "mms": validate_mms,
    # NASA TMR NACA 0012 (SST, Re 6e6), solver/naca0012.py; imported on use; alpha 0 or 10 (None: both)
    "naca0012": lambda level, alpha=None: __import__("solver.naca0012", fromlist=["_"]).validate_naca0012(
        level, alpha),
}


def run_case(name: str, level: str = "coarse", **options) -> ValidationReport:
    """Run validation case ``name`` (:data:`CASES`) at ``level`` (:data:`LEVELS`); ``options`` go to the
    case (``alpha`` for ``naca0012``)."""
    if name not in CASES:
        raise ValueError(f"unknown validation case {name!r}; choose from {sorted(CASES)}")
    if level not in LEVELS:
        raise ValueError(f"unknown level {level!r}; choose from {list(LEVELS)}")
    return CASES[name](level, **options)
