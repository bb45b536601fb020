"""What a validation case returns: :class:`Comparison` records in a :class:`ValidationReport`, and the levels.

Shared by every case module of :mod:`solver.validation` (which imports the cases; this module imports none
of them). A :class:`Comparison` gives ``error`` and ``tolerance`` in the same unit, named in ``name``; it
passes when ``error <= tolerance``. Observed orders of accuracy are compared with the formal order 2:
``error`` is the shortfall ``2 - observed`` and ``tolerance`` the allowed shortfall (0.2 means "order >= 1.8").
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

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


def run_summary(res) -> dict:
    """Cells, iterations, status and solve time of a :class:`solver.results.FlowResults`."""
    return dict(cells=res.mesh.n_cells, iterations=res.iterations, status=res.status,
                converged=res.converged, solve_seconds=round(res.wall_time, 3))
