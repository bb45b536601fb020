"""The fields a campaign keeps for the designs of its front: one small ``RUN/fields/<key>.npz`` per design.

The store (:mod:`optimizer.campaign.store`) keeps figures and monitors, not fields. For the report's
"flow fields of selected designs" (``docs/explanation/reports.md``) the worker writes, after a solved evaluation, a
compact file beside the store (:func:`write_fields`, called by :mod:`optimizer.campaign.record`), and the
driver removes, at the end of each generation, the files of stored designs that are no longer on the
front (:func:`prune_fields`). A 5 000-evaluation campaign so keeps about a population's worth of files
(about 150 KB each), not one per evaluation.

The worker learns where to write from its payload (``payload["fields"]``: the file's absolute path, which
the driver adds). With a cluster backend the run directory must therefore be on a file system shared by
the driver and the workers (as the scheduler's working directory usually is); where it is not, writing
fails, the evaluation still counts and its reason says that its fields were not kept.

A file holds (SI units, arrays ``float32`` except where said)::

    side            (n,) str: "suction", "pressure", "trailing_edge" (the wall distribution's faces,
                    ordered by side then arc length: :class:`optimizer.evaluation.WallDistribution`)
    s, x, y         (n,) arc length from the leading edge (from the suction-side corner on the trailing
                    edge) and face centres, m
    cp, cf, y_plus  (n,) pressure and skin-friction coefficients, y+ of the wall cell (NaN when unknown)
    speed           (ny, nx) velocity magnitude |U| at the grid points, m/s; NaN inside the blade
    grid_x, grid_y  (nx,), (ny,) grid coordinates, m (a regular grid 1.5 chords wide around the blade)
    c0              () inlet speed C0, m/s (for |U|/C0); NaN when unknown

Written whole or not at all (a temporary file renamed onto its name), so a reader never sees half a file.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

#: Directory of the fields files in the run directory.
FIELDS_DIR = "fields"
#: Grid points of the velocity-magnitude sample (x, y): about 1 mm spacing on a 0.1 m chord.
GRID = (200, 120)
#: Width of the sampled window in chords (the height follows from :data:`GRID` for square cells).
WINDOW_CHORDS = 1.5


def fields_path(run_directory: str | Path, key: str) -> Path:
    """The fields file of design ``key`` in ``run_directory``."""
    return Path(run_directory) / FIELDS_DIR / f"{key}.npz"


def with_fields(payload: dict, run_directory: str | Path, key: str) -> dict:
    """A blade ``payload`` with the absolute path of its fields file (``"fields"``), which the worker writes;
    other payloads (the analytic problems: no flow) unchanged."""
    if payload.get("kind") != "blade":
        return payload
    return {**payload, "fields": str(fields_path(Path(run_directory).absolute(), key))}


# --------------------------------------------------------------------------------------------- write
def outline(wall) -> np.ndarray:
    """The blade outline ``(n, 2)`` through the wall face centres, m: suction side from the leading edge,
    the trailing edge, the pressure side back to the leading edge."""
    parts = []
    for side, reverse in (("suction", False), ("pressure", True), ("trailing_edge", False)):
        k = np.flatnonzero(wall.side == side)
        k = k[np.argsort(wall.s[k])]
        parts.append((side, k[::-1] if reverse else k))
    order = np.concatenate([parts[0][1], parts[2][1], parts[1][1]])
    return np.column_stack([wall.x[order], wall.y[order]])


def grid(wall, shape: tuple[int, int] = GRID) -> tuple[np.ndarray, np.ndarray]:
    """Grid coordinates ``(x (nx,), y (ny,))``, m: :data:`WINDOW_CHORDS` chords wide, centred on the blade's
    bounding box, with square cells."""
    nx, ny = shape
    x0, x1 = float(wall.x.min()), float(wall.x.max())
    chord = x1 - x0
    width = WINDOW_CHORDS * chord
    height = width * (ny - 1) / (nx - 1)
    xc, yc = 0.5 * (x0 + x1), 0.5 * (float(wall.y.min()) + float(wall.y.max()))
    return (np.linspace(xc - width / 2, xc + width / 2, nx), np.linspace(yc - height / 2, yc + height / 2, ny))


def sample_speed(flow, wall, shape: tuple[int, int] = GRID) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(speed (ny, nx), x, y)``: |U| at the points of :func:`grid` by the solver's linear reconstruction
    (:meth:`solver.FlowResults.sample`), NaN inside the blade outline."""
    import shapely

    gx, gy = grid(wall, shape)
    X, Y = np.meshgrid(gx, gy)
    u = np.asarray(flow.sample(np.column_stack([X.ravel(), Y.ravel()]), "u"), float)
    speed = np.linalg.norm(u, axis=1)
    inside = shapely.contains_xy(shapely.Polygon(outline(wall)), X.ravel(), Y.ravel())
    speed[inside] = np.nan
    return speed.reshape(X.shape), gx, gy


def arrays(ev, c0: float | None = None, shape: tuple[int, int] = GRID) -> dict[str, np.ndarray]:
    """The arrays of a fields file (see the module docstring) of an evaluation with a wall distribution
    and flow results (``ev.wall``, ``ev.artifacts.flow``). Raises ValueError when either is missing."""
    wall, flow = ev.wall, getattr(ev.artifacts, "flow", None)
    if wall is None or flow is None:
        raise ValueError("the evaluation has no " + ("wall distribution" if wall is None else "flow results"))
    speed, gx, gy = sample_speed(flow, wall, shape)
    n = wall.s.size
    f32 = np.float32
    return {"side": np.asarray(wall.side).astype(str), "s": wall.s.astype(f32), "x": wall.x.astype(f32),
            "y": wall.y.astype(f32), "cp": wall.cp.astype(f32), "cf": wall.cf.astype(f32),
            "y_plus": (np.full(n, np.nan) if wall.y_plus is None else wall.y_plus).astype(f32),
            "speed": speed.astype(f32), "grid_x": gx, "grid_y": gy,
            "c0": np.float64(np.nan if c0 is None else c0)}


def save_arrays(data: dict[str, np.ndarray], path: str | Path) -> Path:
    """Write ``data`` as a compressed ``.npz`` at ``path``, whole or not at all
    (:func:`optimizer.saving.write_atomic`); the directory is created."""
    from optimizer.saving import write_atomic

    def write(temporary: Path) -> None:
        with open(temporary, "wb") as fh:       # a file object: numpy adds no ".npz" to the name
            np.savez_compressed(fh, **data)

    return write_atomic(path, write)


def write_fields(ev, path: str | Path, c0: float | None = None) -> Path:
    """Write the fields file of evaluation ``ev`` at ``path`` (see :func:`arrays`, :func:`save_arrays`)."""
    return save_arrays(arrays(ev, c0), path)


def read_fields(path: str | Path) -> dict[str, Any]:
    """The arrays of a fields file (``c0`` as a float)."""
    with np.load(path, allow_pickle=False) as data:
        out = {k: data[k] for k in data.files}
    out["c0"] = float(out["c0"])
    return out


# --------------------------------------------------------------------------------------------- prune
def prune_fields(store) -> list[Path]:
    """Remove the fields files of stored designs that are not on the store's front (:meth:`Store.front`);
    returns the files removed.

    Only designs the store holds are judged: a file whose design is not stored yet (its evaluation still
    running, or finished after the driver died and to be evaluated again on resume) stays until a later
    call knows it. Called by the driver after each generation is stored, when every result of the
    generation is in the store.
    """
    directory = Path(store.path).parent / FIELDS_DIR
    if not directory.is_dir():
        return []
    files = {p.stem: p for p in directory.glob("*.npz")}
    if not files:
        return []
    stored = store.get_many(files)
    keep = {r.key for r in store.front()}
    removed = []
    for key, p in files.items():
        if key in stored and key not in keep:
            p.unlink(missing_ok=True)
            removed.append(p)
    return removed
