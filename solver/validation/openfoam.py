"""OpenFOAM case files from millfoil's finite-volume mesh, a simpleFoam runner and readers of its output.

The peer of every side-by-side comparison (``bench/bench_openfoam.py``: blades; ``bench/bench_naca_openfoam.py``:
NACA 0012). Both codes solve on the very same cells because the ``polyMesh`` is written directly from the solver's
:class:`solver.fvmesh.FVMesh` (the 2D cells extruded by :data:`DEPTH` along z, front and back ``empty``).
OpenFOAM is Debian's ``openfoam`` package (v1912); its environment is sourced from :data:`BASHRC`.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import time
from pathlib import Path

import numpy as np

DEPTH = 0.01        # extrusion depth, m (forces are divided by it: per unit span)
HEADER = """FoamFile
{{
    version 2.0;
    format ascii;
    class {cls};
    location "{loc}";
    object {obj};
}}
"""
#: Debian's package needs its environment (WM_PROJECT_DIR, etc/controlDict) sourced before running a solver.
BASHRC = Path("/usr/share/openfoam/etc/bashrc")
ENV = f"source {BASHRC} >/dev/null 2>&1; " if BASHRC.exists() else ""


# --------------------------------------------------------------------------------------------- the mesh
def polymesh_arrays(mesh) -> dict:
    """The extruded mesh as OpenFOAM's arrays: ``points (2 np, 3)``, ``faces`` (list of node lists),
    ``owner``, ``neighbour`` and ``patches`` ``[(group, nFaces, startFace)]`` (without ``frontAndBack``,
    which follows with ``2 n_cells`` faces).

    Internal faces in upper-triangular order (owner < neighbour, sorted by owner then neighbour), each
    face's node order giving a normal from owner to neighbour (outward on boundaries); boundary faces per
    group in ``mesh.group_names`` order, each group in ``mesh.boundary[group]`` order (so face ``i`` of
    patch ``g`` is ``mesh.boundary[g][i]``); then the back (normal -z) and front (+z) face of every cell."""
    npts, ni = len(mesh.points), mesh.n_internal
    pts = np.vstack([np.column_stack([mesh.points, np.zeros(npts)]),
                     np.column_stack([mesh.points, np.full(npts, DEPTH)])])
    owner, neigh, faces = mesh.owner.copy(), mesh.neighbour.copy(), mesh.faces.copy()
    swap = np.zeros(len(faces), bool)
    swap[:ni] = owner[:ni] > neigh[:ni]
    owner[:ni][swap[:ni]], neigh[:ni][swap[:ni]] = mesh.neighbour[:ni][swap[:ni]], mesh.owner[:ni][swap[:ni]]
    sf = np.where(swap[:, None], -mesh.sf, mesh.sf)
    edge = mesh.points[faces[:, 1]] - mesh.points[faces[:, 0]]
    flip = edge[:, 1] * sf[:, 0] - edge[:, 0] * sf[:, 1] < 0      # quad (a, b, b', a') has normal (e_y, -e_x)
    faces[flip] = faces[flip][:, ::-1]
    order = np.lexsort((neigh[:ni], owner[:ni]))
    side = np.column_stack([faces[:, 0], faces[:, 1], faces[:, 1] + npts, faces[:, 0] + npts])
    bface = np.concatenate([mesh.boundary[g] for g in mesh.group_names])
    quads = [list(map(int, q)) for q in side[order]] + [list(map(int, q)) for q in side[bface]]
    own = list(owner[:ni][order]) + list(owner[bface])
    cells = np.concatenate([np.pad(c, ((0, 0), (0, 4 - c.shape[1])), constant_values=-1)
                            for c in mesh.cells.values()])
    for c, nodes in enumerate(cells):
        nodes = [int(v) for v in nodes if v >= 0]
        xy = mesh.points[nodes]
        if np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1]) < 0:
            nodes = nodes[::-1]
        quads.append(nodes[::-1])                          # back, normal -z
        quads.append([v + npts for v in nodes])            # front, normal +z
        own += [c, c]
    patches, start = [], ni
    for g in mesh.group_names:
        patches.append((g, len(mesh.boundary[g]), start))
        start += len(mesh.boundary[g])
    return {"points": pts, "faces": quads, "owner": np.array(own), "neighbour": neigh[:ni][order],
            "patches": patches}


def write_polymesh(mesh, directory: Path, types: dict[str, str] | None = None) -> None:
    """``constant/polyMesh`` of the 2D finite-volume mesh ``mesh`` extruded by :data:`DEPTH` along z
    (:func:`polymesh_arrays`); ``types`` maps a boundary group to its patch type (``wall``, ``symmetry``,
    ...; default ``patch``); the front and back faces form the patch ``frontAndBack`` (type ``empty``)."""
    types = types or {}
    poly = directory / "constant" / "polyMesh"
    poly.mkdir(parents=True, exist_ok=True)
    a = polymesh_arrays(mesh)
    pts, quads, own, nei = a["points"], a["faces"], a["owner"], a["neighbour"]
    note = (f'note "nPoints: {len(pts)} nCells: {mesh.n_cells} nFaces: {len(quads)} '
            f'nInternalFaces: {mesh.n_internal}";')

    def write(name, cls, body):
        head = HEADER.format(cls=cls, loc="constant/polyMesh", obj=name)
        if name == "owner":
            head = head.replace("object owner;", f"object owner;\n    {note}")
        (poly / name).write_text(head + body)

    write("points", "vectorField", f"{len(pts)}\n(\n" + "".join(f"({x:.12g} {y:.12g} {z:.12g})\n" for x, y, z in pts)
          + ")\n")
    write("faces", "faceList", f"{len(quads)}\n(\n" + "".join(f"{len(q)}({' '.join(map(str, q))})\n" for q in quads)
          + ")\n")
    write("owner", "labelList", f"{len(own)}\n(\n" + "\n".join(map(str, own)) + "\n)\n")
    write("neighbour", "labelList", f"{len(nei)}\n(\n" + "\n".join(map(str, nei)) + "\n)\n")
    entries = [f"    {g}\n    {{\n        type {types.get(g, 'patch')};\n        nFaces {n};\n"
               f"        startFace {start};\n    }}\n" for g, n, start in a["patches"]]
    start = a["patches"][-1][2] + a["patches"][-1][1]
    entries.append(f"    frontAndBack\n    {{\n        type empty;\n        nFaces {2 * mesh.n_cells};\n"
                   f"        startFace {start};\n    }}\n")
    write("boundary", "polyBoundaryMesh", f"{len(entries)}\n(\n" + "".join(entries) + ")\n")


# --------------------------------------------------------------------------------------------- the case
def control_head(iterations: int, extra: str = "") -> str:
    """The head of a steady ``system/controlDict``: simpleFoam for ``iterations`` iterations, the fields
    written once at the end (``extra``: more entries before ``runTimeModifiable``)."""
    return f"""application simpleFoam;
startFrom startTime;
startTime 0;
stopAt endTime;
endTime {iterations};
deltaT 1;
writeControl timeStep;
writeInterval {iterations};
writeFormat ascii;
{extra}runTimeModifiable false;
"""


def write_file(directory: Path, rel: str, cls: str, body: str) -> None:
    """One case file ``directory/rel`` (``"system/fvSchemes"``) with its FoamFile header."""
    path = directory / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(HEADER.format(cls=cls, loc=str(Path(rel).parent), obj=Path(rel).name) + body)


def field_body(dims: str, internal: str, patches: dict[str, str], tail: str = "") -> str:
    """Body of a ``0/`` field file: ``internalField uniform internal`` and one entry per patch (its
    specification, e.g. ``"type fixedValue; value uniform 0;"``); ``frontAndBack`` is ``empty``; ``tail``
    is added inside ``boundaryField`` (e.g. a regular-expression entry)."""
    body = f"dimensions {dims};\ninternalField uniform {internal};\nboundaryField\n{{\n"
    for patch, spec in patches.items():
        body += f"    {patch}\n    {{\n        {spec}\n    }}\n"
    return body + "    frontAndBack { type empty; }\n" + tail + "}\n"


def nonuniform_vectors(values: np.ndarray) -> str:
    """``nonuniform List<vector> n (...)`` of 2D vectors ``(n, 2)`` (z component 0)."""
    rows = "\n".join(f"({x:.12g} {y:.12g} 0)" for x, y in np.asarray(values, float))
    return f"nonuniform List<vector> {len(values)}\n(\n{rows}\n)"


# ------------------------------------------------------------------------------------------------ running
def ensure_openfoam(install: bool) -> str | None:
    """None when ``simpleFoam`` runs, else why not (after trying ``apt-get install -y openfoam``)."""
    if shutil.which("simpleFoam"):
        return None
    if not install:
        return "simpleFoam not found (--no-install)"
    try:
        subprocess.run(["apt-get", "install", "-y", "-q", "openfoam"], check=True, capture_output=True, timeout=1800)
    except (OSError, subprocess.SubprocessError) as exc:
        return f"apt-get install openfoam failed: {exc}"
    return None if shutil.which("simpleFoam") else "simpleFoam still missing after apt-get install openfoam"


def run_utility(directory: Path, command: str, log_name: str | None = None) -> tuple[int, float]:
    """Run an OpenFOAM command (``"simpleFoam"``, ``"checkMesh"``) on the case ``directory`` with its
    environment; output to ``directory/log.<name>``; returns (exit status, wall seconds)."""
    name = log_name or command.split()[0]
    t0 = time.perf_counter()
    with open(directory / f"log.{name}", "w") as log:
        rc = subprocess.run(["bash", "-c", f'{ENV}{command} -case "{directory}"'], stdout=log,
                            stderr=subprocess.STDOUT, check=False).returncode
    return rc, time.perf_counter() - t0


def execution_times(log_text: str) -> np.ndarray:
    """Cumulative CPU seconds per iteration (``ExecutionTime = ... s``) of a solver log."""
    return np.array([float(t) for t in re.findall(r"ExecutionTime = ([0-9.eE+-]+) s", log_text)])


# ------------------------------------------------------------------------------------------------ reading
def read_dat(path: Path) -> np.ndarray:
    """Numbers of a function-object ``.dat`` file (``#`` lines skipped, parentheses dropped), one row a line."""
    rows = [ln.replace("(", " ").replace(")", " ").split() for ln in path.read_text().splitlines()
            if ln.strip() and not ln.startswith("#")]
    return np.array([[float(v) for v in r] for r in rows])


def latest_time(directory: Path) -> Path | None:
    """The latest time directory (largest number, not ``0``) of a case, or None."""
    times = [p for p in directory.iterdir() if p.is_dir() and re.fullmatch(r"[0-9.eE+-]+", p.name)]
    times = [p for p in times if float(p.name) > 0]
    return max(times, key=lambda p: float(p.name)) if times else None


def _parse_list(text: str, start: int, n_comp: int) -> np.ndarray:
    """The ``n ( ... )`` list that follows position ``start`` of ``text``, ``(n,)`` or ``(n, n_comp)``."""
    m = re.compile(r"\s*(\d+)\s*\(").match(text, start)
    n = int(m.group(1))
    if n == 0:
        return np.zeros((0, n_comp) if n_comp > 1 else 0)
    # a long list is written one entry a line and closed by "\n)"; a short one inline, "3((0 0 0) ...)"
    end = text.index("\n)" if text[m.end()] == "\n" else ("))" if n_comp > 1 else ")"), m.end())
    values = np.array(text[m.end():end].replace("(", " ").replace(")", " ").split(), float)
    return values.reshape(n, n_comp) if n_comp > 1 else values.reshape(n)


def read_field(path: Path, n_cells: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """An ASCII ``volScalarField`` or ``volVectorField`` file: the internal field ``(n_cells,)`` or
    ``(n_cells, 3)`` and ``{patch: values}`` of the patches that write a ``value`` list or uniform value
    (sized by the list; a uniform patch value is returned as a single row)."""
    text = path.read_text()
    nc = 3 if re.search(r"^\s*class\s+volVectorField;", text, re.M) else 1
    internal = _entry_values(text, text.index("internalField"), nc, n_cells)
    patches = {}
    body = text[text.index("{", text.index("boundaryField")) + 1:]
    for m in re.finditer(r"^\s*([\w\"().|]+)\s*\{([^{}]*)\}", body, re.M):
        block = m.group(2)
        v = block.find("value")
        if v >= 0:
            patches[m.group(1)] = _entry_values(block, v, nc, None)
    return internal, patches


def _entry_values(text: str, at: int, nc: int, n: int | None) -> np.ndarray:
    """Values of the entry (``internalField``/``value``) at ``at``: ``uniform x`` or ``nonuniform List<...>``."""
    m = re.compile(r"\w+\s+(uniform|nonuniform)\s*(List<\w+>)?").match(text, at)
    if m.group(1) == "nonuniform":
        return _parse_list(text, m.end(), nc)
    rest = text[m.end():text.index(";", m.end())]
    v = np.array(rest.replace("(", " ").replace(")", " ").split(), float)
    return np.tile(v, (n or 1, 1)) if nc > 1 else np.full(n or 1, float(v[0]))


def face_order(mesh) -> tuple[np.ndarray, np.ndarray]:
    """``(faces, sign)``: OpenFOAM face ``j`` (internal faces, then the patches in group order, without
    ``frontAndBack``) is millfoil face ``faces[j]``, its area vector ``sign[j]`` times millfoil's (-1 where
    :func:`polymesh_arrays` swapped owner and neighbour to get owner < neighbour)."""
    ni = mesh.n_internal
    o, n = mesh.owner[:ni], mesh.neighbour[:ni]
    swap = o > n
    order = np.lexsort((np.where(swap, o, n), np.where(swap, n, o)))
    bface = np.concatenate([mesh.boundary[g] for g in mesh.group_names])
    return np.concatenate([order, bface]), np.concatenate([np.where(swap[order], -1.0, 1.0), np.ones(len(bface))])


def read_face_flux(path: Path, mesh, rho: float = 1.0) -> np.ndarray:
    """An ASCII ``surfaceScalarField`` ``phi`` (volumetric flux through the extruded faces, m³/s) as
    millfoil's face mass flux ``(nf,)`` per unit depth, kg/(s m), owner -> neighbour in millfoil's face
    order (:func:`face_order`); patches without a ``value`` list (``empty``) are skipped."""
    text = path.read_text()
    faces, sign = face_order(mesh)
    phi = np.zeros(len(mesh.owner))
    ni = mesh.n_internal
    phi[faces[:ni]] = sign[:ni] * _entry_values(text, text.index("internalField"), 1, ni)
    body = text[text.index("{", text.index("boundaryField")) + 1:]
    blocks = {m.group(1): m.group(2) for m in re.finditer(r"^\s*([\w\"().|]+)\s*\{([^{}]*)\}", body, re.M)}
    for g in mesh.group_names:
        block = blocks.get(g, "")
        v = block.find("value")
        if v >= 0:
            phi[mesh.boundary[g]] = _entry_values(block, v, 1, len(mesh.boundary[g]))
    return rho * phi / DEPTH


def openfoam_state(directory: Path, problem):
    """A :class:`solver.FlowState` of ``problem`` (same mesh as the case) from the latest written time of a
    finished ``simpleFoam`` ``kOmegaSST`` case: U, p (kinematic, times rho: already the modified pressure
    ``p + 2/3 rho k`` that millfoil's holds, since OpenFOAM's ``divDevReff`` leaves the ``2/3 k`` part of the
    Reynolds stress out of the momentum equation; constant across the boundary layer in both codes'
    fields, docs/explanation/validation.md), the face mass flux (:func:`read_face_flux`), k,
    omega, nut; the gradients are the least-squares ones of these fields and the wall viscosity the molecular one
    (``low_re``). The restart test of docs/decisions/0007-limiter-iterations.md: millfoil
    started from OpenFOAM's converged solution."""
    from solver.gradient import ls_gradient
    from solver.problem import FlowState

    m, b, rho = problem.mesh, problem.bnd, problem.fluid.rho
    last = latest_time(directory)
    if last is None:
        raise FileNotFoundError(f"no written time in {directory}")
    nc = m.n_cells
    u = read_field(last / "U", nc)[0][:, :2].copy()
    k, omega, nut = (read_field(last / name, nc)[0] for name in ("k", "omega", "nut"))
    p = rho * read_field(last / "p", nc)[0]
    grad_u = ls_gradient(m, u, b.velocity(m, u, np.zeros((nc, 2, 2))))
    grad_u = ls_gradient(m, u, b.velocity(m, u, grad_u))
    grad_p = ls_gradient(m, p, b.pressure(m, p, np.zeros((nc, 2))))
    setup = problem.turbulence_setup
    mu_wall = None if setup is None else np.full(len(setup.wall_local), problem.fluid.mu)
    return FlowState(u, p, read_face_flux(last / "phi", m, rho), grad_p, grad_u, k, omega, nut, mu_wall)
