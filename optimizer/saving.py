"""Writing one evaluation to a folder: everything needed to look at it again or to run it again.

A folder holds what exists of ``mesh.msh`` (gmsh 2.2), ``fields.vtu`` (cell fields), ``wall.csv``
(:meth:`~optimizer.evaluation.WallDistribution.to_csv`), ``result.json``
(:meth:`~optimizer.evaluation.Evaluation.to_json`, strict JSON) and the resolved ``config.yaml``
(:meth:`~optimizer.config.Config.to_yaml`; ``millfoil evaluate config.yaml`` runs it again).
"""

from __future__ import annotations

from pathlib import Path

from optimizer.config import Config
from optimizer.evaluation import Evaluation

#: The files of a saved evaluation, in the order they are written.
FILES = ("config.yaml", "mesh.msh", "fields.vtu", "wall.csv", "result.json")


def save(evaluation: Evaluation, config: Config, directory: str | Path) -> list[Path]:
    """Write what exists of :data:`FILES` for ``evaluation`` of ``config`` into ``directory`` (created);
    returns the paths written."""
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    built = evaluation.artifacts
    writers = {
        "config.yaml": lambda path: path.write_text(config.to_yaml()),
        "mesh.msh": None if built.mesh is None else built.mesh.write,
        "fields.vtu": None if built.flow is None else built.flow.write_vtu,
        "wall.csv": None if evaluation.wall is None else evaluation.wall.to_csv,
        "result.json": lambda path: path.write_text(evaluation.to_json(indent=2)),
    }
    written = []
    for name in FILES:
        if writers[name] is not None:
            writers[name](out / name)
            written.append(out / name)
    return written
