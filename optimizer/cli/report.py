"""``millfoil report``: a campaign's report (static HTML, figures, tables) from its store."""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``millfoil report`` (to come)."""
