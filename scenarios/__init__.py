"""Runnable scenario scripts, installed as ``rvflex.scenarios``.

Computing is importable; plotting runs only under ``__main__``.
"""
