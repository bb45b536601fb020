#!/usr/bin/env bash
# Check that the dependency floors of pyproject.toml are versions the code runs on:
# install the LOWEST version every floor allows (uv's --resolution lowest-direct) into a fresh virtual
# environment and run the fast test tier there. A failure means a floor must be raised (or the code fixed);
# record a passing run in docs/dependencies.md.
#
#   scripts/check-lowest-deps.sh [VENV]        # default VENV: /tmp/lowest-venv (recreated)
#
# Needs uv (`pip install uv`) and network access to the package index. Extra arguments after VENV go to
# pytest (e.g. `scripts/check-lowest-deps.sh /tmp/v -x tests/solver`).
set -euo pipefail

venv="${1:-/tmp/lowest-venv}"
shift || true
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

command -v uv >/dev/null || { echo "check-lowest-deps: uv is needed: pip install uv" >&2; exit 2; }

rm -rf "$venv"
uv venv --quiet "$venv" --python 3.11
uv pip install --quiet --python "$venv/bin/python" --resolution lowest-direct -e ".[dev]"

echo "check-lowest-deps: installed (lowest allowed) versions:"
uv pip list --python "$venv/bin/python" 2>/dev/null \
    | grep -E -i '^(numpy|scipy|shapely|pydantic|pyyaml|matplotlib|gmsh|meshio|pyamg|threadpoolctl|dask|distributed|dask-jobqueue|ezdxf|pymoo|pytest|hypothesis) ' \
    | sed 's/^/  /'

"$venv/bin/python" -m pytest -m "not slow" -q -p no:cacheprovider "$@"
