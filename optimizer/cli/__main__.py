"""``python -m optimizer.cli``: the same as the ``millfoil`` command."""

import sys

from optimizer.cli import main

sys.exit(main())
