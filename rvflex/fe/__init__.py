"""FE-reduced flexible parts: netgen/OCC geometry, NGSolve elasticity, Craig–Bampton reduction, disk cache."""
