"""The FE commands of ``rvflex`` (``rvflex reduce``)."""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction) -> None:
    """Add the FE sub-commands to the ``rvflex`` parser."""
