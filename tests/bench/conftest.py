"""The bench scripts are scripts, not a package: their tests import them from bench/ (put on the path here, for
the tests of this folder only)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parents[2] / "bench"))
