"""A made-up campaign store, written through the store's API, for tests and demonstrations without CFD.

The designs are real blades (small perturbations of the Table 5 tool-path blade or the Table 4 design
blade, so that the geometry gallery and the NC export can rebuild them); their figures are **invented**:
|F_Y| and C_max follow a smooth trade-off of the camber angles with noise, in the ranges of the paper's
Table 7. Statuses, convergence classes, oscillation amplitudes, times and generations are spread so that
every section of a report has something to show. Nothing here is a result: the campaign row's message
says "synthetic".
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from geometry.examples import TABLE4_C2_DESIGN
from optimizer.campaign.config import CampaignConfig
from optimizer.campaign.fields import fields_path, write_fields
from optimizer.campaign.status import EvaluationStatus as Status
from optimizer.campaign.store import STORE_NAME, EvaluationRow, GenerationRow, Store
from optimizer.figures import lift_coefficient, pressure_coefficient_min
from solver.convergence import ConvergenceClass

#: Table 5 of the paper (tool-path G1, R = 5 mm; d_s4 = d_p4 = 2 mm machined, see configs/examples).
TABLE5_G1_TOOLPATH = {"L": 0.1, "alpha": 30.0, "beta1": 0.0, "beta1bar": 60.0, "R": 0.005, "u_s2": 0.2,
                      "d_s1": 0.013, "d_s2": 0.019, "d_s3": 0.020, "d_s4": 0.002, "u_p2": 0.25, "d_p1": 0.012,
                      "d_p2": 0.014, "d_p3": 0.025, "d_p4": 0.002}
_FIXED = ("L", "R", "d_s4", "d_p4")


def synthetic_run(directory: str | Path, *, mode: str = "toolpath", population: int = 6, generations: int = 4,
                  seed: int = 0, finished: bool = True, fields: int = 0) -> Path:
    """Write a made-up campaign of ``generations`` × ``population`` designs into ``directory``; returns it.

    ``mode``: ``toolpath`` (Table 5 G1 family) or ``design`` (Table 4 C2 family). ``finished``: the campaign
    state (else ``running``, as a report of a running campaign sees it). ``fields``: write made-up fields
    files (:func:`synthetic_fields`) for that many designs of the front (the others have none).
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    base = TABLE5_G1_TOOLPATH if mode == "toolpath" else dict(TABLE4_C2_DESIGN["parameters"])
    continuity = "G1" if mode == "toolpath" else TABLE4_C2_DESIGN["continuity"]
    config = CampaignConfig.from_mapping({
        "blade": {"mode": mode, "continuity": continuity},
        "algorithm": {"population": population, "generations": generations, "seed": seed},
        "execution": {"backend": "inline"}, "output": {"directory": str(directory)}})
    rng = np.random.default_rng(seed)
    names = [n for n in base if n not in _FIXED]
    with Store(directory / STORE_NAME, sync="normal") as store:
        store.start_campaign(config.to_yaml(), seed, "0.1.0")
        store.set_reference([-10000.0, 16.0])
        members: list[str] = []
        for g in range(generations):
            keys = []
            for i in range(population):
                values = {n: base[n] * (1 + 0.06 * (rng.random() - 0.5)) if n in names else base[n] for n in base}
                key = hashlib.sha256(f"synthetic {seed} {g} {i}".encode()).hexdigest()
                row = _row(key, g, names, values, rng, i)
                store.add(row)
                keys.append(row.key)
            members = _survivors(store, members + keys, population)
            store.add_generation(_generation(store, g, members, keys))
        if finished:
            store.end_campaign("finished", "synthetic campaign: made-up figures for tests and demonstrations")
        front = store.front()
    for row in front[:fields]:
        synthetic_fields(directory, row, mode, continuity)
    return directory


def synthetic_fields(directory: Path, row: EvaluationRow, mode: str, continuity: str, c0: float = 10.0) -> Path:
    """Write a made-up fields file for ``row`` through the campaign's writer
    (:func:`optimizer.campaign.fields.write_fields`): the real blade outline (rebuilt from its parameters)
    with **invented** wall values and an invented velocity field (a uniform stream of ``c0`` m/s with a bump
    near the blade). Nothing in it is a result."""
    from geometry import BladeSpec, build_profile

    profile = build_profile(BladeSpec.from_values(mode, continuity, row.parameters))
    return write_fields(synthetic_evaluation(profile.points, c0), fields_path(directory, row.key), c0=c0)


def synthetic_evaluation(points: np.ndarray, c0: float = 10.0) -> SimpleNamespace:
    """An object shaped like :class:`optimizer.evaluation.Evaluation` for the fields writer: ``wall`` (a
    :class:`~optimizer.evaluation.WallDistribution` on the closed outline ``points (n, 2)``, m, split at its
    leftmost and rightmost points, the upper chain as suction side) and ``artifacts.flow`` with a ``sample``
    method. The values are invented (smooth shapes in plausible ranges)."""
    from optimizer.evaluation import WallDistribution

    le, te = int(np.argmin(points[:, 0])), int(np.argmax(points[:, 0]))
    a, b = sorted((le, te))
    chains = [points[a:b + 1], np.vstack([points[b:], points[:a + 1]])]
    chains = [c if np.allclose(c[0], points[le]) else c[::-1] for c in chains]     # both from the leading edge
    upper = int(np.argmax([c[:, 1].mean() for c in chains]))
    parts = []
    for side, chain in (("suction", chains[upper]), ("pressure", chains[1 - upper])):
        mid = 0.5 * (chain[1:] + chain[:-1])
        length = np.linalg.norm(np.diff(chain, axis=0), axis=1)
        s = np.cumsum(length) - 0.5 * length
        t = s / s[-1]
        sign = 1.0 if side == "suction" else -0.4
        cp = 1.0 - (1.0 + sign * 0.6 * np.sqrt(t) * (1.0 - t) * 3.0) ** 2 * (1.0 - np.exp(-60.0 * t))
        cf = 0.004 / np.sqrt(t + 0.02) * (1.0 - 0.8 * t if side == "suction" else 1.0)
        parts.append((np.full(s.size, side), s, mid, cp, cf, 20.0 + 40.0 * np.sqrt(t), length))
    side, s, mid, cp, cf, yp, length = (np.concatenate(v) for v in zip(*parts, strict=True))
    wall = WallDistribution(side=side, s=s, x=mid[:, 0], y=mid[:, 1], cp=cp, cf=cf, y_plus=yp, length=length)
    centre, chord = points.mean(axis=0), float(np.ptp(points[:, 0]))

    def sample(xy: np.ndarray, which: str = "u") -> np.ndarray:
        r2 = ((np.asarray(xy) - centre) ** 2).sum(axis=1) / (0.4 * chord) ** 2
        return np.column_stack([c0 * (1.0 + 0.3 * np.exp(-r2)), 0.1 * c0 * np.exp(-r2)])

    return SimpleNamespace(wall=wall, artifacts=SimpleNamespace(flow=SimpleNamespace(sample=sample)))


def _row(key: str, generation: int, names: list[str], values: dict, rng: np.random.Generator,
         index: int) -> EvaluationRow:
    x = [values[n] for n in names]
    camber = 0.8 * (values["beta1bar"] - 55.0) + 25.0 * math.sin(math.radians(values["alpha"]))
    lift = 60.0 + camber + 3.0 * rng.normal()
    c_max = 10.5 + 0.02 * lift + 0.4 * rng.random()
    draw = rng.random()
    base = dict(key=key, generation=generation, x=x, parameters=values, finished=_time(generation, index),
                submitted=_time(generation, index - 1), worker=f"tcp://127.0.0.1:{40000 + index % 2}")
    constraints = {"eq21_inlet": -0.5, "eq21_outlet": -0.5, "eq22_curvature": -0.2, "sides_simple": -1.0,
                   "machined_intact": -1.0, "evaluation": 0.0}
    if draw < 0.1:
        return EvaluationRow(**base, status=Status.INFEASIBLE, reason="eq22_curvature: radius 4.1 mm < R = 5 mm",
                             minimised=[1e12, 1e12], constraints={**constraints, "eq22_curvature": 0.18})
    if draw < 0.2:
        return EvaluationRow(**base, status=Status.MESH_FAILED, reason="a cell is below the quality thresholds",
                             minimised=[1e12, 1e12], constraints={**constraints, "evaluation": 1e12},
                             seconds={"geometry": 0.2, "mesh": 3.0, "total": 3.2}, wall_seconds=3.3)
    cls = (ConvergenceClass.OSCILLATING if draw > 0.75
           else ConvergenceClass.STATIONARY if draw > 0.6 else ConvergenceClass.CONVERGED)
    amplitude = 0.008 * lift if cls == ConvergenceClass.OSCILLATING else 0.0
    span = 0.004                                  # 0.04 L, m: lift is in N over the span, fy in N/m
    fy = -lift / span
    figures = {"fx": 0.1 * lift / span, "fy": fy, "fx_span": 0.1 * lift, "fy_span": -lift,
               "c_l": lift_coefficient(lift, 998.2, 10.0, 0.1, span), "c_max": c_max,
               "cp_min": pressure_coefficient_min(c_max, 10.0),
               "yplus_max": 80.0, "yplus_mean": 35.0}
    monitors = {"fy:blade": {"mean": fy, "amplitude": amplitude / span, "drift": 0.0,
                             "period": 40 if amplitude else None, "status": cls},
                "c_max": {"mean": c_max, "amplitude": amplitude * c_max / lift, "drift": 0.0,
                          "period": 40 if amplitude else None, "status": cls}}
    solve = 40.0 + 30.0 * rng.random()
    return EvaluationRow(**base, status=Status.OK, reason="", convergence=cls, objectives={"|fy|": -fy, "c_max": c_max},
                         minimised=[fy, c_max], constraints=constraints, figures=figures, monitors=monitors,
                         cells=9000 + int(2000 * rng.random()), iterations=800 + int(600 * rng.random()),
                         seconds={"geometry": 0.2, "mesh": 3.0, "solve": solve, "post": 0.3, "total": solve + 3.5},
                         wall_seconds=solve + 3.6)


def _time(generation: int, index: int) -> str:
    seconds = 3600 * generation + 60 * (index + 1)
    return f"2026-01-01T{seconds // 3600:02d}:{seconds // 60 % 60:02d}:{seconds % 60:02d}.000000+00:00"


def _survivors(store: Store, keys: list[str], size: int) -> list[str]:
    """The best ``size`` of ``keys``: feasible first, by |F_Y| − 5 C_max (a stand-in for NSGA-II)."""
    rows = store.get_many(keys)
    return sorted(dict.fromkeys(keys), key=lambda k: (not rows[k].feasible,
                                                      rows[k].minimised[0] / 250.0 + 5 * rows[k].minimised[1]))[:size]


def _generation(store: Store, g: int, members: list[str], offspring: list[str]) -> GenerationRow:
    rows = store.get_many(members + offspring)
    F = np.array([rows[k].minimised for k in members if rows[k].feasible])
    hv = _hypervolume(F, np.array([-10000.0, 16.0])) if len(F) else None
    feasible = sum(rows[k].status != Status.INFEASIBLE for k in offspring)
    return GenerationRow(g, members, [0 if rows[k].feasible else None for k in members],
                         [1.0 if rows[k].feasible else None for k in members], offspring, feasible,
                         feasible / len(offspring), 0, hv, {"synthetic": True}, finished=_time(g, 59))


def _hypervolume(F: np.ndarray, ref: np.ndarray) -> float:
    """2-objective hypervolume (minimised) of the points that dominate ``ref``."""
    F = F[np.all(F < ref, axis=1)]
    F = F[np.argsort(F[:, 0])]
    area, best = 0.0, ref[1]
    for f0, f1 in F:
        if f1 < best:
            area += (ref[0] - f0) * (best - f1)
            best = f1
    return float(area)
