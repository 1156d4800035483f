"""
A tolerance sweep: which deviation moves TE most
================================================

The repository's smoke design (``scenarios/designs/smoke.toml``, shipped as
``rvflex.scenarios``' package data): three factors of the rigid RV-40E at two levels each, one
at a time, quasi-static loaded TE at 412 N·m over a quarter output revolution at coarse
resolution. The sweep runs serially here; with ``store=`` it keeps every finished point in
SQLite, so a rerun resumes. ``rvflex sweep`` runs the same design from the command line.
"""

from importlib import resources

import matplotlib.pyplot as plt

import rvflex
from rvflex.sweeps import classify, range_table

design = rvflex.load_design(resources.files("rvflex.scenarios") / "designs" / "smoke.toml")
result = rvflex.sweep(design, executor="serial")  # store="smoke.sqlite" would keep the points to resume
table = result.to_dataframe()
factors = [f.name for f in design.factors]
shown = table[factors + ["te_pp_arcsec"]].copy()
shown[factors] *= 1e6  # the deviations in µm (the design and the table hold metres)
print(shown.round(3))

# %%
# The range of the level means per factor (seed 004's range analysis) and the split into
# sensitive and insensitive factors.
ranking = range_table(design, result.rows, "te_pp_arcsec")
classes = classify(ranking)
fig, ax = plt.subplots(figsize=(6, 3), layout="constrained")
ax.barh([r["factor"] for r in ranking], [r["range"] for r in ranking],
        color=["C3" if classes[r["factor"]] == "sensitive" else "C0" for r in ranking])
ax.set_xlabel("range of the level means of TE peak-to-peak (arcsec)")
ax.set_title("smoke design: red = sensitive")
