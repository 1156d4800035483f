"""Part builders, one module per physical part (``build(mbs, spec, ...) -> Handles``).

Installed as ``rvflex.parts``. The builders arrive with the full reducer model; the
cycloid-stage geometry they use is in :mod:`rvflex.geometry`.
"""
