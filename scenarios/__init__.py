"""Runnable scenario scripts, installed as ``rvflex.scenarios``.

Computing is importable; plotting runs only under ``__main__``. Importing the package
registers the scenarios sweeps can run (:mod:`rvflex.scenarios.sweepable`).
"""

from rvflex.scenarios import sweepable  # noqa: F401 -- registers te and lost-motion with rvflex.sweeps
