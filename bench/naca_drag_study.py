"""Where the NACA 0012 same-mesh drag difference comes from, and where each code's drag converges.

Two measurements on the runs of ``bench/bench_naca_openfoam.py`` (its ``--work`` directory and its JSON lines),
docs/explanation/validation.md (the drag row and its open point):

* **Total pressure lost round the nose.** p0 = p − 2/3 k + |u|²/2 with ρ = 1, U∞ = 1 and p∞ = 0 on the outflow, so
  p0∞ = 1/2 (both codes hold the modified pressure p + 2/3 k). Outside the boundary layer (ν_t/ν < 1) the exact
  flow loses no total pressure, so a deficit there is the discretisation's. Its flux through a wall-normal grid
  line, Σ (p0∞ − p0) (u·n) Δl / (q∞ U∞ c) over the cells outside the boundary layer within 0.2 c of the wall, is a
  drag coefficient: the power lost so far per unit q∞ U∞ c.
* **Three-level Richardson extrapolation** (coarse, medium, fine C-mesh; spacing h ∝ cells^-1/2) of C_L, C_D and
  C_D's pressure and viscous parts of each code: the observed order p from the three levels and the extrapolated
  value f_fine + (f_fine − f_medium)/(r^p − 1).

    python bench/naca_drag_study.py --work runs/bench_naca_openfoam --alpha 10 --records naca.jsonl \\
        --figure docs/figures/validation/naca0012_total_pressure_loss.png
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from solver.validation.meshes.naca_mesh import naca0012_cmesh
from solver.validation.naca0012 import REYNOLDS
from solver.validation.naca_openfoam import (
    INVISCID_NUT,
    NEAR_FIELD,
    lift,
    load_records,
    loss_flux,
    richardson,
    total_pressure_deficit,
    wall_force_parts,
)
from solver.validation.openfoam import latest_time, read_field

ROOT = Path(__file__).parents[1]
LEVELS = ("coarse", "medium", "fine")
#: Stations (x/c of the wall-normal grid line) of the loss-flux table.
STATIONS = (0.01, 0.02, 0.05, 0.1, 0.3, 0.6, 0.9)
CODES = ("millfoil", "openfoam")


def load_fields(work: Path, level: str, alpha: float, n_cells: int) -> dict[str, dict[str, np.ndarray]]:
    """``{code: {u (n, 2), p, k, nut}}`` of both codes' runs of one level and angle (kinematic, ρ = 1): OpenFOAM's
    latest written time and millfoil's state file (``millfoil_state.npz``, the default's)."""
    case = work / level / f"alpha{alpha:g}"
    last = latest_time(case / "openfoam")
    if last is None:
        raise FileNotFoundError(f"no OpenFOAM result under {case / 'openfoam'}")
    of = {"u": read_field(last / "U", n_cells)[0][:, :2], "p": read_field(last / "p", n_cells)[0],
          "k": read_field(last / "k", n_cells)[0], "nut": read_field(last / "nut", n_cells)[0]}
    with np.load(case / "millfoil_state.npz") as z:
        mf = {"u": z["u"], "p": z["p"], "k": z["k"], "nut": z["nu_t"]}
    return {"millfoil": mf, "openfoam": of}


def with_force_parts(record: dict, mesh, alpha: float) -> dict:
    """``record`` with C_D's pressure and viscous parts, from its wall C_p and c_f on ``mesh`` where it lacks them
    (the older OpenFOAM records)."""
    if "c_d_pressure" in record:
        return record
    return record | wall_force_parts(mesh, record["wall"], alpha)


def convergence_table(records: dict, alpha: float) -> str:
    """Markdown: each code's C_L (the window mean of an oscillating run), C_D, C_D,p, C_D,v on the three levels, the
    observed order and the extrapolation."""
    rows = ["| code | quantity | coarse | medium | fine | observed order | extrapolated |", "| --- " * 7 + "|"]
    meshes = [naca0012_cmesh(level, alpha_deg=alpha).mesh for level in LEVELS]
    cells = [m.n_cells for m in meshes]
    for code in CODES:
        recs = [records.get((level, alpha, code)) for level in LEVELS]
        if any(r is None or "error" in r for r in recs):
            rows.append(f"| {code} | (a level is missing) | | | | | |")
            continue
        recs = [with_force_parts(r, m, alpha) for r, m in zip(recs, meshes, strict=True)]
        for key in ("c_l", "c_d", "c_d_pressure", "c_d_viscous"):
            vals = [lift(r) if key == "c_l" else r[key] for r in recs]      # C_L: window mean if oscillating
            p, ext = richardson(vals, cells)
            rows.append(f"| {code} | {key} | " + " | ".join(f"{v:.5f}" for v in vals)
                        + f" | {'—' if p is None else f'{p:.2f}'} | {'—' if ext is None else f'{ext:.5f}'} |")
    return "\n".join(rows)


def loss_table(work: Path, alpha: float, levels) -> tuple[str, dict]:
    """Markdown: the loss flux of both codes at :data:`STATIONS`, per level and side; and the deficit fields
    (for the figure)."""
    rows = ["| level | side | code | " + " | ".join(f"x/c {x:g}" for x in STATIONS) + " |",
            "| --- " * (3 + len(STATIONS)) + "|"]
    fields = {}
    for level in levels:
        cm = naca0012_cmesh(level, alpha_deg=alpha)
        data = load_fields(work, level, alpha, cm.mesh.n_cells)
        fields[level] = (cm, data)
        for side in ("upper", "lower"):
            for code in CODES:
                vals = [loss_flux(cm, data[code], x, side) for x in STATIONS]
                rows.append(f"| {level} | {side} | {code} | " + " | ".join(f"{v:+.5f}" for v in vals) + " |")
    return "\n".join(rows), fields


def figure(fields: dict, alpha: float, path: Path) -> None:
    """Total-pressure deficit round the nose, a row per level, millfoil left and OpenFOAM right, with the
    ν_t/ν = 1 line (the boundary layer's edge)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(fields), 2, figsize=(10, 3.6 * len(fields) + 0.3), sharex=True, sharey=True,
                             constrained_layout=True, squeeze=False)
    for row, (level, (cm, data)) in enumerate(fields.items()):
        n_i, n_j = cm.xy.shape[0] - 1, cm.xy.shape[1] - 1
        centre = cm.mesh.centroid.reshape(n_i, n_j, 2)
        wall = cm.xy[cm.spec.n_wake:cm.spec.n_wake + 2 * cm.spec.n_side + 1, 0]
        for col, code in enumerate(CODES):
            ax = axes[row, col]
            deficit = 100 * total_pressure_deficit(data[code]).reshape(n_i, n_j)
            image = ax.pcolormesh(cm.xy[..., 0], cm.xy[..., 1], deficit, cmap="RdBu_r", vmin=-12, vmax=12,
                                  shading="flat")
            ax.contour(centre[..., 0], centre[..., 1], data[code]["nut"].reshape(n_i, n_j) * REYNOLDS,
                       levels=[INVISCID_NUT], colors="k", linewidths=0.6)
            ax.fill(wall[:, 0], wall[:, 1], color="0.6")
            ax.set(xlim=(-0.02, 0.06), ylim=(-0.03, 0.05), aspect="equal",
                   title=f"{'millfoil' if code == 'millfoil' else 'OpenFOAM'}, {level}, α = {alpha:g}°")
    fig.colorbar(image, ax=axes, label="total-pressure deficit (p0∞ − p0)/q∞ [%]  (black: ν_t/ν = 1)")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--work", type=Path, default=ROOT / "runs" / "bench_naca_openfoam",
                        help="bench_naca_openfoam's --work directory (both codes' runs of each level)")
    parser.add_argument("--alpha", type=float, default=10.0)
    parser.add_argument("--levels", nargs="+", default=list(LEVELS), choices=LEVELS)
    parser.add_argument("--records", nargs="*", type=Path, default=[], help="JSONL records for the extrapolation")
    parser.add_argument("--figure", type=Path, default=None, help="PNG of the deficit round the nose")
    args = parser.parse_args(argv)
    if args.records:
        print(f"## Three-level extrapolation, α = {args.alpha:g}°\n")
        print(convergence_table(load_records(args.records), args.alpha) + "\n")
    table, fields = loss_table(args.work, args.alpha, args.levels)
    print(f"## Loss flux outside the boundary layer (ν_t/ν < {INVISCID_NUT:g}, d < {NEAR_FIELD:g} c), as C_D\n")
    print(table)
    if args.figure:
        figure(fields, args.alpha, args.figure)
        print(f"\nwrote {args.figure}")


if __name__ == "__main__":
    main()
