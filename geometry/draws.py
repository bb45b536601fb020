"""Seeded random feasible blades: rejection sampling of Table 6's parameter spaces, one draw at a time.

Each draw is one uniform design vector of a :class:`~geometry.parameters.ParameterSpace`
(:meth:`~geometry.parameters.ParameterSpace.sample` with ``n = 1``), kept when :func:`~geometry.evaluate_blade`
finds the blade feasible. Drawing one vector at a time makes the sequence of blades depend on the seed and
the order of the spaces only, so a blade is named by its index in the draw (the bench scripts' ``--indices``).
The campaign's initial population is drawn in batches with its own prescreen
(:func:`optimizer.campaign.problem.initial_population`).

Example::

    >>> import numpy as np
    >>> from geometry import ParameterSpace
    >>> spec, result, draws = draw_feasible(ParameterSpace.default("design", "G1"), np.random.default_rng(1), 1000)
    >>> result.feasible
    True
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from geometry.feasibility import BladeResult, evaluate_blade
from geometry.parameters import BladeSpec, ParameterSpace

#: Every (mode, continuity) pair of the paper's Table 6, design mode first.
COMBINATIONS = tuple((m, c) for m in ("design", "toolpath") for c in ("G0", "G1", "C1", "G2", "C2"))


def draw_feasible(space: ParameterSpace, rng: np.random.Generator,
                  max_draws: int) -> tuple[BladeSpec | None, BladeResult | None, int]:
    """Draw uniform blades of ``space`` until one is feasible, at most ``max_draws`` (>= 0) of them.

    Returns ``(spec, result, draws)``: the feasible blade, its :class:`~geometry.BladeResult` and the number of
    draws it took (the rejected ones included); ``(None, None, max_draws)`` when none of ``max_draws`` was
    feasible."""
    for draws in range(1, max_draws + 1):
        spec = space.spec(space.sample(1, rng)[0])
        result = evaluate_blade(spec)
        if result.feasible:
            return spec, result, draws
    return None, None, max_draws


def draw_blades(n: int, seed: int, max_draws: int = 200_000,
                combinations: Sequence[tuple[str, str]] = COMBINATIONS) -> list[tuple[str, str, dict[str, float]]]:
    """``n`` feasible blades ``(mode, continuity, parameters)`` round robin over ``combinations`` (one blade of
    each in turn), drawn from one generator of ``seed``; fewer when ``max_draws`` draws in all are not enough.
    Parameters are in the units of :class:`~geometry.parameters.BladeSpec` (metres, degrees)."""
    rng = np.random.default_rng(seed)
    spaces = {mc: ParameterSpace.default(*mc) for mc in combinations}
    out: list[tuple[str, str, dict[str, float]]] = []
    draws = 0
    while len(out) < n and draws < max_draws:
        mode, continuity = combinations[len(out) % len(combinations)]
        spec, _, used = draw_feasible(spaces[(mode, continuity)], rng, max_draws - draws)
        draws += used
        if spec is not None:
            out.append((mode, continuity, {name: float(v) for name, v in spec.values.items()}))
    return out
