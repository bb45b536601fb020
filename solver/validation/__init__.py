"""Validation cases against published data, as called by ``millfoil validate <case>``: the case registry.

Every case is a function ``level -> ValidationReport``, registered in :data:`CASES`; :func:`run_case` looks
one up by name. Levels (:data:`LEVELS`):

* ``coarse``: CI size (seconds), with tolerances loosened to what the coarse mesh allows but still tight
  enough to fail a wrong scheme (each case states why);
* ``medium`` and ``fine``: the acceptance figures with their agreed tolerances (docs/explanation/validation.md), on
two resolutions.

Layout: one module per case (:mod:`.cavity`, :mod:`.cylinder`, :mod:`.flatplate`, :mod:`.mms`,
:mod:`.naca0012`: the physics set-up, the comparison with the reference and its ``validate_*`` function),
their mesh generators in :mod:`.meshes`, the published reference tables in ``reference/``, and the records
they return in :mod:`.report`. Dependencies point one way: this registry imports the cases, the cases import
:mod:`.report`, :mod:`.meshes` and the solver core, and the solver core imports nothing from here.
"""

from __future__ import annotations

from collections.abc import Callable

from .cavity import validate_cavity
from .cylinder import validate_cylinder
from .flatplate import validate_flatplate
from .mms import validate_mms
from .naca0012 import validate_naca0012
from .report import LEVELS, Comparison, ValidationReport

#: Validation cases by name: ``f(level, **options) -> ValidationReport`` (``naca0012`` takes ``alpha``: 0 or
#: 10 deg, None: both).
CASES: dict[str, Callable[..., ValidationReport]] = {
    "cavity": validate_cavity,
    "cylinder": validate_cylinder,
    "flatplate": validate_flatplate,
    "mms": validate_mms,
    "naca0012": validate_naca0012,
}


def run_case(name: str, level: str = "coarse", **options) -> ValidationReport:
    """Run validation case ``name`` (:data:`CASES`) at ``level`` (:data:`LEVELS`); ``options`` go to the
    case (``alpha`` for ``naca0012``)."""
    if name not in CASES:
        raise ValueError(f"unknown validation case {name!r}; choose from {sorted(CASES)}")
    if level not in LEVELS:
        raise ValueError(f"unknown level {level!r}; choose from {list(LEVELS)}")
    return CASES[name](level, **options)


__all__ = ["CASES", "LEVELS", "Comparison", "ValidationReport", "run_case"]
