"""NASA TMR 2D zero-pressure-gradient flat plate with SST (coarse level, CI size) against the TMR data.

Acceptance tolerances on finer meshes (not run here): ``millfoil validate flatplate --level medium`` / ``fine``
(c_f(0.97) within 2 %, C_D within 3 %), and ``run_case('flatplate', 'fine')``.
"""

import numpy as np
import pytest

from solver.validation import CASES, run_case
from solver.validation.flatplate import (
    LEVELS,
    REFERENCE,
    X_CF,
    flatplate_mesh,
    flatplate_settings,
    geometric,
    load_reference_cf,
    run_flatplate,
)


def test_geometric_spacing():
    x = geometric(2.0, 48, 1e-3)
    h = np.diff(x)
    assert x[0] == 0 and x[-1] == pytest.approx(2.0) and h[0] == pytest.approx(1e-3, rel=1e-6)
    assert np.allclose(h[1:] / h[:-1], h[1] / h[0])


def test_mesh_geometry_and_groups():
    """Areas sum to the domain; the plate starts at x = 0; the first cell is at y+ < 1 by construction."""
    m = flatplate_mesh(**LEVELS["coarse"])
    assert m.volume.sum() == pytest.approx(2.33 * 1.0)
    assert set(m.group_names) == {"inlet", "outlet", "top", "symmetry", "plate"}
    xp = m.face_centre[m.boundary["plate"], 0]
    xs = m.face_centre[m.boundary["symmetry"], 0]
    assert xp.min() > 0 and xs.max() < 0 and np.allclose(m.face_centre[m.boundary["plate"], 1], 0)


def test_reference_files_keep_their_source_header():
    from solver.validation.flatplate import REFERENCE_DIR
    for name in ("tmr_2dzp_sst_cd_convergence.csv", "tmr_2dzp_sst_cf_x0p97_convergence.csv",
                 "tmr_2dzp_sst_cf_plate_finest_545x385.csv"):
        assert (REFERENCE_DIR / name).read_text().startswith("# turbmodels.larc.nasa.gov")
    x, cf = load_reference_cf()
    assert np.interp(X_CF, x, cf) == pytest.approx(REFERENCE["cf_x0.97"], rel=2e-3)


@pytest.fixture(scope="module")
def coarse():
    return run_case("flatplate", "coarse")


@pytest.mark.slow
def test_coarse_case_passes(coarse):
    """Coarse level (3 840 cells, y+ < 0.6, low_re): measured c_f(0.97) 2.1 % and C_D 2.2 % below TMR
    (CFL3D on its 3 264-cell grid: 2.4 % and 2.3 % below); tolerance 5 %, which F1 = 0 (+21 %) and no
    turbulence model (-89 %) fail (solver/validation.py)."""
    assert "flatplate" in CASES
    assert coarse.passed, coarse
    assert coarse.details["converged"]
    assert coarse.details["y_plus_max"] < 1.0


@pytest.mark.slow
def test_laminar_fails_coarse_tolerance():
    """Without the turbulence model the plate is laminar (Blasius c_f ~ 0.0003; converged: 89 % / 85 % low):
    far outside 5 % already after 100 iterations."""
    res, c = run_flatplate("coarse", laminar=True, settings=flatplate_settings(max_iter=100))
    assert c.errors()["cf_x0.97"] > 0.5 and c.errors()["C_D"] > 0.5


@pytest.mark.slow
def test_automatic_wall_treatment_at_y_plus_30():
    """Wall functions: the coarse plate with the first cell at y+ ~ 30 (3e-4 m first spacing, 64 normal cells)
    and the ``automatic`` treatment: measured c_f(0.97) 1.0 % and C_D 1.4 % above TMR (3 %: a failure means
    the wall-function shear or the wall-cell k/omega changed). ``low_re`` on such a mesh is ~9 % / 14 % off
    (docs/explanation/turbulence.md)."""
    res, c = run_flatplate("coarse", "automatic", mesh_overrides={"dy_wall": 3e-4})
    assert res.converged
    assert 20 < np.median(c.y_plus[c.x > 0.05]) < 40
    err = c.errors()
    assert err["cf_x0.97"] < 0.03 and err["C_D"] < 0.03
