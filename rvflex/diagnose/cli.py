"""The diagnosis commands of ``rvflex`` (``rvflex diagnose``, ``rvflex selfcheck``)."""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction) -> None:
    """Add the diagnosis sub-commands to the ``rvflex`` parser."""
