"""Settings of the steady pressure-based solver: :class:`SimpleSettings`, the one definition of every option.

The optimiser's ``solver:`` configuration section is generated from :func:`dataclasses.fields` of
:class:`SimpleSettings`, so a default changed here changes the blade evaluations too.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .linalg import SolverSettings

#: Options of the default pressure solver (:func:`solver.linalg._amg_cg`, relative tolerance 0.05): one
#: Ruge–Stüben set-up per steady solve, reused as built for the first 10 pressure solves (the start-up
#: transient, as before), then kept for its interpolation only while every level's operator is re-formed from
#: each iteration's p' matrix (``galerkin``, :class:`solver.amg.GalerkinHierarchy`, 0.7 ms per refresh); a new
#: set-up after 1 000 solves or after one that took more than 8 CG iterations. Benchmark blade at medium
#: (docs/performance.md, session 5): one set-up instead of 31 (0.70 -> 0.06 s CPU), 3.2 instead of 3.3 CG
#: iterations per solve after the first 10, the AMG part of an iteration 8.8 -> 7.6 ms, the same 310 outer
#: iterations. Refreshing from the first solve made that blade's start-up transient slower (320).
PRESSURE_AMG = {"galerkin": True, "rebuild_every": 1000, "rebuild_above": 8, "refresh_after": 10}


@dataclass(frozen=True)
class SimpleSettings:
    """Settings of the steady pressure-based solver (every option has a default).

    The defaults are those of the blade evaluations (Re ~ 1e6, k-omega SST, first cell at y+ ~ 1), except
    ``pressure_gradient``, ``face_velocity``, ``alpha_p``, ``startup_alpha_p_iterations`` and ``limiter_k``, which
    the blade evaluations set (:data:`optimizer.config.BLADE_SETTINGS`):

    algorithm: ``"simplec"`` (default) or ``"simple"`` (:data:`solver.simple.ALGORITHMS`).
    alpha_u, alpha_p: momentum and pressure under-relaxation; ``alpha_p`` None means 1 (no pressure
        relaxation, the SIMPLEC choice; :attr:`pressure_relaxation`). Defaults SIMPLEC, 0.95, None (1); the
        blade evaluations set 0.7 (from iteration 151, ``startup_alpha_p_iterations``) with their Green–Gauss pressure
        gradient (:data:`optimizer.config.BLADE_SETTINGS`): with it the paper's table5 blade has no stable
        fixed point at alpha_p 1 (a limit cycle of +-6 % in lift, where OpenFOAM converges); 0.7 converges
        it from the free stream in 350-370 iterations (0.8: 430, 0.85: 720) and gives the most converged
        blades of the two robustness sweeps (from iteration 151: medium 34 / 50, coarse channel 45 / 50, for 8 %
        and 16 % more iterations; 0.8 from iteration 51: 29 and 43; alpha_p 1 with least squares: 28 and 44)
        (docs/validation-blades.md, session 12).
        With the bounded SIMPLEC coefficient (:func:`solver.simple.simplec_coefficient`) the benchmark
        blade at medium (16 641 cells) has its lift within 0.5 % / 0.1 % of the final value after 215 /
        257 iterations at alpha_u 0.95, 265 / 352 at 0.9 (OpenFOAM's simpleFoam value on the same mesh),
        793 / > 1 000 with SIMPLE 0.7/0.3 (the default before issue 13); 0.97 and 0.98 gain nothing more
        on the lift and converge the residuals more slowly (stops at 828 and 1 289). The 50 random blades
        of ``bench/bench_robustness.py`` at medium keep their convergence classes at 0.95
        (docs/performance.md, "Session 3"). Unbounded, SIMPLEC diverged within 3 iterations there. At low
        Re (laminar tests, the cavity and cylinder cases) SIMPLEC with alpha_u = 0.8-0.98 and alpha_p = 1
        is faster still.
    startup_iterations, startup_alpha_u: the first ``startup_iterations`` iterations of a solve run with
        ``min(alpha_u, startup_alpha_u)`` (defaults 50 and 0.7; 0 iterations: off). From the free stream in
        the campaigns' channel at ``coarse``, 3 of the 50 random blades of ``bench/bench_robustness.py``
        diverged at the leading edge within 10-48 iterations at 0.95; with 50 iterations at 0.7 all 50
        converge or oscillate (43 / 7 with the wall-spacing cap of :mod:`meshing.hybrid`), the converged
        forces unchanged to 0.1 % (docs/benchmarks.md, "Start-up"). It does nothing at
        ``alpha_u <= startup_alpha_u`` (the NACA 0012 case's SIMPLE 0.7).
    startup_alpha_p: with SIMPLEC, the pressure relaxation of the start-up's iterations; None: ``alpha_p``
        throughout. SIMPLE always runs at its ``alpha_p``, which it needs from the first iteration (0.3 with
        alpha_u 0.7). Default 1, SIMPLEC's own value (no pressure relaxation while the start-up's ``alpha_u`` is
        low): with ``alpha_p`` 0.7 from the first iteration one of the 50 random blades of the campaigns'
        coarse channel diverged at its leading edge within 9 iterations; with 1 there and 0.7 after it, it
        converges (docs/validation-blades.md, session 12).
    startup_alpha_p_iterations: the iterations run at ``startup_alpha_p`` (None, the default: the start-up's
        ``startup_iterations``). The blade evaluations run 150: most coarse blades' lift is within 0.1 % of its
        final value by then, which alpha_p 0.7 from iteration 51 delayed by up to 20 % (docs/performance.md,
        session 12).
    startup_ramp: the last ``startup_ramp`` iterations of the start-up (at most all of them) rise linearly
        from ``min(alpha_u, startup_alpha_u)`` towards ``alpha_u`` instead of the step at its end (iteration
        ``n - r + j`` of a start-up of ``n`` with a ramp of ``r`` at ``a0 + (alpha_u - a0) j / (r + 1)``,
        :func:`solver.simple.iteration_alpha_u`); 0: the step; no start-up, no ramp. Default 50 (the whole
        start-up): lift within 0.1 % in fewer iterations on all six ``bench_openfoam`` cases (random 0 medium
        127 -> 104) and on most blades of both robustness sweeps, the classes unchanged, 4-7 % fewer
        iterations over each sweep (docs/performance.md, "A ramped end of the start-up").
    convection: ``"linear_upwind"`` (second order, deferred correction) or ``"upwind"``
        (:data:`solver.assembly.CONVECTION_SCHEMES`).
    limiter, limiter_k: gradient limiter for convection (:data:`solver.gradient.LIMITERS`). Venkatakrishnan's
        ``eps² = (K h)³`` is dimensional (SI: h in m), so a K limits differently at another scale and speed;
        the blade evaluations use K = 100 (docs/validation-blades.md, session 14).
    limiter_iterations: the limiter acts in the first ``limiter_iterations`` iterations only, the unlimited
        linear-upwind reconstruction (OpenFOAM's ``linearUpwind``) after them; None (default): throughout.
        From a potential or uniform start the unlimited scheme diverges within a few iterations (the slip
        velocity meeting the no-slip wall), while on a settled boundary layer the limiter clips the young
        layer near the leading edge and costs lift near stall (docs/validation-naca0012-sessions.md,
        "Findings (session 3)").
        The stop tests wait until the limiter is off, so the solution returned is the unlimited one.
    max_iter: iteration cap. tol: scaled-residual tolerance for u, v and continuity.
    monitor_tol, monitor_window: integral quantities must vary less than ``monitor_tol`` (relative)
        over the last ``monitor_window`` iterations.
    monitor_groups: boundary groups whose forces are monitored.
    classify_window, classify_tol: a solve that reaches ``max_iter`` is classified from its monitors over
        the last ``classify_window`` iterations (:func:`solver.convergence.classify`): ``converged`` if
        they are stationary within ``classify_tol`` (relative; the issue's "lift and C_max stationary to
        0.1 % over a window"), ``oscillating`` (bounded; use the window means in
        ``FlowResults.classification``) or ``not_converged`` (drifting).
    stall_tol, stop_window, stop_tol: a solve also stops as ``converged`` once every scaled residual is
        below ``stall_tol`` and every monitor is within ``stop_tol`` (relative, default 1e-3) of its
        converged value, judged over two windows of ``stop_window`` (50) iterations: spread within
        ``stop_tol`` and the geometric decay of its trend extrapolated (:func:`solver.monitors.settled`).
        RANS residuals often stall between 1e-6 and 1e-5 (limiter chatter) while forces and C_max have
        settled. Default 1e-4: a guard against monitors that pause while the field is still far from
        converged (the residuals of the first iterations are 1e-1-1e-3), not a second accuracy test — the
        monitors' own test decides (on the benchmark blade at medium, 1e-5 held the stop 60 iterations after
        the objectives had settled, for no change in them beyond 1e-3). None: off (run to ``tol`` or
        ``max_iter``).
    stop_monitors: the monitors that stop test waits for (names as in ``FlowResults.monitors``:
        ``"c_max"``, ``"fx:<group>"``, ``"fy:<group>"``); empty (the default): all of them. The blade
        evaluation waits for its objectives only, F_Y and C_max (:func:`optimizer.pipeline.simple_settings`):
        F_X, reported but not optimised, settles last (on the benchmark blade at medium, 70 iterations after
        the lift) and is then within a few 1e-3 of its converged value. The classification and the
        ``tol`` test still use every monitor.
    early_classify: stop a solve whose oscillation or drift is established over two classification
        windows (after a start-up allowance, ``early_skip``; checked every 25 iterations) with the class and
        figures it would get at ``max_iter`` (:func:`solver.monitors.established`); False: run such solves
        to ``max_iter``.
    early_periods: the two windows of that early stop span this many periods of the oscillation (the
        longest of the monitors' periods over the last ``classify_window`` iterations), between
        ``classify_window / 2`` and ``classify_window`` iterations, so that a short-period oscillation is
        recognised from ``3 x`` that window on rather than from ``3 classify_window``
        (:func:`solver.monitors.early_window`). Default 8: the 24 oscillating blades of
        ``bench/bench_robustness.py`` at medium stop after 637.5 iterations by the median instead of 725
        (1.96x the converged median), with the same classes and window means within half an amplitude of
        those at the cap; 6 stopped a converged blade (random blade 20) early as oscillating
        (docs/performance.md, "Unsettled blades (session 6)"). None: windows of ``classify_window``.
    early_skip: the start-up skipped before those two windows: ``min(early_skip, w)`` iterations for
        windows of ``w``, so the first check comes at ``2 w + min(early_skip, w)`` (None: a whole window,
        ``3 w``, session 6). Default 100: the gentle start-up (``startup_iterations``) and the transient after
        it are over by then on the random blades at medium (lift within 0.5 % of its final value after
        50-210 iterations); replayed on the 22 unsettled blades' 2 000-iteration histories, 100-175 all give
        the same stops, the same classes, and window means within half an amplitude of the cap's on 20 of 22
        (19 with a whole window) (docs/performance.md, "The early stop's start-up allowance (session 9)").
    divergence_factor: a residual above 1 and this many times its running minimum means divergence.
    velocity_limit: a cell velocity component above this (m/s) means divergence.
    pressure_gradient: gradient of p in the momentum source and in the Rhie–Chow interpolation:
        ``"least_squares"``, ``"green_gauss"`` (skewness-corrected face values), ``"green_gauss_bounded"`` (the
        same, each face value kept within its two cells' values) or ``"green_gauss_linear"`` (plain linear face
        values, OpenFOAM's ``Gauss linear``) (:data:`solver.simple.PRESSURE_GRADIENTS`). Default
        ``"least_squares"``: every Green–Gauss form lowers the manufactured solution's velocity order on
        uniformly refined triangles (medium level 1.98 -> 1.68-1.70, below the 1.8 asked). The blade
        evaluations and the NACA 0012 case use ``"green_gauss_bounded"`` (session 12): against OpenFOAM on the
        same meshes the random blades' lift within 1.5 % on 10 of 10 (least squares 9), table4 out of its
        leading-edge stall, and the NACA 0012 coarse C-mesh at 16 deg -1.6 % (-5.4 %); the TMR references met
        on every level. The bound matters at a G0 blade's corner nose, where the unbounded reconstruction put
        C_max 58 % above OpenFOAM's (docs/validation-blades.md and docs/validation-naca0012-sessions.md, session 12).
    face_velocity: the velocity that carries the Rhie–Chow mass flux through each face
        (:func:`solver.pressure.face_velocity`): ``"corrected"``, reconstructed from both cells with their
        gradients (exact for linear fields on skewed meshes), or ``"bounded"``, the same with each
        component kept within its two cells' values. Default ``"corrected"``; the blade evaluations and the
        NACA 0012 case use ``"bounded"`` (session 13): at the trailing edge of the C-mesh the boundary-layer
        cells' gradients extrapolated to the faces they share with the wake's overshoot and remove the
        trailing-edge loading (the coarse lift at 2-8 deg +1.1 ... +1.75 % above OpenFOAM's on the same mesh,
        bounded +0.8 ... +1.0 %), and on the medium blades it halves table5's C_max gap (-1.21 -> -0.58 %)
        and narrows random16's and random18's (-1.27 -> -1.03 %, -1.29 -> -0.89 %); the robustness sweeps
        keep every class. On coarse blade meshes it moves the lift 0.2-1.9 % up, away from OpenFOAM's on most.
        Not the solver's default: the DFG cylinder's coarse lift error becomes 0.00428, above its 0.004
        (docs/validation-naca0012-sessions.md, docs/validation-blades.md, session 13).
    green_gauss_relaxation: under-relaxation, between iterations, of the ``green_gauss`` pressure gradient's
        correction (its difference from ``green_gauss_linear``: the face values' reconstruction terms), in
        (0, 1]; 1: none. The converged solution does not depend on it. Why: the reconstruction brings the
        neighbours' pressure gradients into each face value; iterated explicitly it let table5's nose leave
        OpenFOAM's converged solution into a limit cycle (F_Y +-5.8 %), relaxed by 0.1-0.3 it converges there
        (docs/validation-blades.md, session 10).
    blas_threads: BLAS threads while iterating (via threadpoolctl when installed; None: leave as is).
        The per-iteration work is many small vector operations, where BLAS threads only contend
        (measured 5x slower with default OpenBLAS threading on a busy 2-core machine).
    momentum_solver, pressure_solver: linear solvers of the momentum and pressure-correction systems. The
        pressure default: CG preconditioned by AMG with refreshed Galerkin operators (:data:`PRESSURE_AMG`) to
        a relative residual of 0.05 (0.1 diverges on the coarse benchmark blade within 4 iterations).
    """

    algorithm: str = "simplec"
    alpha_u: float = 0.95
    alpha_p: float | None = None
    startup_iterations: int = 50
    startup_alpha_u: float = 0.7
    startup_alpha_p: float | None = 1.0
    startup_alpha_p_iterations: int | None = None
    startup_ramp: int = 50
    convection: str = "linear_upwind"
    limiter: str = "venkatakrishnan"
    limiter_k: float = 5.0
    limiter_iterations: int | None = None
    max_iter: int = 2000
    tol: float = 1e-6
    monitor_tol: float = 1e-5
    monitor_window: int = 20
    monitor_groups: tuple[str, ...] = ()
    classify_window: int = 200
    classify_tol: float = 1e-3
    stall_tol: float | None = 1e-4
    stop_window: int = 50
    stop_tol: float = 1e-3
    stop_monitors: tuple[str, ...] = ()
    early_classify: bool = True
    early_periods: float | None = 8.0
    early_skip: int | None = 100
    pressure_gradient: str = "least_squares"
    face_velocity: str = "corrected"
    green_gauss_relaxation: float = 1.0
    blas_threads: int | None = 1
    divergence_factor: float = 1e5
    velocity_limit: float = 1e4
    momentum_solver: SolverSettings = field(default_factory=lambda: SolverSettings("gauss_seidel", 0.1, 8))
    pressure_solver: SolverSettings = field(default_factory=lambda: SolverSettings("amg", 0.05, 50, dict(PRESSURE_AMG)))

    @property
    def pressure_relaxation(self) -> float:
        """The pressure under-relaxation applied: ``alpha_p``, or 1 when it is None."""
        return 1.0 if self.alpha_p is None else self.alpha_p
