"""SST closures (limits of each blending function and limiter), wall distance, the automatic wall law,
inlet turbulence, positivity of k and omega in a short turbulent run, and the laminar path unchanged.

Flat-plate validation against NASA TMR: ``tests/solver/test_flatplate.py`` (coarse) and
``millfoil validate flatplate --level fine`` (issue tolerances).
"""

import numpy as np
import pytest

from solver import Fluid, Problem, SimpleSettings, initial_state, solve_steady
from solver.fvmesh import build_fvmesh
from solver.momentum import momentum_system
from solver.turbulence import (
    SST,
    TMR_FREESTREAM,
    WALL_TREATMENTS,
    SSTConstants,
    blend,
    cross_diffusion,
    eddy_viscosity,
    f1,
    f2,
    inlet_turbulence,
    omega_flux_factor,
    omega_log,
    omega_viscous,
    production,
    spalding_u_tau,
)
from solver.validation.meshes import square_mesh
from solver.walldistance import segment_distance, wall_distance

#: The solver settings these tests were written with (not SimpleSettings' defaults): SIMPLEC, alpha_u 0.8,
#: alpha_p 1, no early stop on stalled residuals.
SIMPLEC = dict(algorithm="simplec", alpha_u=0.8, alpha_p=1.0, stall_tol=None)

C = SSTConstants()
NU = 2e-7


def test_constants_frozen_and_2003_values():
    with pytest.raises(AttributeError):
        C.beta1 = 0.1
    assert (C.gamma1, C.gamma2, C.production_limit, C.cd_floor) == (5 / 9, 0.44, 10.0, 1e-10)
    assert (C.sigma_k1, C.sigma_w1, C.beta1, C.sigma_k2, C.sigma_w2, C.beta2, C.beta_star, C.a1) == \
        (0.85, 0.5, 0.075, 1.0, 0.856, 0.0828, 0.09, 0.31)


def test_blend():
    assert blend(np.array(1.0), 2.0, 3.0) == 2.0 and blend(np.array(0.0), 2.0, 3.0) == 3.0


def test_f1_f2_one_near_wall():
    """Near a wall omega follows 6 nu/(beta1 d²): 500 nu/(d² omega) = 500 beta1/6 = 6.25, so F1 = F2 = 1."""
    d = np.array([1e-6, 1e-5, 1e-4])
    w = omega_viscous(d, NU, C)
    k = 1e-12 * np.ones(3)
    cd = cross_diffusion(np.zeros((3, 2)), np.zeros((3, 2)), w, C)
    assert np.allclose(f1(k, w, d, NU, cd, C), 1.0) and np.allclose(f2(k, w, d, NU, C), 1.0)


def test_f1_f2_zero_in_freestream():
    """Far from walls with freestream k and omega (TMR values) both blending functions vanish."""
    k, w = (np.array([v]) for v in inlet_turbulence(1.0, TMR_FREESTREAM["intensity"],
                                                     TMR_FREESTREAM["viscosity_ratio"], NU))
    d = np.array([0.5])
    cd = cross_diffusion(np.zeros((1, 2)), np.zeros((1, 2)), w, C)
    assert f1(k, w, d, NU, cd, C)[0] < 1e-6 and f2(k, w, d, NU, C)[0] < 1e-3


def test_cross_diffusion_floor():
    gk, gw = np.array([[1.0, 0.0]]), np.array([[-1.0, 0.0]])
    assert cross_diffusion(gk, gw, np.array([1.0]), C)[0] == C.cd_floor
    assert cross_diffusion(gk, -gw, np.array([2.0]), C)[0] == pytest.approx(C.sigma_w2)


def test_eddy_viscosity_limits():
    k, w = np.array([1e-3, 1e-3]), np.array([10.0, 10.0])
    s = np.array([1.0, 1e3])              # small strain: k/omega; large strain with F2 = 1: a1 k / S
    nut = eddy_viscosity(k, w, s, np.ones(2), C)
    assert nut[0] == pytest.approx(k[0] / w[0]) and nut[1] == pytest.approx(C.a1 * k[1] / s[1])
    assert eddy_viscosity(k, w, s, np.zeros(2), C) == pytest.approx(k / w)      # F2 = 0: no limiter


def test_production_limiter():
    k, w = np.array([1.0, 1.0]), np.array([1.0, 1.0])
    p = production(np.array([0.1, 100.0]), np.array([1.0, 1.0]), k, w, C)
    assert p[0] == pytest.approx(0.1) and p[1] == pytest.approx(10 * C.beta_star)


def test_limited_omega_production_is_the_k_limiter_over_nu_t():
    from solver.turbulence.sst import OMEGA_PRODUCTIONS

    k, w, s2 = np.array([1.0, 1.0]), np.array([1.0, 1.0]), np.array([1.0, 1.0])
    nut = np.array([0.1, 100.0])           # limiter inactive (P = nu_t S²) and active (P = 10 beta* k omega)
    p = OMEGA_PRODUCTIONS["limited"](s2, nut, k, w, C)
    assert p == pytest.approx(production(nut, s2, k, w, C) / nut)
    assert p[0] == pytest.approx(1.0) and p[1] == pytest.approx(10 * C.beta_star / 100.0)
    assert np.array_equal(OMEGA_PRODUCTIONS["unlimited"](s2, nut, k, w, C), s2)
    with pytest.raises(ValueError, match="omega_production.*limited"):
        SST(omega_production="clipped")


def test_inlet_turbulence():
    k, w = inlet_turbulence(10.0, 0.05, 10.0, 1e-5)
    assert k == pytest.approx(1.5 * 0.25) and w == pytest.approx(k / 1e-4)
    k, w = inlet_turbulence(1.0, TMR_FREESTREAM["intensity"], TMR_FREESTREAM["viscosity_ratio"], NU)
    assert k == pytest.approx(9e-9 / 0.2**2) and w == pytest.approx(1e-6 / 0.2**2 / NU)   # TMR at M = 0.2


def test_spalding_limits():
    """Viscous sublayer (y+ ~ 0.1): u_tau = sqrt(nu U/y); log layer (y+ ~ 1000): U+ = ln(y+)/kappa + B
    within Spalding's blending (0.1 %)."""
    y = np.array([1e-7])
    u = np.array([0.05**2 * y[0] / NU])               # u_tau = 0.05 exactly in the linear law, y+ = 0.025
    assert spalding_u_tau(u, y, NU, C)[0] == pytest.approx(0.05, rel=1e-4)
    u_tau, yp = 0.04, 1000.0
    y = np.array([yp * NU / u_tau])
    u = np.array([u_tau * (np.log(yp) / C.kappa + C.spalding_b)])
    assert spalding_u_tau(u, y, NU, C)[0] == pytest.approx(u_tau, rel=1e-3)


def test_automatic_omega_blend_limits():
    """sqrt(omega_vis² + omega_log²): viscous value at y+ = 0.1, log value at y+ = 1000."""
    u_tau = 0.04
    for yp, which in ((0.1, "vis"), (1000.0, "log")):
        y = np.array([yp * NU / u_tau])
        wv, wl = omega_viscous(y, NU, C), omega_log(np.array([u_tau]), y, C)
        w = np.sqrt(wv**2 + wl**2)
        assert w[0] == pytest.approx((wv if which == "vis" else wl)[0], rel=1e-3)


@pytest.mark.parametrize("power, weight_log", [(2, 0.0), (1, 1.0)])
def test_omega_flux_factor_makes_two_point_flux_exact(power, weight_log):
    """For omega = 1/y^p (p = 2 sublayer, p = 1 log layer) the scaled two-point difference equals the exact
    derivative at the face; the factor is below 1 (the plain difference over-estimates the flux)."""
    y1, y2, yf = np.array([1.0, 0.5]), np.array([3.2, 1.4]), np.array([2.0, 0.9])
    phi = omega_flux_factor(y1, y2, yf, np.full(2, weight_log))
    two_point = (y2**-power - y1**-power) / (y2 - y1)
    assert np.allclose(phi * two_point, -power * yf ** (-power - 1.0)) and np.all(phi < 1.0)


def test_omega_wall_flux_options():
    """``analytic`` is the flux factor (hand value for omega ~ 1/y², y1 = 1, y2 = 3, yf = 2:
    2 y1² y2² / (yf³ (y1 + y2)) = 18/32); ``two_point`` leaves the diffusivity unscaled (OpenFOAM)."""
    from solver.turbulence.sst import OMEGA_WALL_FLUXES

    y1, y2, yf, wl = np.array([1.0]), np.array([3.0]), np.array([2.0]), np.array([0.0])
    assert OMEGA_WALL_FLUXES["analytic"](y1, y2, yf, wl) == pytest.approx(18.0 / 32.0, rel=1e-15)
    assert np.array_equal(OMEGA_WALL_FLUXES["two_point"](y1, y2, yf, wl), [1.0])
    assert SST().omega_wall_flux == "analytic"
    with pytest.raises(ValueError, match="omega_wall_flux.*two_point"):
        SST(omega_wall_flux="none")


def test_sst_velocity_gradient_options_green_gauss_exact_for_a_linear_field():
    """``velocity_gradient``: ``least_squares`` hands the momentum step's gradient through; ``green_gauss``
    (``green_gauss_bounded`` is the default) rebuilds it from face values and is exact for a linear field too."""
    from solver.turbulence.sst import VELOCITY_GRADIENTS

    assert SST().velocity_gradient == "green_gauss_bounded"
    with pytest.raises(ValueError, match="velocity_gradient.*green_gauss"):
        SST(velocity_gradient="gauss")
    p = channel_problem(n=8)
    m = p.mesh
    x, y = m.centroid[:, 0], m.centroid[:, 1]
    u = np.stack([0.3 + 2.0 * x - 1.0 * y, -0.5 + 0.5 * x + 3.0 * y], axis=1)
    exact = np.broadcast_to(np.array([[2.0, -1.0], [0.5, 3.0]]), (m.n_cells, 2, 2))
    gg = VELOCITY_GRADIENTS["green_gauss"](m, p.bnd, u, 0.0 * exact, exact)      # the faces' gradient is used
    assert np.array_equal(VELOCITY_GRADIENTS["least_squares"](m, p.bnd, u, exact, 0.0 * exact), exact)
    interior = np.setdiff1d(np.arange(m.n_cells), m.owner[m.n_internal:])   # walls and inlet impose their own values
    assert np.allclose(gg[interior], exact[interior], atol=1e-9)


def test_sst_velocity_gradient_bounded_clips_only_overshooting_faces():
    """``green_gauss_bounded``: where the reconstruction stays within the two cells' values (a linear field on a
    uniform mesh) it is ``green_gauss`` bitwise; a reconstructing gradient that overshoots is clipped."""
    from solver.gradient import green_gauss_gradient
    from solver.turbulence.sst import VELOCITY_GRADIENTS

    assert "green_gauss_bounded" in VELOCITY_GRADIENTS
    m = square_mesh(8, triangles="none")
    x = m.centroid[:, 0]
    phi_b = m.face_centre[m.n_internal:, 0]
    exact = np.tile([1.0, 0.0], (m.n_cells, 1))
    assert np.array_equal(green_gauss_gradient(m, x, phi_b, exact, bounded=True),
                          green_gauss_gradient(m, x, phi_b, exact))
    steep = exact * np.random.default_rng(1).normal(0.0, 50.0, (m.n_cells, 1))   # reconstructs far past the cells
    free, clipped = green_gauss_gradient(m, x, phi_b, steep), green_gauss_gradient(m, x, phi_b, steep, bounded=True)
    assert np.abs(free).max() > 10.0 and np.abs(clipped).max() <= 2.0 + 1e-12       # faces within their cells
    # a vector field (the SST step's velocity) is its components side by side
    u, g = np.column_stack([x, -2.0 * x]), np.stack([steep, -3.0 * steep], axis=1)
    u_b = np.column_stack([phi_b, -2.0 * phi_b])
    both = green_gauss_gradient(m, u, u_b, g, bounded=True)
    for i in range(2):
        assert np.allclose(both[:, i, :], green_gauss_gradient(m, u[:, i], u_b[:, i], g[:, i, :], bounded=True),
                           rtol=1e-14, atol=1e-12)


def test_spalding_velocity_gradient_limits_and_profile_slope():
    """dU/dy of Spalding's profile: ``u_tau²/nu`` in the sublayer, ``u_tau/(kappa y)`` deep in the log layer,
    and the slope of the profile itself (a central difference of ``y+(u+)``) in the buffer layer."""
    from solver.turbulence.closures import spalding_velocity_gradient

    c, nu, u_tau = SSTConstants(), 1e-6, 0.05
    eb = np.exp(-c.kappa * c.spalding_b)

    def y_of(up):                                     # Spalding's y (m) at u+
        kup = c.kappa * up
        return (up + eb * (np.exp(kup) - 1 - kup - kup**2 / 2 - kup**3 / 6)) * nu / u_tau

    assert spalding_velocity_gradient(0.01 * u_tau, u_tau, nu, c) == pytest.approx(u_tau**2 / nu, rel=1e-6)
    up = 30.0                                         # y+ ~ 2e4
    assert spalding_velocity_gradient(up * u_tau, u_tau, nu, c) == pytest.approx(
        u_tau / (c.kappa * y_of(up)), rel=0.01)
    up, h = 11.0, 1e-5                                # buffer layer
    slope = 2 * h * u_tau / (y_of(up + h) - y_of(up - h))
    assert spalding_velocity_gradient(up * u_tau, u_tau, nu, c) == pytest.approx(slope, rel=1e-6)


def test_wall_law_gradient_replaces_only_the_wall_normal_shear_of_single_wall_cells():
    """:func:`with_wall_law_gradient` sets ``d u_t / d n`` (inward) of the cells with one wall face and keeps
    every other component and cell; under the ``automatic`` treatment the wall values carry the law's slope."""
    from solver.turbulence.walls import automatic_wall, with_wall_law_gradient

    p = channel_problem(n=8)
    m, setup = p.mesh, SST().setup(p.mesh, p.bnd, 1000.0, 1e-3)
    rng = np.random.default_rng(3)
    u = np.column_stack([1.0 + rng.random(m.n_cells), 0.1 * rng.random(m.n_cells)])
    grad = rng.normal(size=(m.n_cells, 2, 2))
    wall = automatic_wall(m, setup, u, np.full(m.n_cells, 1e-3), 1e-6, 1000.0, SSTConstants())
    out = with_wall_law_gradient(m, setup, u, grad, wall.wall_law_dudn)
    f = m.n_internal + setup.wall_local
    cell, normal = m.owner[f], m.normal[f]
    single = np.bincount(setup.wall_face_cell)[setup.wall_face_cell] == 1
    assert single.any()
    for face in np.flatnonzero(single):
        du = u[cell[face]] - setup.wall_velocity[face]
        t = du - du @ normal[face] * normal[face]
        t /= np.linalg.norm(t)
        g, g0 = out[cell[face]], grad[cell[face]]
        assert t @ g @ -normal[face] == pytest.approx(wall.wall_law_dudn[face], rel=1e-12)
        assert np.allclose(g @ t, g0 @ t) and np.allclose((g - g0) @ -normal[face], (g - g0) @ -normal[face] @ t * t)
    untouched = np.setdiff1d(np.arange(m.n_cells), cell[single])
    assert np.array_equal(out[untouched], grad[untouched])


def test_segment_distance():
    a, b = np.array([0.0, 0.0]), np.array([1.0, 0.0])
    p = np.array([[0.5, 2.0], [-3.0, 4.0], [2.0, -1.0]])
    assert np.allclose(segment_distance(p, a, b), [2.0, 5.0, np.sqrt(2.0)])


def test_wall_distance_flat_wall_exact():
    m = square_mesh(12, triangles="checker", distort=0.2)
    assert np.allclose(wall_distance(m, m.boundary["bottom"]), m.centroid[:, 1], atol=1e-14)


@pytest.mark.parametrize("pairs", [0, None])
def test_wall_distance_matches_brute_force_on_polygon(pairs, monkeypatch):
    """Cells around a 24-gon 'cylinder' wall (quads in a ring, very unequal faces): the k-d tree candidates
    (``pairs`` 0: the tree at any size) and the compiled loop over every segment (the default at this size)
    give exactly the brute-force minimum over all wall segments."""
    import solver.walldistance

    if pairs is not None:
        monkeypatch.setattr(solver.walldistance, "BRUTE_FORCE_PAIRS", pairs)
    nt, nr = 24, 6
    th = np.linspace(0, 2 * np.pi, nt, endpoint=False) + 0.08 * np.sin(np.arange(nt))   # unequal faces
    r = 0.5 * 1.4 ** np.arange(nr + 1)
    pts = np.array([[ri * np.cos(t), ri * np.sin(t)] for ri in r for t in th])
    nid = np.arange(len(pts)).reshape(nr + 1, nt)
    quads = [[nid[i, j], nid[i, (j + 1) % nt], nid[i + 1, (j + 1) % nt], nid[i + 1, j]]
             for i in range(nr) for j in range(nt)]
    quads = [q[::-1] for q in quads]           # counter-clockwise
    wall = [[nid[0, (j + 1) % nt], nid[0, j]] for j in range(nt)]
    outer = [[nid[nr, j], nid[nr, (j + 1) % nt]] for j in range(nt)]
    m = build_fvmesh(pts, {"quad": quads}, {"wall": wall, "far": outer})
    f = m.boundary["wall"]
    d = wall_distance(m, f)
    a, b = m.points[m.faces[f, 0]], m.points[m.faces[f, 1]]
    brute = segment_distance(m.centroid[:, None, :], a[None], b[None]).min(axis=1)
    assert np.array_equal(d, brute)
    assert np.all(d > 0)


def channel_problem(wall_treatment="low_re", n=24, triangles="right_half"):
    """Developing flow between a no-slip bottom wall and a symmetry top, Re = 1e5 per metre."""
    m = square_mesh(n, triangles=triangles, strength=0.0)
    bc = {"left": {"type": "velocity_inlet", "velocity": (1.0, 0.0), "intensity": 0.05, "viscosity_ratio": 10.0},
          "right": {"type": "pressure_outlet", "p": 0.0}, "top": "symmetry", "bottom": "wall"}
    return Problem.create(m, bc, Fluid(1.0, 1e-5), turbulence=SST(wall_treatment=wall_treatment))


@pytest.mark.slow
@pytest.mark.parametrize("wall", sorted(WALL_TREATMENTS))
def test_turbulent_run_positive_and_results_api(wall, tmp_path):
    """k, omega, nu_t stay positive and finite on a mixed quad/triangle mesh (triangles at the wall on the
    right half, y+ 20-130) with the default alpha_u = 0.8; both wall treatments converge (measured 150-225
    iterations); results API shapes."""
    p = channel_problem(wall)
    r = solve_steady(p, SimpleSettings(**SIMPLEC, max_iter=400, monitor_groups=("bottom",)),
                     initial_state(p, (1.0, 0.0)))
    assert r.converged, r.message
    for a in (r.k, r.omega, r.nu_t):
        assert a.shape == (p.mesh.n_cells,) and np.all(np.isfinite(a)) and np.all(a > 0)
    assert set(r.residuals) == {"u", "v", "continuity", "k", "omega"}
    nb = len(p.mesh.boundary["bottom"])
    tau = r.wall_shear("bottom")
    assert tau.shape == (nb, 2) and np.all(tau[:, 0] > 0)
    assert r.y_plus("bottom").shape == (nb,) and r.wall_faces("bottom").shape == (nb, 2)
    assert r.forces("bottom").fx == pytest.approx((tau[:, 0] * p.mesh.length[p.mesh.boundary["bottom"]]).sum())
    r.write_vtu(tmp_path / "t.vtu")
    import meshio
    assert {"k", "omega", "nu_t"} <= set(meshio.read(tmp_path / "t.vtu").cell_data)


def test_sst_config_errors():
    with pytest.raises(ValueError, match="automatic.*low_re"):
        SST(wall_treatment="log")
    m = square_mesh(4)
    bc = {"left": {"type": "velocity_inlet", "velocity": (1.0, 0.0)}, "right": "pressure_outlet",
          "top": "symmetry", "bottom": "symmetry"}
    with pytest.raises(ValueError, match="wall"):
        Problem.create(m, bc, Fluid(), turbulence=SST())


def test_laminar_path_unchanged():
    """No turbulence model: no turbulent fields, the laminar residual set, and the momentum operator with a
    scalar mu is the per-face one minus only the explicit transpose stress (same matrix)."""
    m = square_mesh(8, triangles="right_half", distort=0.2)
    bc = {"left": {"type": "velocity_inlet", "velocity": (1.0, 0.0)}, "right": "pressure_outlet",
          "top": "wall", "bottom": "wall"}
    p = Problem.create(m, bc, Fluid(1.0, 0.01))
    assert p.turbulence is None and p.turbulence_setup is None
    r = solve_steady(p, SimpleSettings(**SIMPLEC, max_iter=30))
    assert r.k is None and r.omega is None and r.nu_t is None and r.mu_wall is None
    assert set(r.residuals) == {"u", "v", "continuity"}
    rng = np.random.default_rng(1)
    u = rng.normal(size=(m.n_cells, 2))
    g = rng.normal(size=(m.n_cells, 2, 2))
    u_b = p.bnd.velocity(m, u, g)
    flux = rng.normal(size=m.n_faces)
    gp = rng.normal(size=(m.n_cells, 2))
    a = momentum_system(m, p.pattern, p.bnd, u, u_b, flux, g, g, gp, 0.01, 0.8)
    b = momentum_system(m, p.pattern, p.bnd, u, u_b, flux, g, g, gp, np.full(m.n_faces, 0.01), 0.8)
    assert np.array_equal(a.u.A.data, b.u.A.data) and np.array_equal(a.a_p, b.a_p)
    from solver.gradient import interpolate_linear
    ni = m.n_internal
    t = 0.01 * np.einsum("fdc,fd->fc", interpolate_linear(m, g), m.sf[:ni])
    src_t = np.stack([np.bincount(m.owner[:ni], t[:, c], m.n_cells)
                      - np.bincount(m.neighbour[:ni], t[:, c], m.n_cells) for c in range(2)], 1)
    assert np.allclose(b.u.b - a.u.b, src_t[:, 0], atol=1e-12) and np.allclose(b.v.b - a.v.b, src_t[:, 1],
                                                                                 atol=1e-12)


@pytest.mark.parametrize("turbulent", [True, False])
def test_outer_iteration_leaves_the_state_arrays_untouched(turbulent):
    """:func:`solver.simple.outer_iteration` replaces the arrays of the state and never writes into them:
    ``solve_steady`` keeps a shallow snapshot of the last iterate to fall back to after a divergence."""
    import dataclasses

    from solver.simple import outer_iteration

    p = channel_problem("automatic", n=12)
    if not turbulent:
        p = dataclasses.replace(p, turbulence=None, turbulence_setup=None)
    s = initial_state(p, (1.0, 0.0))
    settings = SimpleSettings(**SIMPLEC)
    for it in range(1, 4):
        before = dataclasses.replace(s)
        saved = {k: None if v is None else np.copy(v) for k, v in dataclasses.asdict(before).items()}
        outer_iteration(p, s, settings, {"iteration": it})
        for k, v in saved.items():
            if v is not None:
                assert np.array_equal(getattr(before, k), v, equal_nan=True), k
