"""The report's figures, drawn with matplotlib (Agg) into SVG files with text as paths (no fonts needed).

Pareto planes (Fig. 9–11 style), the geometry gallery (Fig. 12–13: blades rebuilt from their stored
parameters with :mod:`geometry`, milliseconds each), the kept fields of a few front designs (velocity
magnitude, C_p, c_f, y+), the campaign's health per generation and the hypervolume against the CFD spent.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from optimizer.campaign.fields import outline  # noqa: E402
from optimizer.campaign.status import EvaluationStatus  # noqa: E402
from optimizer.report.analysis import Convergence, Health, Point, front  # noqa: E402
from optimizer.report.run import Run  # noqa: E402

plt.rcParams.update({"svg.fonttype": "path", "font.size": 9, "svg.hashsalt": "millfoil"})

#: Marker of each status that has values (solved, possibly rejected); feasible accepted designs are dots.
STATUS_MARKERS = {EvaluationStatus.OK: "o", EvaluationStatus.OSCILLATING: "x", EvaluationStatus.NOT_CONVERGED: "+",
                  EvaluationStatus.DIVERGED: "1", EvaluationStatus.TIMEOUT: "2"}
RUN_MARKERS = ("o", "s", "^", "D", "v", "P", "*", "h")
AXES = {"fy": "|F_Y| over the span [N]", "cl": "C_L [-]", "cmax": "C_max [m/s]", "cpmin": "|C_p,min| [-]"}


#: Runs drawn on one Pareto plane together; more get one panel each (small multiples on shared axes), where
#: fifteen overlaid clouds and their legend would hide one another.
OVERLAID_RUNS = 2


def pareto_figure(runs: list[tuple[Run, list[Point]]], x: str, y: str, path: Path) -> Path:
    """Every solved design of every run in the (x, y) plane: accepted feasible designs as filled markers
    shaded by generation, rejected or constraint-violating ones as open markers by status, oscillating ones
    with their amplitude as error bars, each run's front as a line. Up to :data:`OVERLAID_RUNS` runs share
    one plane (one marker shape each); more get a panel each, on shared axes, with one legend."""
    gmax = max([max((p.design.row.generation for p in pts), default=0) for _, pts in runs] + [1])
    norm = matplotlib.colors.Normalize(0, gmax)
    cmap = matplotlib.colormaps["viridis"]
    overlaid = len(runs) <= OVERLAID_RUNS
    cols = 1 if overlaid else min(4, int(np.ceil(np.sqrt(len(runs)))))
    rows = 1 if overlaid else -(-len(runs) // cols)
    size = (6.4, 4.4) if overlaid else (2.6 * cols + 1.0, 2.2 * rows + 0.8)
    fig, axes = plt.subplots(rows, cols, figsize=size, sharex=True, sharey=True, squeeze=False)
    if overlaid:
        for k, (run, pts) in enumerate(runs):
            _pareto_run(axes[0, 0], pts, x, y, norm, RUN_MARKERS[k % len(RUN_MARKERS)], f"C{k % 10}",
                        f"{run.name}: ")
        panels = [axes[0, 0]]
    else:
        for ax, (run, pts) in zip(axes.flat, runs, strict=False):
            _pareto_run(ax, pts, x, y, norm, "o", "k", "")
            ax.set_title(f"{run.name} ({sum(p.feasible for p in pts)} feasible)", fontsize=7)
        for ax in axes.flat[len(runs):]:
            ax.set_axis_off()
        panels = list(axes.flat[:len(runs)])
    for ax in panels:
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7 if not overlaid else 9)
    for i, ax in enumerate(panels):
        if i + cols >= len(panels):                  # nothing below it: this panel carries the x axis
            ax.xaxis.set_tick_params(labelbottom=True)
            ax.set_xlabel(AXES[x])
    for ax in axes[:, 0]:
        ax.set_ylabel(AXES[y])
    values = [(p.value(x), p.value(y)) for _, pts in runs for p in pts]
    if values:
        # the limits of the markers: an oscillating design's error bar may run off the axes, where a few
        # large amplitudes would otherwise squeeze every front into a corner
        for limits, set_limits in zip(np.array(values).T, (axes[0, 0].set_xlim, axes[0, 0].set_ylim),
                                      strict=True):
            margin = 0.05 * max(limits.max() - limits.min(), 1e-9)
            set_limits(limits.min() - margin, limits.max() + margin)
    else:
        axes[0, 0].text(0.5, 0.5, "no solved design yet", transform=axes[0, 0].transAxes, ha="center",
                        va="center")
    shading = matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap)
    if overlaid:
        if values:
            fig.colorbar(shading, ax=axes[0, 0], label="generation")
            axes[0, 0].legend(fontsize=7, loc="best")
        fig.tight_layout()
    else:
        bottom, top = 0.8 / size[1], 1 - 0.3 / size[1]
        fig.subplots_adjust(left=0.6 / size[0], right=1 - 0.9 / size[0], bottom=bottom, top=top, hspace=0.4,
                            wspace=0.08)
        fig.colorbar(shading, cax=fig.add_axes((1 - 0.7 / size[0], bottom, 0.12 / size[0], top - bottom)),
                     label="generation")
        # one legend entry per kind of mark, not per run: the panels' titles name the runs
        unique: dict[str, object] = {}
        for ax in panels:
            for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
                unique.setdefault(label, handle)
        fig.legend(list(unique.values()), list(unique.keys()), loc="lower center", ncol=min(len(unique), 5),
                   fontsize=7, frameon=False)
    fig.savefig(path)
    plt.close(fig)
    return path


def _pareto_run(ax, pts: list[Point], x: str, y: str, norm, marker: str, colour: str, prefix: str) -> None:
    """One run's designs on ``ax`` (see :func:`pareto_figure`); legend labels start with ``prefix``."""
    cmap = matplotlib.colormaps["viridis"]
    good = [p for p in pts if p.feasible]
    bad = [p for p in pts if not p.feasible]
    osc = [p for p in good if p.value("d" + x) or p.value("d" + y)]
    count = (lambda sel: f"{len(sel)} ") if prefix else (lambda sel: "")
    if osc:
        ax.errorbar([p.value(x) for p in osc], [p.value(y) for p in osc],
                    xerr=[p.value("d" + x) for p in osc], yerr=[p.value("d" + y) for p in osc], fmt="none",
                    ecolor="0.4", elinewidth=0.8, capsize=2, zorder=2)
    if good:
        ax.scatter([p.value(x) for p in good], [p.value(y) for p in good],
                   c=[p.design.row.generation for p in good], cmap=cmap, norm=norm, marker=marker,
                   s=22 if prefix else 9, edgecolors=colour, linewidths=0.6 if prefix else 0.2, zorder=3,
                   label=f"{prefix}{count(good)}feasible" + ("" if prefix else " (shaded by generation)"))
    for status in sorted({p.status for p in bad}):
        sel = [p for p in bad if p.status == status]
        ax.scatter([p.value(x) for p in sel], [p.value(y) for p in sel], marker=STATUS_MARKERS.get(status, "x"),
                   color="firebrick" if status != EvaluationStatus.OK else "0.5", s=26 if prefix else 14,
                   linewidths=0.9, zorder=2,
                   label=f"{prefix}{count(sel)}{'constraint violated' if status == EvaluationStatus.OK else status}")
    f = front(pts, x, y) if x in ("cmax", "cpmin") else front(pts, y, x)
    if len(f) > 1:
        ax.plot([p.value(x) for p in f], [p.value(y) for p in f], "-", color=colour if prefix else "C3", lw=1.2,
                zorder=4, label=f"{prefix}front ({len(f)})" if prefix else "front")


def gallery_figure(run: Run, chosen: list[Point], path: Path) -> Path:
    """Blades of ``chosen`` rebuilt from their parameters: outline and camber line; for tool-path runs also
    the tool path, the cutter at the start of the cut and the machined blade (filled)."""
    n = max(len(chosen), 1)
    cols = min(n, 3)
    rows = -(-n // cols)
    # the blades are drawn to scale (a 100 mm chord, 20-40 mm high): short rows
    fig, axes = plt.subplots(rows, cols, figsize=(3.3 * cols, 1.8 * rows + 0.4), squeeze=False)
    for ax in axes.flat:
        ax.set_axis_off()
    for ax, p in zip(axes.flat, chosen, strict=False):
        blade_panel(ax, run, p, f"#{p.design.number}: |F_Y| {p.fy:.1f} N, C_max {p.cmax:.2f} m/s")
    handles = blade_legend(run.mode)
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=7, frameon=False)
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    fig.savefig(path)
    plt.close(fig)
    return path


def blade_panel(ax, run: Run, p: Point, title: str) -> None:
    """Draw design ``p`` of ``run`` rebuilt from its parameters on ``ax`` (mm): outline (filled) and camber
    line; for tool-path runs also the tool path and the cutter at both ends of the suction side."""
    from geometry import BladeSpec, build_profile
    from geometry.profile import GeometryError

    ax.set_title(title, fontsize=8)
    try:
        profile = build_profile(BladeSpec.from_values(run.mode, run.continuity, p.design.row.parameters))
    except (ValueError, GeometryError) as exc:
        ax.text(0.5, 0.5, f"cannot rebuild: {exc}"[:80], ha="center", va="center", fontsize=7, wrap=True)
        return
    mm = profile.points * 1e3
    ax.fill(mm[:, 0], mm[:, 1], color="0.85", zorder=1)
    ax.plot(*np.vstack([mm, mm[:1]]).T, "k-", lw=0.9, zorder=3)
    camber = profile.curves.camber.points(np.linspace(0, 1, 60)) * 1e3
    ax.plot(camber[:, 0], camber[:, 1], "--", color="C0", lw=0.8, zorder=2)
    if profile.tool_path is not None:
        tp = np.vstack([profile.tool_path, profile.tool_path[:1]]) * 1e3
        ax.plot(tp[:, 0], tp[:, 1], "-", color="C3", lw=0.8, zorder=2)
        r = profile.spec["R"] * 1e3
        for at in (profile.curves.suction.start, profile.curves.suction.end):
            ax.add_patch(plt.Circle(tuple(at * 1e3), r, fill=False, color="C3", lw=0.6, ls=":"))
    ax.set_aspect("equal")
    ax.set_axis_on()
    ax.tick_params(labelsize=6)


def blade_legend(mode: str) -> list:
    """Legend handles of :func:`blade_panel` for a run of ``mode``."""
    handles = [plt.Line2D([], [], color="k", lw=0.9, label="blade" if mode == "design" else "machined blade"),
               plt.Line2D([], [], color="C0", ls="--", lw=0.8, label="camber line")]
    if mode == "toolpath":
        handles += [plt.Line2D([], [], color="C3", lw=0.8, label="tool path (cutter centre)"),
                    plt.Line2D([], [], color="C3", ls=":", lw=0.6, label="cutter")]
    return handles


def health_figure(h: Health, path: Path) -> Path:
    """Hypervolume, feasible share of offspring, designs by status and by convergence class per generation,
    and the histogram of the time per evaluation; for a surrogate-assisted run a third row
    (:func:`_model_panels`)."""
    surrogate = bool(h.model_error)
    fig, axes = plt.subplots(3 if surrogate else 2, 3, figsize=(10, 7.8 if surrogate else 5.2))
    g = np.array(h.generations)
    if surrogate:
        _model_panels(axes[2], g, h)
    ax = axes[0, 0]
    hv = [np.nan if v is None else v for v in h.hypervolume]
    ax.plot(g, hv, "o-", ms=3)
    ax.set_title("hypervolume")
    ax = axes[0, 1]
    _columns(ax, g, [np.nan if v is None else 100 * v for v in h.feasible_share], color="C2")
    ax.set_ylim(0, 100)
    ax.set_title("feasible share of offspring [%]")
    for ax, counts, title in ((axes[1, 0], h.by_status, "designs by status"),
                              (axes[1, 1], h.by_class, "solved designs by convergence class")):
        bottom = np.zeros(len(g))
        for k, (name, values) in enumerate(counts.items()):
            _columns(ax, g, values, bottom=bottom, label=name, color=f"C{k}")
            bottom = bottom + np.array(values)
        ax.set_title(title)
        if counts:
            ax.legend(fontsize=6)
    ax = axes[0, 2]
    _columns(ax, g, h.cache_hits, color="C4")
    ax.set_ylim(0, max([1, *h.cache_hits]) * 1.05)      # a run without hits: an empty axis from 0, not ±0.05
    ax.set_title("cache hits")
    ax = axes[1, 2]
    if h.times:
        ax.hist(np.array(h.times) / 60.0, bins=min(30, max(5, len(h.times) // 3)), color="C5")
    ax.set_title("time per evaluation [min]")
    for ax in axes.flat:
        ax.grid(alpha=0.3)
    for ax in (*axes[1, :2], *axes[0, :], *(axes[2, :] if surrogate else ())):
        ax.set_xlabel("generation")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def _model_panels(axes, g: np.ndarray, h: Health) -> None:
    """The surrogate's row of the health figure: out-of-sample RMSE per objective, in standard deviations of
    the training values, against the line of a model that predicts their mean; the batch's failed share; the
    driver's seconds fitting the models and screening the candidates."""
    ax = axes[0]
    for k, (label, values) in enumerate(h.model_error.items()):
        ax.plot(g, [np.nan if v is None else 100 * v for v in values], "o-", ms=3, color=f"C{k}", label=label)
    ax.axhline(100, color="0.5", lw=0.8, ls="--", label="the training mean")
    ax.set_title("model error on the batch [% of spread]")
    ax.legend(fontsize=6)
    ax = axes[1]
    for k, (name, values) in enumerate(h.failures.items()):
        ax.plot(g, [np.nan if v is None else 100 * v for v in values], "o-" if name == "observed" else "x--", ms=3,
                color=f"C{k + 3}", label=name)
    ax.set_ylim(0, 100)
    ax.set_title("failed share of the batch [%]")
    ax.legend(fontsize=6)
    ax = axes[2]
    for k, (name, values) in enumerate(h.seconds.items()):
        ax.plot(g, [np.nan if v is None else v for v in values], "o-", ms=3, color=f"C{k + 5}", label=name)
    ax.set_ylim(bottom=0)
    ax.set_title("fit and screen per generation [s]")
    ax.legend(fontsize=6)


def _columns(ax, g: np.ndarray, values, bottom: np.ndarray | None = None, **style) -> None:
    """One column per generation ``g`` from ``bottom`` (0) up by ``values``, as a single filled step patch
    (a bar per generation and series costs a patch each: hundreds for a campaign's 50 generations × 8
    series, a fifth of the report's drawing time). A NaN value leaves its column empty."""
    if len(g) == 0:
        return
    edges = np.concatenate([[g[0] - 0.5], (g[1:] + g[:-1]) / 2.0, [g[-1] + 0.5]])
    base = np.zeros(len(g)) if bottom is None else np.asarray(bottom, float)
    ax.stairs(base + np.asarray(values, float), edges, baseline=base, fill=True, **style)


def fields_figure(chosen: list[tuple[Point, dict]], path: Path) -> Path:
    """One row per design of ``chosen`` (point, arrays of its fields file: :func:`optimizer.campaign.fields.
    read_fields`): the velocity magnitude |U|/C0 around the blade (the blade outline through its wall faces),
    C_p (axis reversed, suction peak up) and c_f along the suction and pressure sides, and the wall cells' y+,
    each against x/L from the leading edge."""
    n = max(len(chosen), 1)
    fig, axes = plt.subplots(n, 4, figsize=(12.5, 2.9 * n), squeeze=False,
                             gridspec_kw={"width_ratios": [1.6, 1, 1, 1]})
    for row, (p, data) in zip(axes, chosen, strict=False):
        _speed_panel(row[0], p, data)
        _wall_panels(row[1:], data)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def _speed_panel(ax, p: Point, data: dict) -> None:
    c0 = data["c0"] if np.isfinite(data["c0"]) else 1.0
    label = "|U|/C0 [-]" if np.isfinite(data["c0"]) else "|U| [m/s]"
    gx, gy = data["grid_x"] * 1e3, data["grid_y"] * 1e3
    image = ax.imshow(np.ma.masked_invalid(data["speed"] / c0), origin="lower", cmap="viridis",
                      extent=(gx[0], gx[-1], gy[0], gy[-1]), interpolation="nearest")
    ring = outline(SimpleNamespace(**data)) * 1e3
    ax.fill(ring[:, 0], ring[:, 1], color="0.85", zorder=2)
    ax.plot(*np.vstack([ring, ring[:1]]).T, "k-", lw=0.6, zorder=3)
    ax.set_aspect("equal")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(f"#{p.design.number}: |F_Y| {p.fy:.1f} N, C_max {p.cmax:.2f} m/s", fontsize=8)
    plt.colorbar(image, ax=ax, label=label, shrink=0.9)


def _wall_panels(axes, data: dict) -> None:
    side = data["side"]
    sides = [s for s in ("suction", "pressure") if np.any(side == s)]
    k = np.isin(side, sides)
    x0, x1 = float(data["x"][k].min()), float(data["x"][k].max())
    for ax, name, label in zip(axes, ("cp", "cf", "y_plus"), ("C_p [-]", "c_f [-]", "y+ of the wall cell [-]"),
                               strict=True):
        for j, s in enumerate(sides):
            m = np.flatnonzero(side == s)
            m = m[np.argsort(data["s"][m])]
            ax.plot((data["x"][m] - x0) / (x1 - x0), data[name][m], "-", color=f"C{j}", lw=0.9, label=s)
        ax.set_xlabel("x/L from the leading edge [-]")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        if name == "cp":
            ax.invert_yaxis()
            ax.legend(fontsize=7)
        if name == "y_plus" and not np.isfinite(data[name][k]).any():
            ax.text(0.5, 0.5, "not known", transform=ax.transAxes, ha="center", va="center")


def convergence_figure(curves: list[Convergence], path: Path) -> Path:
    """Hypervolume against CFD evaluations (left) and against CPU hours (right), one line per run."""
    fig, (left, right) = plt.subplots(1, 2, figsize=(9.6, 3.6), sharey=True)
    for k, c in enumerate(curves):
        label = f"{c.run.name} ({c.run.config.get('algorithm', {}).get('method', 'nsga2')})"
        # ten colours, then the same colours dashed, dotted...: no two of up to 40 runs look alike
        style = {"color": f"C{k % 10}", "ls": ("-", "--", ":", "-.")[k // 10 % 4], "lw": 1.2}
        left.plot(c.evaluations, c.hypervolume, label=label, **style)
        right.plot(c.cpu_hours, c.hypervolume, **style)
    left.set_xlabel("CFD evaluations (failed ones included)")
    right.set_xlabel("CPU hours of the evaluations")
    left.set_ylabel("hypervolume (normalised over the runs shown)")
    for ax in (left, right):
        ax.grid(alpha=0.3)
    if curves:
        left.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


# ------------------------------------------------------------------------------------------- paper study
LEVEL_STYLES = {"coarse": "--", "medium": "-", "fine": ":"}


def study_fronts_figure(fronts: list[tuple[str, tuple[str, str], str, list[Point]]], path: Path) -> Path:
    """Fig. 9: every paper run's front in the C_L–|C_p,min| plane, one colour per case
    (:func:`optimizer.report.study.case_colour`), circles for design and triangles for tool-path runs, the
    line style by mesh level; ``fronts`` from :func:`optimizer.report.study.fronts_by_case`."""
    from optimizer.report.study import case_colour

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for label, c, level, f in fronts:
        if not f:
            continue
        ax.plot([p.cpmin for p in f], [p.cl for p in f], LEVEL_STYLES.get(level, "-."), color=case_colour(c),
                marker="o" if c[0] == "design" else "^", ms=3.5, lw=1.1, label=f"{label}: {len(f)}")
    ax.set_xlabel(AXES["cpmin"])
    ax.set_ylabel(AXES["cl"])
    ax.grid(alpha=0.3)
    if any(f for *_, f in fronts):
        ax.legend(fontsize=7, loc="best", title="case (mesh level): front designs", title_fontsize=7)
    else:
        ax.text(0.5, 0.5, "no feasible design yet", transform=ax.transAxes, ha="center", va="center")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def study_pairs_figure(g1, walls: dict[str, dict | None], path: Path) -> Path:
    """Fig. 10–13: the G1 design and tool-path fronts in the C_L–|C_p,min| plane with the paired designs
    numbered (top); per pair, the design blade, the tool-path blade and both designs' C_p along the wall
    against x/L (axis reversed; "not kept" where the run kept no fields file). ``g1``:
    :class:`optimizer.report.study.G1Pairs`; ``walls``: {design key: arrays of its fields file or None}."""
    pairs = g1.pairs
    n = max(len(pairs), 1)
    fig = plt.figure(figsize=(max(2.3 * n, 7.0), 8.6))
    # the blades are drawn to scale: a 100 mm chord over a panel's width leaves them a short row
    grid = fig.add_gridspec(4, n, height_ratios=[1.5, 0.65, 0.65, 1])
    top = fig.add_subplot(grid[0, :])
    for run, f, colour, marker in ((g1.design, g1.design_front, "C0", "o"),
                                   (g1.toolpath, g1.toolpath_front, "C3", "^")):
        top.plot([p.cpmin for p in f], [p.cl for p in f], "-", color=colour, marker=marker, ms=3, lw=0.9,
                 label=f"{run.name}: front")
    for pair in pairs:
        # the design's number above left of its ring, the tool path's below right: the two fronts run close
        for p, colour, offset in ((pair.design, "C0", (-11, 4)), (pair.toolpath, "C3", (4, -11))):
            if p is not None:
                top.scatter([p.cpmin], [p.cl], s=70, facecolors="none", edgecolors=colour, linewidths=1.3, zorder=5)
                top.annotate(str(pair.index), (p.cpmin, p.cl), color=colour, fontsize=8, fontweight="bold",
                             xytext=offset, textcoords="offset points", zorder=6,
                             bbox={"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none", "alpha": 0.8})
    top.set_xlabel(AXES["cpmin"])
    top.set_ylabel(AXES["cl"])
    top.grid(alpha=0.3)
    top.legend(fontsize=7)
    for k, pair in enumerate(pairs):
        ax = fig.add_subplot(grid[1, k])
        blade_panel(ax, g1.design, pair.design, f"{pair.index}: design #{pair.design.design.number}")
        ax = fig.add_subplot(grid[2, k])
        if pair.toolpath is None:
            ax.set_axis_off()
            ax.text(0.5, 0.5, "no tool-path design left", ha="center", va="center", fontsize=7)
        else:
            blade_panel(ax, g1.toolpath, pair.toolpath, f"{pair.index}: tool path #{pair.toolpath.design.number}")
        _pair_cp_panel(fig.add_subplot(grid[3, k]), pair, walls)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def _pair_cp_panel(ax, pair, walls: dict[str, dict | None]) -> None:
    drawn = False
    for p, colour, name in ((pair.design, "C0", "design"), (pair.toolpath, "C3", "tool path")):
        data = walls.get(p.design.key) if p is not None else None
        if data is None:
            continue
        side = data["side"]
        k = np.isin(side, ("suction", "pressure"))
        x0, x1 = float(data["x"][k].min()), float(data["x"][k].max())
        for s, lw in (("suction", 1.0), ("pressure", 0.6)):
            m = np.flatnonzero(side == s)
            m = m[np.argsort(data["s"][m])]
            ax.plot((data["x"][m] - x0) / (x1 - x0), data["cp"][m], "-", color=colour, lw=lw,
                    label=name if s == "suction" else None)
        drawn = True
    ax.set_xlabel("x/L [-]", fontsize=7)
    ax.set_ylabel("C_p [-]", fontsize=7)
    ax.tick_params(labelsize=6)
    ax.grid(alpha=0.3)
    if drawn:
        ax.invert_yaxis()
        ax.legend(fontsize=6)
    else:
        ax.text(0.5, 0.5, "fields not kept", transform=ax.transAxes, ha="center", va="center", fontsize=7)
