"""The NACA 0012 side-by-side harness (solver.validation.naca_openfoam, run by bench/bench_naca_openfoam.py and
bench/naca_drag_study.py): the OpenFOAM case files it writes, its option types, its records and its report. No
OpenFOAM needed."""

from __future__ import annotations

import numpy as np
import pytest

from solver.validation.meshes.naca_mesh import CMeshSpec, naca0012_cmesh

SPEC = CMeshSpec(n_side=16, n_wake=8, ds_le=1e-2, ds_te=2e-2, first_cell=5e-3, growth=1.2, switch=0.02,
                 far_growth=1.5, radius=20.0)


def _mesh():
    return naca0012_cmesh(SPEC, alpha_deg=10.0).mesh


def test_naca_fv_schemes_gradient_options():
    """bench_naca_openfoam's fvSchemes: ``--u-gradient`` sets only the linear-upwind U gradient, ``--gradient``
    the default of every other gradient, ``--interpolation`` the face interpolation of the flux; the defaults are
    the results table's (Gauss linear, linear)."""
    from solver.validation.naca_openfoam import fv_schemes

    plain = fv_schemes()
    assert "default Gauss linear;" in plain and "gradU Gauss linear;" in plain
    text = fv_schemes("cellLimited Gauss linear 1", "pointCellsLeastSquares")
    assert "default pointCellsLeastSquares;" in text and "gradU cellLimited Gauss linear 1;" in text
    assert "div(phi,U) bounded Gauss linearUpwind gradU;" in text
    assert "interpolationSchemes { default linear; }" in plain       # the face flux of the results table
    skew = fv_schemes(interpolation="skewCorrected linear")           # --interpolation
    assert "interpolationSchemes { default skewCorrected linear; }" in skew and "gradU Gauss linear;" in skew



def test_naca_fv_solution_non_orthogonal_correctors():
    """``--of-non-orthogonal N`` sets simpleFoam's pressure non-orthogonal correctors (the fine mesh needs 2);
    the default is the results table's 0, and SIMPLEC stays on."""
    from solver.validation.naca_openfoam import fv_solution

    assert "nNonOrthogonalCorrectors 0;" in fv_solution(0.9, 0.8)
    fine = fv_solution(0.9, 0.8, non_orthogonal=2)
    assert "nNonOrthogonalCorrectors 2;" in fine and "consistent yes;" in fine
    assert "U 0.9;" in fine and '"(k|omega)" 0.8;' in fine

def test_wall_force_parts_add_up_to_the_wall_force():
    """The pressure and viscous parts of C_D and C_L from a wall record: a uniform C_p on a closed wall gives
    no force; a uniform c_f gives a viscous drag of about 2 c_f (both surfaces, chord 1) at alpha = 0."""
    from solver.validation.naca_openfoam import wall_force_parts

    mesh = _mesh()
    nw = len(mesh.boundary["wall"])
    parts = wall_force_parts(mesh, {"cp": np.ones(nw), "cf": np.zeros(nw)}, 0.0)
    assert abs(parts["c_d_pressure"]) < 1e-12 and abs(parts["c_l_pressure"]) < 1e-12
    parts = wall_force_parts(mesh, {"cp": np.zeros(nw), "cf": np.full(nw, 1e-3)}, 0.0)
    assert abs(parts["c_d_viscous"] - 2e-3) < 1e-4 and abs(parts["c_l_viscous"]) < 1e-6


def test_naca_drag_study_richardson_recovers_order_and_limit():
    """The drag study's Richardson extrapolation: three levels of f = f0 + C h^p on the validation meshes' cell
    counts (unequal refinement ratios) give back p and f0; values that no order explains (not monotone) give None."""
    from solver.validation.naca_openfoam import richardson

    cells = [10800, 21728, 41184]
    h = 1 / np.sqrt(np.asarray(cells, float))
    for p, f0, c in ((1.35, 0.0127, 3.0), (2.0, 1.06, -40.0)):
        order, limit = richardson(f0 + c * h ** p, cells)
        assert abs(order - p) < 1e-6 and abs(limit - f0) < 1e-9 * max(1.0, abs(f0))
    assert richardson([1.0, 2.0, 1.5], cells) == (None, None)


def test_naca_drag_study_total_pressure_loss_flux():
    """The free stream loses no total pressure; a uniform deficit δ in a uniform stream gives a loss flux of δ
    times the line's length within the near field (0.2 c), positive downstream on both surfaces."""
    from solver.validation.naca_openfoam import NEAR_FIELD, loss_flux, total_pressure_deficit

    cm = naca0012_cmesh(SPEC, alpha_deg=0.0)
    n = cm.mesh.n_cells
    free = {"u": np.tile([1.0, 0.0], (n, 1)), "p": np.zeros(n), "k": np.zeros(n), "nut": np.zeros(n)}
    assert np.allclose(total_pressure_deficit(free), 0.0)
    assert loss_flux(cm, free, 0.5, "upper") == 0.0
    delta = 0.02
    lossy = dict(free, p=np.full(n, -0.5 * delta))                 # (p0∞ − p0)/q∞ = δ everywhere
    for side in ("upper", "lower"):
        flux = loss_flux(cm, lossy, 0.5, side)
        assert 0.6 * delta * NEAR_FIELD < flux < 1.2 * delta * NEAR_FIELD


def test_naca_options_refuse_negative_values():
    """``--of-non-orthogonal`` takes an integer >= 0 and ``--mf-cl-rel`` a number >= 0 (:func:`non_negative`);
    otherwise argparse names what it got and exits with 2."""
    import argparse

    from solver.validation.naca_openfoam import non_negative

    parser = argparse.ArgumentParser()
    parser.add_argument("--n", type=non_negative(int), default=0)
    parser.add_argument("--r", type=non_negative(float), default=1e-4)
    assert parser.parse_args(["--n", "2", "--r", "0"]) == argparse.Namespace(n=2, r=0.0)
    for option, bad in (("--n", "-1"), ("--n", "two"), ("--r", "-1e-4"), ("--r", "nan"), ("--r", "tight")):
        with pytest.raises(SystemExit) as exc:
            parser.parse_args([option, bad])
        assert exc.value.code == 2


def test_naca_resumed_case_joins_its_coefficients_and_cpu(tmp_path):
    """``--of-resume``: the controlDict starts from the latest time; the record reads the forceCoeffs files of every
    start in time order (10000 after 4000, not before it) and adds the CPU seconds of every simpleFoam log."""
    from solver.validation.naca_openfoam import cpu_seconds, read_coefficients, write_controls

    write_controls(tmp_path, 10.0, 12000, resume=True)
    control = (tmp_path / "system/controlDict").read_text()
    assert "startFrom latestTime;" in control and "endTime 12000;" in control
    write_controls(tmp_path, 10.0, 4000)
    assert "startFrom startTime;" in (tmp_path / "system/controlDict").read_text()
    header = "# Force coefficients\n#\n# Time\tCd\tCs\tCl\n"
    for start, rows in (("0", [(1, 0.5, 0, 1.0), (4000, 0.02, 0, 1.5)]), ("10000", [(10001, 0.019, 0, 1.58)]),
                        ("4000", [(4001, 0.0201, 0, 1.51), (10000, 0.0195, 0, 1.57)])):
        body = "".join("\t".join(str(v) for v in r) + "\n" for r in rows)
        (tmp_path / "postProcessing/forceCoeffs" / start).mkdir(parents=True)
        (tmp_path / "postProcessing/forceCoeffs" / start / "coefficient.dat").write_text(header + body)
    c = read_coefficients(tmp_path)
    assert c["Time"].tolist() == [1, 4000, 4001, 10000, 10001] and c["Cl"][-1] == 1.58 and c["Cd"][1] == 0.02
    (tmp_path / "log.simpleFoam.4000").write_text("ExecutionTime = 100.5 s  ClockTime = 101 s\n")
    (tmp_path / "log.simpleFoam").write_text("ExecutionTime = 3 s\nExecutionTime = 20.25 s  ClockTime = 21 s\n")
    assert cpu_seconds(tmp_path) == 120.75


def test_naca_criteria_names_the_angles_outside_each_tolerance():
    """The criteria summary: lift from 2° and drag from 0° up to the reference's C_L,max, not beyond; the angle of
    C_L,max of each code; an oscillating run by its window mean; the level-to-level C_L change of both codes."""
    from solver.validation.naca_openfoam import criteria

    def rec(c_l, c_d, window=None):
        r = {"c_l": c_l, "c_d": c_d, "converged": window is None, "cl_spread_window": 1e-2 if window else None}
        return r | ({"cl_mean_window": window} if window else {})

    records = {("coarse", 0.0, "openfoam"): rec(0.001, 0.0100), ("coarse", 0.0, "millfoil"): rec(0.0, 0.0101),
               ("coarse", 2.0, "openfoam"): rec(0.200, 0.0100), ("coarse", 2.0, "millfoil"): rec(0.203, 0.0096),
               ("coarse", 10.0, "openfoam"): rec(1.000, 0.0150), ("coarse", 10.0, "millfoil"): rec(1.009, 0.0150),
               ("coarse", 12.0, "openfoam"): rec(9.0, 0.0300, window=0.9),  # oscillating: C_L,max stays at 10°
               ("coarse", 12.0, "millfoil"): rec(0.950, 0.0200),
               ("medium", 10.0, "openfoam"): rec(1.010, 0.0140), ("medium", 10.0, "millfoil"): rec(1.0292, 0.0142)}
    text = criteria(records)
    coarse = next(line for line in text.splitlines() if line.startswith("| coarse"))
    assert "| 0, 2, 10, 12 | 10° / 10° |" in coarse
    assert "2° (+1.50 %)" in coarse and "10°" not in coarse.split("|")[4]      # lift: 10° is +0.90 %
    assert "2° (-4.00 %)" in coarse and "12°" not in coarse.split("|")[5]      # drag: 12° is past C_L,max
    assert "- C_L coarse → medium (millfoil / openfoam): 10° +2.00 / +1.00 %" in text
    medium = next(line for line in text.splitlines() if line.startswith("| medium"))
    assert medium.split("|")[4].strip() == "10° (+1.90 %)" and medium.split("|")[5].strip() == "none"
