"""Figures of a blade: camber line, control polygons, cutter path and the blade, with edge close-ups."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; no display needed

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from geometry.parameters import Mode  # noqa: E402
from geometry.profile import Profile  # noqa: E402

_MM = 1e3


def plot_profile(profile: Profile, path: str | Path, title: str | None = None) -> None:
    """Save a PNG with the whole blade and close-ups of the leading and trailing edges (axes in mm)."""
    fig = plt.figure(figsize=(12, 7.5), layout="constrained")
    grid = fig.add_gridspec(2, 2, height_ratios=[1.6, 1])
    overview = fig.add_subplot(grid[0, :])
    leading = fig.add_subplot(grid[1, 0])
    trailing = fig.add_subplot(grid[1, 1])
    for ax in (overview, leading, trailing):
        _draw(ax, profile)
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
    _zoom(leading, profile.leading_edge, 8e-3, "leading edge")
    _zoom(trailing, 0.5 * (profile.points[profile.te_index] + profile.points[0]), 8e-3, "trailing edge")
    overview.legend(loc="upper left", fontsize=8)
    spec = profile.spec
    overview.set_title(title or f"{spec.continuity.value} {spec.mode.value} blade — area "
                       f"{profile.area * 1e6:.1f} mm², max thickness {profile.max_thickness * _MM:.2f} mm")
    fig.savefig(path, dpi=130)
    plt.close(fig)


def _draw(ax, profile: Profile) -> None:
    curves = profile.curves
    u = np.linspace(0.0, 1.0, 200)
    closed = np.vstack([profile.points, profile.points[:1]]) * _MM
    blade_label = "machined blade" if profile.mode is Mode.TOOLPATH else "blade"
    ax.fill(*closed.T, color="tab:blue", alpha=0.15, lw=0)
    ax.plot(*closed.T, color="tab:blue", lw=1.2, label=blade_label)
    ax.plot(*(curves.camber.points(u) * _MM).T, "k--", lw=0.8, label="camber line")
    ax.plot(*(curves.camber.control_points * _MM).T, "k:", marker="s", ms=3, lw=0.6, label="camber polygon")
    for name, colour in (("suction", "tab:red"), ("pressure", "tab:green")):
        cp = getattr(curves, name).control_points * _MM
        ax.plot(*cp.T, ":", color=colour, marker="o", ms=3, lw=0.7, label=f"{name} control polygon")
    if profile.tool_path is not None:
        path = np.vstack([profile.tool_path, profile.tool_path[:1]]) * _MM
        ax.plot(*path.T, color="tab:orange", lw=0.9, label=f"cutter path (R = {curves.radius * _MM:g} mm)")
    ax.plot(*(profile.leading_edge * _MM), "k+", ms=8)


def _zoom(ax, centre: np.ndarray, half_width: float, title: str) -> None:
    x, y = centre * _MM
    w = half_width * _MM
    ax.set_xlim(x - w, x + w)
    ax.set_ylim(y - 0.6 * w, y + 0.6 * w)
    ax.set_title(title, fontsize=9)
